"""``fogbench simulate``: a scenario's runs simulated and written as data files.

A simulation directory holds, per run, ``<run>.npz`` (arrays, SI, units in every name) and
``<run>.json`` (metadata), and last ``simulation.json``, the manifest. Every file is written to a
temporary name in the same directory and renamed into place, and the manifest is written only
when every run is complete: a directory without ``simulation.json`` is incomplete.

Arrays in ``<run>.npz`` (n samples, a = number of sensitive axes):

=============================  =========  ===============================================
name                           shape      meaning
=============================  =========  ===============================================
t_s                            (n,)       sample start time, s
truth_rate_rps                 (n, 3)     true inertial rate on sensor x, y, z, rad/s
table_rate_rps                 (n, 3)     the same without the Earth's rate, rad/s
specific_force_g               (n, 3)     accelerometer truth at the FOG site, g
gravity_g                      (n, 3)     gravity projection on sensor axes, g
tilt_rad, turn_rad             (n,)       joint angles
tilt_rate_rps, turn_rate_rps   (n,)       joint rates
tilt_cmd_rad                   (n,)       tilt command
turn_rate_cmd_rps              (n,)       turntable rate command
fog_quat, tilt_quat,           (n, 4)     orientations in the world frame (w, x, y, z)
turntable_quat
fog_pos_m                      (n, 3)     FOG site position
chamber_c, coil_c              (n,)       chamber and (true) coil temperature, deg C
housing_c                      (n,)       FOG housing temperature, deg C (the chamber's
                                          when the device has no housing lag)
coil_rate_c_per_s              (n,)       true coil dT/dt, deg C/s
sensor_c                       (n,)       the temperature sensor's reading (lag, noise,
                                          quantisation; held between readings), deg C
sensor_rate_c_per_s            (n,)       dT/dt differenced from the readings, deg C/s
raw_rps                        (n, a)     FOG output (angle increment / interval), rad/s
saturated                      (n, a)     bool: the rate was beyond the measurement range
                                          and the output clipped (all False without a range)
term_<name>_rps                (n, a)     each error term's contribution, rad/s
=============================  =========  ===============================================

``raw_rps = truth_rate_rps[:, axes] + sum of term_*_rps`` (with saturation, the ``saturation``
term is the clipped minus the unclipped sum). The compensators of a scenario see ``sensor_c`` and
``sensor_rate_c_per_s``, a lab's view; ``coil_c`` and ``coil_rate_c_per_s`` are the truth.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from fogbench.outputs.files import atomic_write_text, versions
from fogcomp._persistence import atomic_write_bytes

__all__ = ["write_run", "write_manifest", "simulate_to_dir"]


def run_arrays(rd) -> dict[str, np.ndarray]:
    """The arrays of a RunData, named as in the table above."""
    tr, th = rd.truth, rd.thermal
    arr = {
        "t_s": tr.t, "truth_rate_rps": tr.rate, "table_rate_rps": tr.table_rate,
        "specific_force_g": tr.specific_force, "gravity_g": tr.gravity,
        "tilt_rad": tr.tilt, "turn_rad": tr.turn, "tilt_rate_rps": tr.tilt_rate,
        "turn_rate_rps": tr.turn_rate, "tilt_cmd_rad": tr.tilt_cmd,
        "turn_rate_cmd_rps": tr.turn_rate_cmd, "fog_quat": tr.fog_quat, "tilt_quat": tr.tilt_quat,
        "turntable_quat": tr.turntable_quat, "fog_pos_m": tr.fog_pos,
        "chamber_c": th.chamber, "coil_c": th.coil, "coil_rate_c_per_s": th.coil_rate,
        "raw_rps": rd.fog.raw,
    }
    for key, v in (("housing_c", th.housing), ("sensor_c", th.sensor),
                   ("sensor_rate_c_per_s", th.sensor_rate)):
        if v is not None:
            arr[key] = v
    sat = getattr(rd.fog, "saturated", None)
    arr["saturated"] = (np.zeros(rd.fog.raw.shape, dtype=bool) if sat is None
                        else np.asarray(sat, dtype=bool))
    for name, v in rd.fog.terms.items():
        arr[f"term_{name}_rps"] = v
    return arr


def run_metadata(scenario, rd) -> dict:
    from fogcomp.units import DPH

    return {
        "scenario": scenario.name, "scenario_file": scenario.path, "run": rd.run.name,
        "seed": rd.run.seed, "sample_rate_hz": rd.fs, "samples": rd.n, "axes": list(rd.axes),
        "duration_s": rd.n / rd.fs, "fog_preset": scenario.fog_preset,
        "fog_source": scenario.fog_source, "fog_device": scenario.device,
        "switch_on_draws": {
            "switch_on_bias_dph": (rd.fog.draws["switch_on_bias"] / DPH).tolist(),
            "g_sens_dph_per_g": (rd.fog.draws["g_sens"] / DPH).tolist(),
            "g2_sens_dph_per_g2": (rd.fog.draws["g2_sens"] / DPH).tolist(),
        },
        "terms": sorted(rd.fog.terms),
        "physics_steps": rd.truth.physics_steps,
        "settled_hold_fast_path_s": rd.truth.settled_fast_path_s,
        "versions": versions(),
    }


def write_run(out: Path, scenario, rd) -> tuple[Path, Path]:
    """Write ``<run>.npz`` and ``<run>.json`` into ``out`` atomically."""
    out = Path(out)
    buf = io.BytesIO()
    np.savez_compressed(buf, **run_arrays(rd))
    npz, js = out / f"{rd.run.name}.npz", out / f"{rd.run.name}.json"
    atomic_write_bytes(npz, buf.getvalue())
    atomic_write_text(js, json.dumps(run_metadata(scenario, rd), indent=2))
    return npz, js


def write_manifest(out: Path, scenario, run_names: list[str]) -> Path:
    """Write ``simulation.json`` last: its presence marks a complete directory."""
    doc = {"scenario": scenario.name, "scenario_file": scenario.path,
           "scenario_text": scenario.text, "runs": run_names, "versions": versions()}
    path = Path(out) / "simulation.json"
    atomic_write_text(path, json.dumps(doc, indent=2))
    return path


def simulate_to_dir(scenario: str | Path, out: str | Path, runs: list[str] | None = None,
                    quiet: bool = False) -> tuple[str, list[str], Path]:
    """Simulate the runs of ``scenario`` (all, or those named in ``runs``) and write them into
    ``out`` (new, empty, or a folder ``fogbench simulate`` wrote: nothing else is replaced),
    through a part folder moved into place when every run is written. Returns (the scenario's
    name, the runs written, the folder)."""
    from fogbench.console import Progress
    from fogbench.outputs.folders import (as_final, check_out_dir, discard_part, new_part_dir,
                                          replace_dir)
    from fogbench.scenario import load_plan, load_scenario
    from fogbench.scenario.load import RUNNER_SECTIONS
    from sim.rig import simulate_run

    sc = load_scenario(scenario, extra_sections=RUNNER_SECTIONS)
    if sc.extra:
        load_plan(sc)  # the whole file is validated, not only the part simulated
    if runs:
        missing = sorted(set(runs) - {r.name for r in sc.runs})
        if missing:
            raise ValueError(f"--run: {scenario}: no run named {missing}; runs: "
                             f"{[r.name for r in sc.runs]}")
    out = check_out_dir(out, "simulation")
    tmp = new_part_dir(out, "simulation", {"scenario": sc.name, "scenario_file": str(sc.path),
                                           "fogbench": versions().get("fogbench")})
    try:
        names = []
        for run in sc.runs:
            if runs and run.name not in runs:
                continue
            with Progress(100, f"{sc.name}/{run.name}", quiet=quiet, unit="%") as bar:
                rd = simulate_run(sc.rig, run, progress=bar.to_fraction)
            write_run(tmp, sc, rd)
            names.append(run.name)
        write_manifest(tmp, sc, names)
        replace_dir(tmp, out, "simulation")
    except OSError as exc:
        discard_part(tmp)
        raise as_final(exc, tmp, out) from None
    except BaseException:
        discard_part(tmp)
        raise
    return sc.name, names, out
