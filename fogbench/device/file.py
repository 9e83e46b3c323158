"""A device file as ``fogbench device fit`` writes it: every value with a comment naming the log
and the fit it came from and its interval, every key the logs could not determine listed with
the simulator's default and what would give it; a preset shown as a device file; a device
file's values as the simulator's parameters."""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from fogbench.formats.errors import LogError

__all__ = ["MARKER", "preset_text", "DeviceFit", "TriadFit"]

MARKER = "# fogbench device fit"           # first line of a file this command wrote

# the keys a fit can leave undetermined, with the simulator's default and what would give them
_NEEDS = {
    "bias_dph": ("0", "a static log (its mean rate)"),
    "switch_on_bias_dph": ("0 (no switch-on change)", "two or more static logs of separate "
                           "power-ons (--static A.csv --static B.csv ...)"),
    "arw_deg_rt_h": ("0", "a static log or an Allan curve showing a slope -1/2"),
    "bias_instability_dph": ("0", "a static log or an Allan curve showing a flat floor"),
    "rrw_dph_rt_h": ("0", "a longer record (the curve does not rise with slope +1/2)"),
    "quantization_arcsec": ("0", "a record whose shortest averaging times show slope -1"),
    "rate_ramp_dph_per_h": ("0", "a record showing slope +1"),
    "gm_drift_dps": ("0", "a record showing a Gauss-Markov hump"),
    "scale_factor_ppm": ("0", "a rate-table log (--multipos LOG.csv --reference COLUMN)"),
    "sf_nonlinearity_ppm": ("0", "a rate-table log over the range (--multipos, with "
                            "--full-scale-dps)"),
    "g_sens_dph_per_g": ("[0, 0, 0]", "a multi-position log (--multipos LOG.csv --reference "
                         "COLUMN)"),
    "g2_sens_dph_per_g2": ("[0, 0, 0, 0, 0, 0]", "a centrifuge and multi-position log "
                           "(--multipos)"),
    "misalignment_mrad": ("zero", "a rate-table log with the reference rates about the other "
                          "axes (not fitted here: --reference names the input axis's only)"),
    "temp_coeff_dph_per_c": ("0", "a thermal log (--thermal)"),
    "temp_coeff2_dph_per_c2": ("0", "a thermal log (--thermal)"),
    "temp_rate_coeff_dph_per_c_per_min": ("0", "a thermal log with ramps (--thermal)"),
    "temp_cross_coeff_dph_per_c_per_c_per_min": ("0", "a thermal log with ramps (--thermal)"),
    "coil_time_constant_s": ("600", "a thermal log whose sensor the coil lags (--thermal)"),
}


def preset_text(name: str) -> str:
    """A preset of ``sim/presets.toml`` as a device file: its lines, comments (the source of
    every number) included, without the section header."""
    from sim.rig import PRESETS_PATH, load_presets

    if name not in load_presets():
        raise LogError(f"device show: {name!r} is neither a preset ({', '.join(sorted(load_presets()))}) "
                       "nor a device file")
    lines = PRESETS_PATH.read_text().splitlines()
    start = lines.index(f"[{name}]")
    body = []
    for ln in lines[start + 1:]:
        if re.match(r"\s*\[", ln):
            break
        body.append(ln)
    while body and not body[-1].strip():
        body.pop()
    return (f"# preset {name} of sim/presets.toml as a device file ([fog] device = "
            f"\"this file\" in a scenario runs it)\n" + "\n".join(body) + "\n")


# ---------------------------------------------------------------------------------------------
# fit
@dataclass
class Entry:
    """One determined key: its value (datasheet unit), the interval (None: not stated) and where
    it comes from."""

    key: str
    value: object
    low: float | list | None     # a vector key: one bound per component (None: undetermined)
    high: float | list | None
    source: str


@dataclass
class DeviceFit:
    """What a fit determined (``entries``), what it did not (``undetermined``: key -> why) and
    the warnings a reader must see (``notes``)."""

    entries: list = field(default_factory=list)
    undetermined: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    ci: float = 0.683
    inputs: list = field(default_factory=list)
    options: list = field(default_factory=list)   # the fit's command-line options

    def values(self) -> dict:
        return {e.key: e.value for e in self.entries}

    def entry(self, key: str) -> Entry | None:
        return next((e for e in self.entries if e.key == key), None)

    def to_toml(self) -> str:
        out = [MARKER + " (this line lets a later fit with --overwrite replace the file)",
               "# from: " + ", ".join(self.inputs),
               "# options: " + (" ".join(self.options) or "(none)"),
               f"# intervals: {self.ci:.1%} (the identifier's, or over the power-ons)"]
        for n in self.notes:
            out.append(f"# NOTE: {n}")
        out.append(f"source = {json.dumps('fitted by fogbench device fit to ' + ', '.join(self.inputs))}")
        out += self.key_lines()
        return "\n".join(out) + "\n"

    def key_lines(self, leave_out=()) -> list[str]:
        """Every determined key with its comment (source and interval), then the keys left
        undetermined (comments), but for ``leave_out``: a one-axis file's body, or one axis
        table of a triad's."""
        out = []
        for e in self.entries:
            if e.key in leave_out:
                continue
            out.append(f"# {e.key}: {e.source}{_entry_interval(e)}")
            out.append(f"{e.key} = {_toml_value(e.value)}")
        out.append("# Not determined by these logs (the simulator's default applies):")
        for k, why in self.undetermined.items():
            if k in leave_out:
                continue
            default = _NEEDS.get(k, ("the simulator's (sim.fog.FogParams, sim.thermal)",))[0]
            out.append(f"#   {k}: default {default}; {why}")
        return out


