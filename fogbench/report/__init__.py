"""Run directories and what a person reads in them: ``report.md``, its figures (PNG), the
claim figures and maps, the noise figures, ``fogbench compare``'s table.

Figures are drawn with matplotlib's Agg backend. Long records are decimated for display only
(the report says so); every metric is computed on the full record."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

# the submodules below draw with pyplot: the backend is chosen first

from fogbench.report.markdown import raw_segment_stability
from fogbench.report.rundir import write_run_dir
from fogbench.report.timeseries import dwell_means, dwells

__all__ = ["write_run_dir", "dwells", "dwell_means", "raw_segment_stability"]
