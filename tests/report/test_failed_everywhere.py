"""A method that fails in every replicate stays visible: metrics.json's montecarlo keeps it
(its summaries n = 0, its series all null, its first error), report.md lists it in "In short"
and the Monte Carlo tables as "failed in R of R: <first error>", and `fogbench compare` ranks
it last (the other method "1 of 2", not "1 of 1") with failed = R, in compare.md, compare.json
and compare.png. It disappeared from all of them before (only the single-replicate tables of
replicate 0 named it)."""

from __future__ import annotations

import json

from helpers import SMALL_SCENARIO, run_cli

ERROR = "RuntimeError: planted failure in fit"
FAILED = f"failed in 3 of 3: {ERROR}"


#: SMALL_SCENARIO with a third power-on scored beside b (so that runs.png is drawn) and a
#: plug-in that raises in every fit
SCENARIO = SMALL_SCENARIO.replace('score = ["b"]', 'score = ["b", "c"]').replace(
    "[[protocols]]", '[[runs]]\nname = "c"\nseed = 3\n[[runs.motion]]\ntype = "hold"\n'
    'duration_s = 30.0\n\n[[protocols]]') + '\n[[methods]]\nname = "plugin_methods:Raises"\n'


def _suite(tmp_path, monkeypatch):
    """``fogbench suite`` of the one scenario (3 replicates): (exit status, stderr, the texts
    of every figure drawn: axes texts, tick labels, legends)."""
    from fogbench.outputs import files as IO

    texts = []
    save = IO.save_figure

    def keep(fig, path):
        texts.append(" | ".join(t.get_text() for ax in fig.axes for t in [
            *ax.texts, *ax.get_xticklabels(), *ax.get_yticklabels(),
            *(ax.get_legend().get_texts() if ax.get_legend() else [])]))
        return save(fig, path)

    monkeypatch.setattr(IO, "save_figure", keep)
    (tmp_path / "scn").mkdir()
    (tmp_path / "scn" / "tiny.toml").write_text(SCENARIO)
    code, _, err = run_cli("suite", "--scenarios", tmp_path / "scn", "--out", tmp_path / "rep",
                           "--replicates", "3", "--jobs", "1", "--no-recording", "--quiet",
                           "--no-map")
    return code, err, texts


def _table_after(lines: list[str], heading: str) -> list[str]:
    i = lines.index(heading)
    rows = []
    for ln in lines[i + 1:]:
        if ln.startswith("|"):
            rows.append(ln)
        elif rows:
            break
    return rows


def test_a_method_failing_in_every_replicate_is_listed_last_everywhere(tmp_path, monkeypatch):
    code, err, figures = _suite(tmp_path, monkeypatch)
    assert code == 0, err
    doc = json.loads((tmp_path / "rep" / "tiny" / "metrics.json").read_text())
    mc = doc["montecarlo"]
    assert mc["failed_methods"]["p"]["Raises"] == {
        "failed": 3, "replicates": 3, "first_error": ERROR, "first_replicate": 0}
    assert "wavelet_soft" not in mc["failed_methods"].get("p", {})
    assert mc["series"]["p"]["rmse_dph"]["Raises"] == [None, None, None]
    sm = mc["over_runs"]["p"]["Raises"]["rmse_dph"]
    assert (sm["n"], sm["n_failed"], sm["mean"]) == (0, 3, None)

    lines = (tmp_path / "rep" / "tiny" / "report.md").read_text().splitlines()
    short = next(ln for ln in lines if ln.startswith("- `p`, rmse_dph:"))
    assert short.index("wavelet_soft") < short.index(f"failed: Raises ({FAILED})"), short
    for prot in ("p", "p.ideal"):
        rows = _table_after(lines, f"### `{prot}`: mean over scored runs, over replicates")
        assert rows[-1] == f"| Raises | {FAILED} | – | – | – | – |", rows
        assert rows[-2].startswith("| wavelet_soft | "), rows
    cost = _table_after(lines, "### What the lab's references cost")
    assert cost[-1] == f"| `p` | Raises | – | {FAILED} | {FAILED} | – | – |", cost

    # replicates.png: an empty column saying so; runs.png: named last in the legend
    assert any("Raises" in t and "failed in 3 of 3" in t and "wavelet_soft" in t
               for t in figures), figures
    assert any(t.endswith("wavelet_soft | Raises: failed in 3 of 3") for t in figures), figures

    # the suite's summary: the same row, last
    summary = (tmp_path / "rep" / "README.md").read_text().splitlines()
    table = _table_after(summary, "**Protocol `p` (held out)**, scored on b, c:")
    assert table[-1].startswith(f"| Raises | {FAILED} | – |"), table

    # compare (the suite writes it beside its summary; `fogbench compare` writes the same)
    code, _, err = run_cli("compare", tmp_path / "rep" / "tiny", "--out", tmp_path / "cmp")
    assert code == 0, err
    md = (tmp_path / "cmp" / "compare.md").read_text().splitlines()
    assert md == (tmp_path / "rep" / "compare.md").read_text().splitlines()
    mine = [ln for ln in md if ln.startswith("| tiny | p | ")]
    assert len(mine) == 2, md
    assert "| wavelet_soft |" in mine[0] and "| 1 of 2 (100%) | 0 of 3 |" in mine[0], mine
    assert mine[1] == (f"| tiny | p | improvement_rmse_pct | Raises | {FAILED} | "
                       + mine[0].split(" | ")[5] + " | – | 2 of 2 (100%) | 3 of 3 | no |"), mine
    rows = json.loads((tmp_path / "cmp" / "compare.json").read_text())["rows"]
    got = {(r["protocol"], r["method"]): r for r in rows}
    for prot in ("p", "p.ideal"):
        r = got[(prot, "Raises")]
        assert (r["failed"], r["replicates"], r["rank"], r["methods_ranked"],
                r["rank_probability"], r["first_error"]) == (3, 3, 2, 2, 1.0, ERROR)
        assert r["value"]["n"] == 0 and r["value"]["mean"] is None
        w = got[(prot, "wavelet_soft")]
        assert (w["rank"], w["methods_ranked"], w["failed"], w["first_error"]) == \
            (1, 2, 0, None)
    assert [r["method"] for r in rows if r["protocol"] == "p"] == ["wavelet_soft", "Raises"]


