"""The consistency benchmark (fogbench.bench.consistency) on short records: it prints a row per
filter model, and the model missing its Gauss-Markov term is flagged in every record."""

from __future__ import annotations


def test_the_consistency_bench_prints_each_model_and_flags_the_missing_term(capsys):
    from fogbench.bench.consistency import run

    m = run(seeds=3, hours=0.5)
    out = capsys.readouterr().out
    for label in ("true model", "identified model", "missing the GM term", "x10 (guessed)"):
        assert label in out
    assert m["models"]["missing the GM term"]["overconfident"] == 1.0
    lo, hi = m["models"]["true model"]["in_band_ci"]
    assert 0.0 <= lo <= hi <= 1.0