@dataclass
class TriadFit:
    """A triad's fit: one :class:`DeviceFit` per axis (``axes``: "x" -> its fit), written as a
    triad device file (``fogbench.scenario.device_triad``): each axis's keys in its table
    ``[x]``, ``[y]``, ``[z]``; the cross-axis matrices (``Tw``, ``Tg_dph_per_g``) listed as not
    determined (static logs cannot separate them)."""

    axes: dict = field(default_factory=dict)
    ci: float = 0.683
    inputs: list = field(default_factory=list)
    options: list = field(default_factory=list)

    def to_toml(self) -> str:
        out = [MARKER + " (this line lets a later fit with --overwrite replace the file)",
               "# from: " + ", ".join(self.inputs),
               "# options: " + (" ".join(self.options) or "(none)"),
               f"# intervals: {self.ci:.1%} (the identifier's, or over the power-ons)",
               "# a FOG triad: each gyro fitted alone, as a one-axis fit of its column (its "
               "input axis its own body axis), in its table [x], [y], [z]"]
        for a, f in self.axes.items():
            out += [f"# NOTE ({a}): {n}" for n in f.notes]
        out.append(f"source = {json.dumps('fitted by fogbench device fit to ' + ', '.join(self.inputs))}")
        out.append("# Not determined by these logs (each axis's scale_factor_ppm, "
                   "misalignment_mrad and g_sens_dph_per_g apply, default 0):")
        for k, why in TRIAD_NEEDS.items():
            out.append(f"#   {k}: {why}")
        from fogbench.scenario.device_triad import THERMAL_BUILD_KEYS

        out.append("#   " + ", ".join(THERMAL_BUILD_KEYS) + ": the triad's thermal build and "
                   "temperature sensor, one for the three gyros (top level); the simulator's "
                   "defaults")
        for a, f in self.axes.items():
            out += ["", f"[{a}]"] + f.key_lines(leave_out=THERMAL_BUILD_KEYS)
        return "\n".join(out) + "\n"


TRIAD_NEEDS = {
    "Tw": "the 3x3 scale-factor-and-misalignment matrix (dimensionless); needs a rate-table "
          "calibration with rotations about each axis (fogcomp.triad.fit_triad)",
    "Tg_dph_per_g": "the 3x3 g-sensitivity (deg/h per g); needs dwells at several attitudes "
                    "against the lab's references (fogcomp.triad.fit_triad)",
}


def _entry_interval(e: Entry) -> str:
    """An entry's interval as written after its value ('' when none is stated): one pair, or
    one per component of a vector ('-' for a component the logs do not determine)."""
    if e.low is None and e.high is None:
        return ""
    if isinstance(e.low, (list, tuple)):
        return " [" + "; ".join("-" if a is None else _interval_text(a, b)
                                for a, b in zip(e.low, e.high)) + "]"
    return f" [{_interval_text(e.low, e.high)}]"


def _interval_text(lo: float | None, hi: float | None) -> str:
    """Both bounds with the digits that tell them apart (at least 4 significant); a side the
    logs do not bound (None) as '-'."""
    if lo is None or hi is None:
        return ", ".join("-" if x is None else f"{x:.4g}" for x in (lo, hi))
    width = abs(hi - lo)
    scale = max(abs(lo), abs(hi))
    digits = 4 if width == 0 or scale == 0 else max(4, int(math.ceil(
        math.log10(scale / width))) + 2)
    return f"{lo:.{min(digits, 12)}g}, {hi:.{min(digits, 12)}g}"


def _toml_value(v) -> str:
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, str):
        return json.dumps(v)
    return repr(float(f"{float(v):.6g}"))


# ---------------------------------------------------------------------------------------------
# command line
def _is_device_file(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(len(MARKER)) == MARKER.encode()
    except OSError:
        return False


_TRIAD_NEEDS_AXIS = ("a triad device file (tables [x], [y], [z]) where one gyro is simulated: "
                     "choose its gyro with --axis x, y or z")


def _device_from_values(values: dict, fs: float, axis: str | None = None):
    """FogParams of a device file's keys (datasheet units) at sample rate ``fs``; of a triad
    device file, its gyro ``axis``'s (required: a one-axis consumer is handed one gyro)."""
    from fogbench.scenario.device_file import _fog
    from fogbench.scenario.device_triad import is_triad
    from fogbench.scenario.tables import _Table

    if is_triad(values):
        if axis is None:
            raise LogError(_TRIAD_NEEDS_AXIS)
        values = {**values, "axes": [axis]}
    params, *_ = _fog(_Table(dict(values), "device", "fitted device"), fs)
    return params


def _device_params(path, fs: float, axis: str | None = None):
    """(FogParams, the file's keys) of a device file; of a triad's, its gyro ``axis``'s (a
    triad file without ``axis`` is refused, naming the file)."""
    from fogbench.scenario import ScenarioError
    from fogbench.scenario.device_file import load_device_file
    from fogbench.scenario.device_triad import is_triad

    try:
        doc = load_device_file(path, fs)
    except ScenarioError as exc:
        raise LogError(str(exc)) from None
    if is_triad(doc) and axis is None:
        raise LogError(f"{path}: {_TRIAD_NEEDS_AXIS}")
    return _device_from_values(doc, fs, axis), doc