def test_compare_draws_a_method_that_failed_everywhere_as_a_row_saying_so(tmp_path,
                                                                          monkeypatch):
    from fogbench.outputs import files as IO
    from fogbench.report import compare as C

    kept = []
    monkeypatch.setattr(IO, "save_figure", lambda fig, path: kept.append(fig))
    value = {"n": 0, "n_failed": 3, "mean": None, "ci_low": None, "ci_high": None}
    rows = [{"scenario": "s", "protocol": "p", "method": "k", "in_sample": False,
             "metric": "improvement_rmse_pct", "failed": 0, "replicates": 3,
             "value": {"n": 3, "mean": 5.0, "ci_low": 4.0, "ci_high": 6.0}},
            {"scenario": "s", "protocol": "p", "method": "Raises", "in_sample": False,
             "metric": "improvement_rmse_pct", "failed": 3, "replicates": 3,
             "first_error": ERROR, "value": value}]
    C._figure(rows, str(tmp_path / "c.png"))
    ax = kept[0].axes[0]
    assert [t.get_text() for t in ax.get_yticklabels()] == ["s / p [rmse]: k", "Raises"]
    texts = [t.get_text() for t in ax.texts]
    assert any(t.startswith("failed in 3 of 3: RuntimeError") for t in texts), texts
    assert "failed in every replicate" in " ".join(
        t.get_text() for t in ax.get_legend().get_texts())


def test_compare_finds_a_failed_method_in_an_older_run_folder(tmp_path):
    """A metrics.json written before montecarlo kept the failed method (no series of it, no
    'failed_methods'): replicate 0's record of the failure lists it, failed in every
    replicate (it has no value in any)."""
    d = tmp_path / "old"
    d.mkdir()
    doc = {"scenario": "old", "methods": {"a": {}, "Raises": {}},
           "protocols": {"p": {"in_sample": False, "runs": {"b": {
               "raw": {"rmse_dph": 1.0}, "a": {"rmse_dph": 0.5},
               "Raises": {"status": "failed", "error": ERROR + "\n  more lines"}}}}},
           "montecarlo": {"claims": [], "series": {"p": {"improvement_rmse_pct": {
               "raw": [None, None], "a": [10.0, 12.0]}}}}}
    (d / "metrics.json").write_text(json.dumps(doc))
    from fogbench.report.compare import collect

    rows = {r["method"]: r for r in collect([d])}
    assert (rows["Raises"]["failed"], rows["Raises"]["rank"], rows["Raises"]["first_error"]) \
        == (2, 2, ERROR)
    assert (rows["a"]["rank"], rows["a"]["methods_ranked"]) == (1, 2)
