"""The Rerun recording of a scenario run (``recording.rrd`` in the run directory).

``write_recording(res, path, replicates=None)`` writes one Rerun recording (application id
``fogbench``, recording id = the scenario name) holding every run of the scenario, with a
blueprint (the viewer's layout) declared in code; ``fogbench view DIR`` opens it (:func:`view`).

All time series are logged in bulk with ``send_columns`` on one timeline, ``sim_time`` (a
duration: the simulated time since the run's power-on, s). The runs of a scenario are separate
power-ons that all start at ``sim_time`` 0, so they share one time base: every time-series view
opens on the whole of the longest run (0 to its end) and their time axes are linked (zooming one
zooms all). In the 3-D view each run has its own table (``/table/<run>``), placed in a row along
the world y axis (0.8 m apart, base labelled with the run name), all moving together as
``sim_time`` plays; the default camera frames every table.

Entity paths (`<run>`: run name; `<protocol>`: protocol name, with `_2`, `_3`... appended when
a protocol scores the same run more than once; `<label>`: `raw`, `oracle` or a method label;
`<term>`: a FOG error term; `<metric>`: a metric name). The table is markdown, as in the README:

| entity path | content |
|---|---|
| `/table` | world frame, z up (static) |
| `/table/<run>` | the run's table, offset 0.8 m per run along world y (static transform) |
| `/table/<run>/base` | base and yoke boxes, labelled with the run name (static) |
| `/table/<run>/tilt` | tilt platform box; pose per sample = truth `tilt_quat` |
| `/table/<run>/turntable` | turntable cylinder (r 0.15 m); pose = `turntable_quat` |
| `/table/<run>/turntable/index_mark` | a mark near the turntable rim, to see it turn (static) |
| `/table/<run>/fog` | FOG case (9 cm cube); pose = `fog_pos`, `fog_quat` |
| `/table/<run>/fog/sensitive_axis` | orange arrow (0.2 m) along the scenario's sensitive axis, FOG frame, drawn from a point 0.11 m beside the case so that it stays apart from the gravity arrow when the two are parallel (static) |
| `/table/<run>/fog/gravity` | green arrow of `Truth.gravity` from the case centre, FOG frame, per sample (Arrows3D vectors column): 1 g *up*, what an accelerometer at rest reads, 0.12 m per g |
| `/runs/<run>/truth/rate` | true inertial rate about the sensitive axis, deg/s |
| `/runs/<run>/fog/raw` | raw FOG output, deg/s |
| `/runs/<run>/fog/compensated/<protocol>/<label>` | output of a scored piece (raw, oracle, each method), deg/s |
| `/runs/<run>/fog/error/<protocol>/<label>` | that output minus the truth, deg/h |
| `/runs/<run>/fog/error_shown/<protocol>/<label>` | the same with what every output keeps alike taken out (`fogbench.report.views.kept_alike`, as the PNG time series): raw's slow variation about its mean under a wander no method removes, or each curve's moving mean under fast noise every method keeps; each curve less its own mean where every claim on the run scores the std (`fogbench.report.views.mean_blind`); only for pieces that have such a thing or a sweep (then the errors as they are, the sweep's default named as such); the Overview shows these, the Errors tab the errors as they are, deg/h; a sweep's members other than its default are only in its envelope (next row) |
| `/runs/<run>/fog/error_shown/<protocol>/<sweep> envelope/{low,high}` | a sweep's envelope in the Overview's error view: the lowest and highest of its members' shown errors at each time (their errors as they are where a piece takes nothing out), deg/h |
| `/runs/<run>/fog/error_terms/<term>` | each simulated error term (`FogOutput.terms`), deg/h |
| `/runs/<run>/table/tilt_deg`, `tilt_cmd_deg` | tilt angle and its command, deg |
| `/runs/<run>/table/turn_rate_dps`, `turn_rate_cmd_dps` | turntable rate and its command, deg/s |
| `/runs/<run>/thermal/chamber_c`, `coil_c` | chamber and (true) coil temperature, deg C |
| `/runs/<run>/thermal/housing_c`, `sensor_c` | FOG housing temperature and the temperature sensor's reading (what the compensators get), deg C |
| `/runs/<run>/thermal/coil_rate_c_per_min` | true coil temperature rate, deg C/min |
| `/runs/<run>/thermal/sensor_rate_c_per_min` | temperature rate differenced from the sensor's readings (what the compensators get), deg C/min |
| `/runs/<run>/gravity/x`, `y`, `z` | `Truth.gravity` on the sensor axes, g |
| `/report/metrics` | metrics tables, failed methods, display decimation (markdown, static) |
| `/report/scenario` | the scenario file (markdown with a TOML block, static) |
| `/report/allan/<protocol>/<run>` | a log-log plot (static, 2-D view origin): `axes` (decade grid and labels), `legend` (names in their colours); `axes` and every curve carry the transform from (log10 tau/s, log10 deviation/(deg/h)) onto the plot |
| `/report/allan/<protocol>/<run>/<label>` | overlapping Allan deviation of (output - truth): a line strip of points (log10 tau in s, log10 ADEV in deg/h), static; up to the longest tau with at least 8 non-overlapping clusters |
| `/report/allan/<protocol>/<run>/<label>/ci` | its 68.3 % confidence interval at every tau: one vertical segment per tau, same coordinates |
| `/report/psd/<protocol>/<run>`, `.../<label>` | the same for the Welch PSD of (output - truth), mean removed, averaged in 10 bands a decade (``fogcomp.metrics.psd_bands``, as the PNGs): (log10 f/Hz, log10 PSD/((deg/h)^2/Hz)), and `/ci` its interval per band |
| `/report/{allan,psd}/<protocol>/<run>/<sweep> envelope low`, `... high` | a sweep's members but its default as their lowest and highest curve (every x a member reaches; thin, no intervals); where every output is raw plus a constant (``fogbench.report.views.offsets_only``) only raw's curve is logged |
| `/replicates/<protocol>/<metric>/<label>` | with Monte Carlo replicates: the metric of each replicate on the sequence timeline `replicate` (points) |
| `/replicates/summary` | the distribution of every replicated metric: median, 5-95 % range, finite replicates, one table per protocol and metric, the headline metrics first (markdown, static) |
| `/report/replicates/<metric>` | a dot plot of a headline metric over the replicates (static, 2-D view origin), a column per protocol: `names` (a row per label, named left of the columns), `title`; `<protocol>/axes` (grid, tick labels, the protocol's name), `<protocol>/<label>` the dots, one per replicate, at (value or its log10, row) under the transform onto the column, `<protocol>/<label>/range` its 5-95 % bar and median tick (`.../off_scale`: the note of a label drawn off scale) |

Scored pieces are logged at their own sample times (``Piece.t``): a subset of the run, and for
smoothed protocols the block means at the blocks' mean times. A method that failed has no
``compensated``/``error``/``allan``/``psd`` entries; the metrics text says so.

Allan deviation and PSD are static line strips in 2-D views with their own decade grid and
labels (Rerun 0.41 has no logarithmic plot axis): they show the moment their tab opens, whatever
timeline is selected. The confidence interval of the Allan deviation is the chi-square interval
(NIST SP 1065 eq. 45) with Greenhall and Riley's equivalent degrees of freedom for the noise type
that leads the curve at each tau (``fogcomp.allan.oadev_ci``: the five-term IEEE 952 model
fitted to the curve picks the type), so the bars widen where bias instability or rate random
walk dominate instead of keeping white noise's width. The PSD's
interval is the chi-square interval with each band's EDF: the Welch EDF of a Hann window at
50 % overlap (Percival and Walden 1993, eq. 292b) times the ordinates the band holds, less
their correlation (``fogcomp.metrics.band_edf``).

Colours (``fogbench.report.palette``, shared with the PNG figures): the method's colour everywhere (raw
grey, oracle cyan, one hue per method family -- the built-in method a label runs -- and the
members of a family in darker and lighter shades of it; every colour reads on both the light web
theme and the dark native one); a held-out protocol in the full colour, an in-sample one in a
30 % lighter tint with "(in-sample)" in its name. The Allan deviation stops at the longest tau
with at least ``palette.ALLAN_MIN_CLUSTERS`` (8) non-overlapping clusters, as in the PNGs. Series whose values are constant
to rounding (peak to peak below 1e-6 in their display unit) are shown on a fixed range around
their value instead of being autoscaled onto floating-point noise.

Long runs are decimated for display only (every k-th sample): at most ``MAX_SERIES_POINTS`` points
per series per run or piece and ``MAX_POSE_POINTS`` 3-D poses per run; ``/report/metrics`` gives k
for every run and piece. Every metric, Allan deviation and PSD is computed on the full record.

The blueprint (sent with the recording, active and default for the application) opens on tab
"Overview": the 3-D tables and the metrics on the left; on the right the error against truth of
each scored run (one tab per run: raw, oracle and every method of every protocol, deg/h, its
legend above the data) and the temperatures. Further tabs: "Errors" (every scored run side by
side), "Table and chamber" (rate of every run, truth and raw; tilt; turntable rate; gravity; coil
dT/dt; temperatures), "FOG error terms" (a plot per run), "Allan deviation" and "PSD" (a log-log
plot per scored piece), "Monte Carlo" (with replicates) and "Report".

Legends list every line: the members of a sweep share one entry, ``<group> (<n> settings)``, in
their family's hue (a viewer legend merges equal names; the shades tell the members apart), and
in a time series the methods of an in-sample protocol share one, ``<protocol> (in-sample):
every method, lighter`` (a view of a held-out and an in-sample protocol would otherwise list 2 x
the methods, more than a plot holds: the viewer's legend cuts off what does not fit). The
Allan and PSD tabs hold at most ``MAX_LOGLOG_VIEWS`` plots, else a tab per protocol (so that
each plot holds its legend). The log-log plots label at most ``LOGLOG_MAX_LABELS`` decades an
axis (every k-th; the grid keeps every decade) and span at most ``LOGLOG_MAX_DECADES`` decades
in y: lower values (a filtered output's PSD falling towards 0) are drawn on the floor; their
legend is right of the plot.

"Monte Carlo" (with replicates): the summary table (numbers first, the label last, so that long
labels do not push them off the panel) beside one dot plot per headline metric
(:func:`headline_metrics`: the metrics the claims are about, else the report's key metric), a
column per protocol on one x scale: a row per label, a dot per replicate, the 5-95 % bar and
the median tick. The plots
are static 2-D views: they show whatever timeline is selected (time series on the `replicate`
timeline showed nothing while `sim_time`, the default, was selected). A label whose median is
far from all the others (:func:`_off_scale`: paper000's oracle_filter, std 0) gets a note with
its median instead of stretching the axis over the differences the claims are about. Each
replicate's values are also on the sequence timeline `replicate` (`/replicates/...`).
"""

from __future__ import annotations

from fogbench.recording.entities import (
    APPLICATION_ID,
    CONFIDENCE,
    MAX_POSE_POINTS,
    MAX_SERIES_POINTS,
    REPLICATE_TIMELINE,
    TIMELINE,
)
from fogbench.recording.loglog import LOGLOG_MAX_DECADES, LOGLOG_MAX_LABELS
from fogbench.recording.replicates import headline_metrics
from fogbench.recording.viewer import view
from fogbench.recording.write import ReplicatesError, blueprint_for, write_recording
from fogbench.report.fmt import decimation

__all__ = ["write_recording", "view", "blueprint_for", "ReplicatesError", "decimation", "MAX_SERIES_POINTS", "MAX_POSE_POINTS", "TIMELINE", "REPLICATE_TIMELINE", "APPLICATION_ID", "CONFIDENCE", "headline_metrics", "LOGLOG_MAX_DECADES", "LOGLOG_MAX_LABELS"]
