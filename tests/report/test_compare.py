"""fogbench compare: its intervals, ranks and flags against values worked out by hand from the
replicates written into run directories; foreign outputs refused and left as they were."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import stats as sst

from fogbench.report.compare import collect

from helpers import run_cli


def _run_dir(root, name, series, claims=None, in_sample=False):
    d = root / name
    d.mkdir(parents=True)
    doc = {"scenario": name, "protocols": {"p": {"in_sample": in_sample}},
           "montecarlo": {"series": {"p": series}, "claims": claims or []}}
    (d / "metrics.json").write_text(json.dumps(doc))
    return d


def test_rows_against_hand_computed_intervals_and_ranks(tmp_path):
    a = [10.0, 20.0, 30.0, 40.0]
    b = [15.0, 10.0, 35.0, None]          # one failed replicate
    _run_dir(tmp_path / "rep", "s1", {"improvement_rmse_pct": {
        "raw": [0, 0, 0, 0], "oracle": [50.0, 50.0, 50.0, 50.0], "a": a, "b": b}})
    _run_dir(tmp_path / "rep", "s2", {"bias_stability_100s_dph": {
        "raw": [1.0, 1.0, 1.0], "a": [0.5, 0.2, 0.3], "b": [0.4, 0.3, 0.1]},
        "improvement_rmse_pct": {"a": [1.0, 2.0, 3.0]}},
        claims=[{"metric": "bias_stability_100s_dph"}], in_sample=True)
    rows = {(r["scenario"], r["method"]): r for r in collect([tmp_path / "rep"])}
    ra = rows[("s1", "a")]
    half = sst.t.ppf(0.975, 3) * np.std(a, ddof=1) / math.sqrt(4)
    assert ra["value"]["mean"] == pytest.approx(25.0)
    assert ra["value"]["ci_low"] == pytest.approx(25.0 - half)
    assert ra["value"]["ci_high"] == pytest.approx(25.0 + half)
    assert ra["oracle"]["mean"] == pytest.approx(50.0) and ra["failed"] == 0
    # ranks by replicate (higher is better): a 2,1,2,1 ; b 1,2,1,2 (failed last): both 50 %
    assert (ra["rank"], ra["rank_probability"]) == (1, 0.5)
    rb = rows[("s1", "b")]
    assert rb["failed"] == 1 and rb["value"]["mean"] == pytest.approx(20.0)
    # the headline of s2 is its claim's metric (lower is better there), flagged in-sample
    r2a, r2b = rows[("s2", "a")], rows[("s2", "b")]
    assert "bias_stability_100s_dph" in r2a["metric"] and r2a["in_sample"]
    # shown as its improvement over raw (1.0): 50, 80, 70 %
    assert r2a["value"]["mean"] == pytest.approx((50 + 80 + 70) / 3)
    # a: 0.5 > 0.4 (2nd), 0.2 < 0.3 (1st), 0.3 > 0.1 (2nd): rank 2 in 2 of 3
    assert (r2a["rank"], r2a["rank_probability"]) == (2, pytest.approx(2 / 3))
    assert (r2b["rank"], r2b["rank_probability"]) == (1, pytest.approx(2 / 3))


def test_compare_cli_writes_its_three_files_and_refuses_foreign_ones(tmp_path):
    _run_dir(tmp_path / "rep", "s1", {"improvement_rmse_pct": {
        "raw": [0, 0], "a": [10.0, 12.0], "b": [5.0, 6.0]}})
    code, out, err = run_cli("compare", tmp_path / "rep")
    assert code == 0, err
    md = (tmp_path / "rep" / "compare.md").read_text()
    assert "| s1 | p | improvement_rmse_pct | a | 11 [" in md
    assert json.loads((tmp_path / "rep" / "compare.json").read_text())["format"] == \
        "fogbench-compare"
    code, _, err = run_cli("compare", tmp_path / "rep")          # its own: replaced
    assert code == 0, err
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "compare.md").write_text("my notes\n")
    code, _, err = run_cli("compare", tmp_path / "rep", "--out", mine)
    assert code == 2 and "not written by fogbench compare" in err
    assert (mine / "compare.md").read_text() == "my notes\n"
    assert sorted(p.name for p in mine.iterdir()) == ["compare.md"]
    code, _, err = run_cli("compare", tmp_path / "nothing_here")
    assert code == 2 and "no such run directory" in err


def test_the_figure_leaves_ideal_twins_to_the_table_and_draws_a_sweep_as_one_row(tmp_path):
    """compare.png was 3182 px tall: every ideal-lab twin again and paper000's 8 wavelet_band
    settings a row each. The table keeps every row; the figure draws the lab protocol only and
    a sweep as its paper setting's row with its settings' range (min, max of their means)."""
    from fogbench.report.compare import _figure_rows

    d = tmp_path / "s"
    d.mkdir()
    series = {"improvement_rmse_pct": {"raw": [0, 0, 0], "k": [1.0, 2.0, 3.0],
                                       "w.a": [5.0, 6.0, 7.0], "w.b": [9.0, 9.0, 9.0],
                                       "w.c": [-1.0, 0.0, 1.0]}}
    doc = {"scenario": "s",
           "protocols": {"p": {"in_sample": False},
                         "p.ideal": {"in_sample": False, "ideal_of": "p"}},
           "methods": {"k": {"method": "kalman", "group": None, "paper_setting": False},
                       **{f"w.{x}": {"method": "wavelet_soft", "group": "w",
                                     "paper_setting": x == "b"} for x in "abc"}},
           "montecarlo": {"series": {"p": series, "p.ideal": series}, "claims": []}}
    (d / "metrics.json").write_text(json.dumps(doc))
    rows = collect([d])
    assert len(rows) == 8                                # the table: 4 methods x 2 protocols
    fig_rows = _figure_rows(rows)
    assert [(r["protocol"], r["method"]) for r in fig_rows] == [
        ("p", "k"), ("p", "w (3 settings)")]
    sweep = fig_rows[1]
    assert sweep["value"]["mean"] == pytest.approx(9.0)  # the paper setting w.b's
    assert sweep["sweep"] == (pytest.approx(0.0), pytest.approx(9.0))


def test_each_protocol_s_first_row_names_its_metric_in_the_figure(tmp_path, monkeypatch):
    """compare.png put scenarios ranked on different headline metrics on one axis labelled
    "headline metric" alone (lab_references' 64.7 % is of the RMSE, its report's 97.2 % of the
    dwell means): the first row of each protocol names its metric."""
    from fogbench.report import compare as C
    from fogbench.outputs import files as IO

    kept = []
    monkeypatch.setattr(IO, "save_figure", lambda fig, path: kept.append(fig))
    rows = []
    for scen, metric in (("a", "improvement_rmse_pct"),
                         ("b", "improvement of std_dps over raw, %")):
        for m in ("k", "w"):
            rows.append({"scenario": scen, "protocol": "p", "method": m, "metric": metric,
                         "value": {"mean": 5.0, "ci_low": 4.0, "ci_high": 6.0},
                         "in_sample": False, "failed": 0})
    C._figure(rows, str(tmp_path / "c.png"))
    labels = [t.get_text() for t in kept[0].axes[0].get_yticklabels()]
    assert labels == ["a / p [rmse]: k", "w", "b / p [std_dps]: k", "w"]
    assert "metric in [ ]" in kept[0].axes[0].get_xlabel()


def _listing(d):
    return sorted(str(q.relative_to(d)) for q in d.rglob("*"))


@pytest.mark.parametrize("edit, words", [
    (lambda doc: [doc], "expected a JSON object"),
    (lambda doc: {**doc, "montecarlo": {"series": [1, 2]}}, "key 'montecarlo.series': expected a"),
    (lambda doc: {**doc, "protocols": {"p": 3}}, "key 'protocols': expected a table"),
    (lambda doc: {**doc, "montecarlo": {"series": {"p": {"improvement_rmse_pct": {
        "raw": [0, 0], "a": [1.0, "abc"]}}}}}, "['a']: expected a list of numbers"),
    (lambda doc: {**doc, "montecarlo": {"series": {"p": {"improvement_rmse_pct": {
        "raw": [0, 0, 0], "a": [1.0]}}}}}, "ragged"),
])
def test_a_damaged_metrics_json_is_refused_naming_the_file_and_key(tmp_path, edit, words):
    d = _run_dir(tmp_path / "rep", "s1", {"improvement_rmse_pct": {
        "raw": [0, 0], "a": [10.0, 12.0]}})
    doc = json.loads((d / "metrics.json").read_text())
    (d / "metrics.json").write_text(json.dumps(edit(doc)))
    before = _listing(tmp_path)
    code, _, err = run_cli("compare", d, "--out", tmp_path / "cmp")
    assert code == 2, err
    line = err.strip().splitlines()[-1]
    assert line.startswith(f"fogbench: error: {d / 'metrics.json'}") and words in line, line
    assert _listing(tmp_path) == before            # no traceback, nothing written


def test_the_same_run_twice_or_a_copy_of_it_is_refused(tmp_path):
    d = _run_dir(tmp_path / "rep", "s1", {"improvement_rmse_pct": {
        "raw": [0, 0], "a": [10.0, 12.0]}})
    code, _, err = run_cli("compare", d, d, "--out", tmp_path / "cmp")
    assert code == 2 and "given twice" in err
    import shutil

    shutil.copytree(d, tmp_path / "rep" / "copy")
    code, _, err = run_cli("compare", d, tmp_path / "rep" / "copy", "--out", tmp_path / "cmp")
    assert code == 2 and "the same run as" in err
    assert not (tmp_path / "cmp").exists()


def test_a_failed_write_leaves_no_output_folder(tmp_path, monkeypatch):
    _run_dir(tmp_path / "rep", "s1", {"improvement_rmse_pct": {
        "raw": [0, 0], "a": [10.0, 12.0]}})
    from fogbench.report import compare as C

    def no_space(rows, path):
        raise OSError(28, "No space left on device", path)

    monkeypatch.setattr(C, "_figure", no_space)
    code, _, err = run_cli("compare", tmp_path / "rep" / "s1", "--out", tmp_path / "new" / "cmp")
    assert code == 1 and "No space left on device" in err
    assert not (tmp_path / "new").exists()


def test_a_metrics_json_edited_after_it_was_written_is_named(tmp_path):
    """A run directory's metrics.json carries its own checksum (written by the writer every
    run uses): compared as written it is taken without a word; one value edited x100 is
    refused naming the file; one without a checksum (an older run) is compared with a
    warning."""
    from fogbench.run.runner import write_metrics

    d = tmp_path / "rep" / "s1"
    d.mkdir(parents=True)
    doc = {"scenario": "s1", "protocols": {"p": {"in_sample": False}},
           "montecarlo": {"series": {"p": {"improvement_rmse_pct": {
               "raw": [0.0, 0.0], "a": [10.0, 12.0], "b": [float("nan"), 3.5]}}},
               "claims": []}}
    write_metrics(d / "metrics.json", doc)
    code, _, err = run_cli("compare", d, "--out", tmp_path / "ok")
    assert code == 0 and "warning" not in err, err
    text = (d / "metrics.json").read_text()
    assert '"sha256"' in text and "12.0" in text
    (d / "metrics.json").write_text(text.replace("12.0", "1200.0"))
    before = _listing(tmp_path)
    code, _, err = run_cli("compare", d, "--out", tmp_path / "cmp")
    line = err.strip().splitlines()[-1]
    assert code == 2 and line.startswith(f"fogbench: error: {d / 'metrics.json'}"), err
    assert "does not match its checksum" in line
    assert _listing(tmp_path) == before
    edited = json.loads(text)
    del edited["sha256"]
    (d / "metrics.json").write_text(json.dumps(edited))
    code, _, err = run_cli("compare", d, "--out", tmp_path / "old")
    assert code == 0 and "no checksum (key 'sha256'" in err, err
