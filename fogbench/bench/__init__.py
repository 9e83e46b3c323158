"""Benchmarks: figures printed, nothing asserted about speed (``fogbench bench``, ``make
bench``). Measured in one run, each ``repeats`` times, medians quoted, every speed as a ratio
to a reference in the same run: the rig against bare ``mujoco.rollout`` and the FOG error model
(:mod:`.rig`); the Allan deviation against allantools and the CSV writer against pandas
(:mod:`.allan`); every method, the Kalman engines against filterpy (:mod:`.methods`); every
bundled scenario's first run and one replicate, and the replicates per second on one and two
processes (:mod:`.scenarios`); the noise identifier's accuracy and coverage on records of known
noise (:mod:`.noise`) and its choice of model on composite records (:mod:`.noise_select`, about 6 minutes), the joint round trip of one gyro's logs (:mod:`.joint`), the device-file round trip (:mod:`.device`) and the consistency of the filters noise models imply (:mod:`.consistency`, about a minute at 20 seeds: full bench only)."""

from __future__ import annotations

from fogbench.bench.rig import bench_rig
from fogbench.bench.scenarios import bench_replicates, bench_scenario_replicates

__all__ = ["main"]


def main(seconds: float = 600.0, repeats: int = 5, noise_seeds: int = 20,
         quick: bool = False) -> int:
    """Every benchmark in turn (``fogbench bench``), or with ``quick`` every speed ratio on
    short records (``_quick``, its own lengths and repeats); returns 0."""
    if quick:
        return _quick()
    print("fogbench bench: the whole bench takes an hour or more on two cores (the noise "
          "identifier's and the device files' tables over 20 seeds are most of it); "
          "`fogbench bench --quick` prints every speed ratio in a few minutes", flush=True)
    bench_rig(seconds, repeats)
    from fogbench.bench.allan import bench_allan, bench_compensate_write

    print()
    bench_allan(n=10**7, repeats=min(repeats, 3))
    print()
    bench_compensate_write(repeats=min(repeats, 3))
    from fogbench.bench.methods import main as bench_methods

    print()
    bench_methods(repeats=min(repeats, 3))
    print()
    bench_scenario_replicates()
    print()
    bench_replicates()
    from fogbench.bench.noise import run as bench_noise

    print()
    bench_noise(seeds=noise_seeds)
    from fogbench.bench.noise_select import run as bench_noise_select

    print()
    bench_noise_select(seeds=noise_seeds)
    from fogbench.bench.device import run as bench_device
    from fogbench.bench.joint import print_joint

    print()
    print_joint(seeds=noise_seeds)
    print()
    bench_device(seeds=noise_seeds)
    from fogbench.bench.consistency import run as bench_consistency

    print()
    bench_consistency(seeds=noise_seeds)
    from fogbench.bench.attitude import attitude_study, report, triad_report, triad_study

    print()
    for line in report(attitude_study(replicates=noise_seeds)):
        print(line, flush=True)
    print()
    for line in triad_report(triad_study(replicates=noise_seeds)):
        print(line, flush=True)
    return 0


def _quick() -> int:
    """Every speed ratio of the bench on short records, medians of 3: the rig against bare
    rollout, the error model, Allan against allantools, the CSV writer against pandas, the
    Kalman fast path against filterpy at a high and a low gain, each method's fit (2,500
    samples) and compensation, and one replicate of each bundled scenario (its first run:
    the table's motion and replicate 0). No accuracy tables."""
    import time

    from fogbench.bench.allan import bench_allan, bench_compensate_write
    from fogbench.bench.methods import main as bench_methods

    t0 = time.perf_counter()
    print("fogbench bench --quick: speed ratios on short records (the accuracy tables: "
          "`fogbench bench`)", flush=True)
    bench_rig(seconds=30.0, repeats=3)
    print()
    bench_allan(n=10**6, repeats=3)
    print()
    bench_compensate_write(n=5 * 10**4, repeats=3)
    print()
    bench_methods(repeats=3, quick=True)
    print()
    bench_scenario_replicates(first_only=True)
    print(f"\nfogbench bench --quick took {time.perf_counter() - t0:.0f} s")
    return 0
