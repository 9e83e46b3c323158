"""``fogbench device``: device files (one gyro's ``[fog]`` keys, the format of
``sim/presets.toml``) shown, fitted to a user's logs, and checked against a log.

A device file holds exactly the keys of a scenario's ``[fog]`` table (datasheet units in their
names) and ``source``; a scenario runs it with ``[fog] device = "mygyro.toml"``
(:func:`fogbench.scenario.load_device_file` validates it). ``device fit`` writes one: every
value with a comment naming the log and the fit it came from and its interval; every key the
logs could not determine listed in comments with the default the simulator uses and why.
``device check`` simulates the device under a log's own conditions (sample rate, length,
gap-free pieces) over replicates and sets the log's Allan curve with its interval beside the
twin's band.

What a fit determines (``fit_device``):

- static logs: the noise terms of the composite identifier (:mod:`fogcomp.noise`) of the longest
  log; the bias (the logs' mean rate less the Earth rate's projection on the input axis, when
  the latitude is given); with two or more logs of separate power-ons the switch-on bias
  repeatability (their spread less the part each mean's own noise explains);
- an Allan curve (``--curve``): the noise terms only;
- a thermal log (``--thermal``: a constant rate through a chamber program, with the temperature
  sensor): the temperature terms and the coil's lag behind the sensor
  (:mod:`fogbench.device.thermal`), weighted by the noise model of the static logs or curve.

- a multi-position, centrifuge or rate-table log (``--multipos``, with its reference rate
  column): the g and g^2 terms of paper 004 eq. 8 and the scale factor (and its non-linearity
  with the full scale given), each term flagged identifiable from the log's design or not
  (:mod:`fogbench.device.multipos`). Misalignment is not fitted (it needs the reference rates
  about the other axes).
"""

from __future__ import annotations

from fogbench.device.twin import twin_curves, check_device
from fogbench.device.commands import CheckOptions, FitOptions, ShowOptions, check, fit, show
from fogbench.device.file import MARKER, preset_text, DeviceFit
from fogbench.device.fit import fit_device

__all__ = ["MARKER", "preset_text", "DeviceFit", "fit_device", "twin_curves", "check_device",
           "ShowOptions", "FitOptions", "CheckOptions", "show", "fit", "check"]
