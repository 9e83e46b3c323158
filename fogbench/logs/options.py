"""How a log is read: the options every log command shares (format, topic, column map, sample
rate, gaps, timing tolerance), as one value the commands' options extend."""

from __future__ import annotations

from dataclasses import dataclass

from fogbench.formats.table import MIN_RECORD_SAMPLES, read_log

__all__ = ["LogOptions"]


@dataclass(frozen=True)
class LogOptions:
    """The shared flags of the log commands (``--format``, ``--topic``, ``--column``, ``--fs``,
    ``--gaps``, ``--time-tolerance``), as :func:`fogbench.formats.table.read_log` takes them.

    ``format``: csv, euroc, rosbag or ulog (None: recognised from the file); ``topic``: a bag's
    Imu topic or a ULog topic; ``column``: ``CHANNEL=HEADER:UNIT`` items; ``fs``: the sample
    rate, Hz, of a log without a time column; ``gaps``: "refuse" or "split" at a gap;
    ``time_tolerance``: the largest relative departure of a sample interval from the median."""

    format: str | None = None
    topic: str | None = None
    column: list[str] | None = None
    fs: float | None = None
    gaps: str = "refuse"
    time_tolerance: float = 0.05

    def read(self, path, channels, *, gaps: str | None = None,
             min_samples: int = MIN_RECORD_SAMPLES, **kwargs):
        """:func:`~fogbench.formats.table.read_log` of ``path`` with these options (``gaps``
        overrides the option's: a command that cannot take a gap refuses it)."""
        return read_log(path, fmt=self.format, topic=self.topic, mapping=self.column,
                        channels=channels, fs=self.fs,
                        gaps=self.gaps if gaps is None else gaps,
                        time_tolerance=self.time_tolerance, min_samples=min_samples, **kwargs)

