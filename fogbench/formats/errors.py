"""What a log reader raises (:class:`LogError`) and warns (:class:`PlausibilityWarning`)."""

from __future__ import annotations

__all__ = ["LogError", "PlausibilityWarning"]


class LogError(ValueError):
    """A log file, a curve file or a command-line option is refused (one-line message)."""


class PlausibilityWarning(UserWarning):
    """A log's values contradict the unit its header names (read, but say so)."""
