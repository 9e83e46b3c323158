"""`fogbench bench`'s scenario lines on a folder of one small scenario: it runs, prints a row per
scenario and times a replicate that is not the first (the benchmark asserts nothing of speed;
this checks that it measures what it says, on the API it drives)."""

from __future__ import annotations

from helpers import SMALL_SCENARIO


def test_the_scenario_bench_times_the_first_run_and_a_later_replicate(tmp_path, capsys):
    from fogbench.bench import bench_scenario_replicates

    (tmp_path / "tiny.toml").write_text(SMALL_SCENARIO + "\n[montecarlo]\nreplicates = 7\n")
    (row,) = bench_scenario_replicates(tmp_path)
    out = capsys.readouterr().out
    assert row["scenario"] == "tiny" and row["replicates"] == 7 and not row["failed"]
    assert row["first_s"] > 0 and row["replicate_s"] > 0 and row["table_s"] > 0
    assert abs(row["ratio"] * (row["table_s"] + row["first_s"]) - row["replicate_s"]) < 1e-12
    assert "tiny" in out and "1 scenario(s)" in out
    assert list(tmp_path.iterdir()) == [tmp_path / "tiny.toml"]     # nothing left behind


def test_the_quick_bench_runs_each_scenarios_first_run_only(tmp_path, capsys):
    """`fogbench bench --quick`'s scenario lines: the first run alone, its columns only."""
    from fogbench.bench import bench_scenario_replicates

    (tmp_path / "tiny.toml").write_text(SMALL_SCENARIO)
    (row,) = bench_scenario_replicates(tmp_path, first_only=True)
    out = capsys.readouterr().out
    assert row["first_s"] > 0 and row["replicate_s"] != row["replicate_s"]       # NaN
    assert "replicate 1 s" not in out and "nan" not in out and "tiny" in out
    assert list(tmp_path.iterdir()) == [tmp_path / "tiny.toml"]


def test_bench_help_offers_quick():
    from helpers import run_cli

    code, out, _ = run_cli("bench", "--help")
    assert code == 0 and "--quick" in out
