"""Benchmarks: figures printed, nothing asserted about speed (``fogbench bench``, ``make
bench``). Measured in one run, each ``repeats`` times, medians quoted, every speed as a ratio
to a reference in the same run: the rig against bare ``mujoco.rollout`` and the FOG error model
(:mod:`.rig`); the Allan deviation against allantools and the CSV writer against pandas
(:mod:`.allan`); every method, the Kalman engines against filterpy (:mod:`.methods`); every
bundled scenario's first run and one replicate, and the replicates per second on one and two
processes (:mod:`.scenarios`); the noise identifier's accuracy and coverage on records of known
noise (:mod:`.noise`) and its model selection on composite records (:mod:`.noise_select`); and the device-file round trip (:mod:`.device`)."""

from __future__ import annotations

from fogbench.bench.rig import bench_rig
from fogbench.bench.scenarios import bench_replicates, bench_scenario_replicates

__all__ = ["main"]


def main(seconds: float = 600.0, repeats: int = 5, noise_seeds: int = 20) -> int:
    """Every benchmark in turn (``fogbench bench``); returns 0."""
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

    print()
    bench_device(seeds=noise_seeds)
    return 0
