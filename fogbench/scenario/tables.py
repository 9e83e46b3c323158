"""A TOML table being read: each key read as a kind (number, integer, string, list, table) in
its range, the rest refused; every read can be recorded, so that the validator itself is the
schema (:func:`fogbench.scenario.device_file.fog_json_schema`). Also the reading of a TOML file
(UTF-8, named in every error)."""

from __future__ import annotations

import math
import os
import tomllib
from typing import Any, NamedTuple

from fogbench.scenario.names import NAME_RULE, name_problem

__all__ = ["ScenarioError", "Read"]

MAX_REPLICATES = 10_000


class ScenarioError(ValueError):
    """A scenario file is malformed; the message names the file, the key and what was expected."""


class Read(NamedTuple):
    """One key read by the validator: where (the table, as errors name it), the key, its kind
    ('float', 'int', 'str', 'bool', 'floats', 'ints', 'strs', 'name', 'table', 'tables',
    'any'), its range, its choices, and its default (``...``: required)."""

    key: str
    kind: str
    lo: Any
    hi: Any
    lo_open: bool
    choices: Any
    where: str = ""
    default: Any = ...


class _Table:
    """A TOML table being read: tracks which keys were used, so the rest can be refused."""

    #: When a list: every get() appends a :class:`Read` to it, so that the validator itself
    #: declares the keys' schema (:func:`~fogbench.scenario.device_file.fog_json_schema`,
    #: :mod:`fogbench.scenario.schema`).
    recorder: list | None = None

    def __init__(self, data: dict, where: str, file: str):
        if not isinstance(data, dict):
            raise ScenarioError(f"{file}: {where}: expected a table, got {type(data).__name__}")
        self.data, self.where, self.file = data, where, file
        self.used: set[str] = set()

    def err(self, key: str, msg: str) -> ScenarioError:
        return ScenarioError(f"{self.file}: {self.where} key '{key}': {msg}")

    def has(self, key: str) -> bool:
        return key in self.data

    def get(self, key: str, kind: str, default: Any = ..., lo=None, hi=None, lo_open=False,
            choices=None):
        """Read ``key`` as ``kind``: 'float', 'int', 'str', 'bool', 'floats', 'strs', 'table',
        'tables'. Ranges are inclusive unless ``lo_open``."""
        if _Table.recorder is not None:
            _Table.recorder.append(Read(key, kind, lo, hi, lo_open, choices, self.where,
                                        default))
        self.used.add(key)
        if key not in self.data:
            if default is ...:
                import difflib

                near = difflib.get_close_matches(key, [str(k) for k in self.data
                                                       if k not in self.used], n=1, cutoff=0.6)
                raise self.err(key, "missing (required; expected "
                               f"{_describe(kind, lo, hi, choices, lo_open)})"
                               + (f"; the table has {near[0]!r}: did you mean {key!r}?"
                                  if near else ""))
            return default
        v = self.data[key]
        if kind == "float":
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise self.err(key, f"expected a number, got {v!r}")
            v = float(v)
            if not math.isfinite(v):
                raise self.err(key, f"expected a finite number, got {v!r}")
            self._range(key, v, lo, hi, lo_open)
        elif kind == "int":
            if isinstance(v, bool) or not isinstance(v, int):
                raise self.err(key, f"expected an integer, got {v!r}")
            self._range(key, v, lo, hi, lo_open)
        elif kind == "str":
            if not isinstance(v, str):
                raise self.err(key, f"expected a string, got {v!r}")
            if choices is not None and v not in choices:
                raise self.err(key, f"expected one of {sorted(choices)}, got {v!r}")
        elif kind == "bool":
            if not isinstance(v, bool):
                raise self.err(key, f"expected true or false, got {v!r}")
        elif kind == "floats":
            if not isinstance(v, list) or not v or not all(
                    isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
                raise self.err(key, f"expected a non-empty list of numbers, got {v!r}")
            v = [float(x) for x in v]
            for i, x in enumerate(v):
                if not math.isfinite(x):
                    raise self.err(key, f"expected finite numbers, got {x!r} at index {i}")
                self._range(key, x, lo, hi, lo_open)
        elif kind == "ints":
            if not isinstance(v, list) or not all(
                    isinstance(x, int) and not isinstance(x, bool) for x in v):
                raise self.err(key, f"expected a list of integers, got {v!r}")
            for x in v:
                self._range(key, x, lo, hi, lo_open)
        elif kind == "name":
            if not isinstance(v, str):
                raise self.err(key, f"expected a string, got {v!r}")
            msg = name_problem(v)
            if msg:
                raise self.err(key, msg)
        elif kind == "strs":
            if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
                raise self.err(key, f"expected a list of strings, got {v!r}")
            if choices is not None:
                for x in v:
                    if x not in choices:
                        raise self.err(key, f"expected entries from {sorted(choices)}, got {x!r}")
        elif kind == "table":
            if not isinstance(v, dict):
                raise self.err(key, f"expected a table, got {v!r}")
        elif kind == "tables":
            if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
                raise self.err(key, f"expected an array of tables ([[{key}]]), got {v!r}")
        elif kind == "any":
            pass
        else:  # pragma: no cover
            raise ValueError(kind)
        return v

    def _range(self, key, v, lo, hi, lo_open):
        if lo is not None and (v <= lo if lo_open else v < lo):
            raise self.err(key, f"expected a value {'>' if lo_open else '>='} {lo}, got {v}")
        if hi is not None and v > hi:
            raise self.err(key, f"expected a value <= {hi}, got {v}")

    def done(self):
        extra = sorted(set(self.data) - self.used)
        if extra:
            raise ScenarioError(f"{self.file}: {self.where}: unknown key(s) {extra}; "
                                f"allowed: {sorted(self.used)}")


def _describe(kind, lo, hi, choices, lo_open=False):
    what = {"float": "a number", "int": "an integer", "str": "a string", "bool": "true/false",
            "floats": "a list of numbers", "strs": "a list of strings", "table": "a table",
            "ints": "a list of integers", "name": f"a name ({NAME_RULE})",
            "tables": "an array of tables"}.get(kind, kind)
    if choices:
        what += f" from {sorted(choices)}"
    if lo is not None:
        what += f", {'>' if lo_open else '>='} {lo}"
    if hi is not None:
        what += f", <= {hi}"
    return what


def decode_text(raw: bytes, file: str) -> str:
    """A scenario file's text: UTF-8 (TOML's encoding; a leading byte-order mark is accepted).
    Anything else is refused naming the line and column of the first undecodable byte."""
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise ScenarioError(f"{file}: line {line}, column {col}: not UTF-8 text (byte "
                            f"0x{raw[exc.start]:02x}); save the file as UTF-8") from None


#: The largest scenario, map or device file read, bytes: the largest bundled one is 40 kB;
#: beyond this a file is not one a person wrote (a log given by mistake, a device node).
MAX_FILE_BYTES = 4 * 2**20


def read_text(path, what: str = "scenario file") -> str:
    """The text of a TOML input: a regular file (not a folder, pipe or device, which could
    block or never end) of at most :data:`MAX_FILE_BYTES`, in UTF-8; refused naming it."""
    import stat

    file = str(path)
    try:
        st = os.stat(path)
    except OSError as exc:
        raise ScenarioError(f"{file}: cannot read ({exc.strerror})") from None
    if stat.S_ISDIR(st.st_mode):
        raise ScenarioError(f"{file}: is a directory, expected a {what} (TOML)")
    if not stat.S_ISREG(st.st_mode):
        raise ScenarioError(f"{file}: not a regular file (a pipe, device or socket); expected "
                            f"a {what} (TOML)")
    if st.st_size > MAX_FILE_BYTES:
        raise ScenarioError(f"{file}: {st.st_size / 2**20:.1f} MiB, larger than any {what} "
                            f"({MAX_FILE_BYTES / 2**20:g} MiB at most); is it the right file?")
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ScenarioError(f"{file}: cannot read ({exc.strerror})") from None
    if len(raw) > MAX_FILE_BYTES:   # it grew while being read
        raise ScenarioError(f"{file}: larger than any {what} ({MAX_FILE_BYTES / 2**20:g} MiB "
                            "at most)")
    return decode_text(raw, file)


def _read_toml(path, what: str = "scenario file") -> dict:
    file = str(path)
    try:
        return tomllib.loads(read_text(path, what))
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{file}: not valid TOML ({exc})") from None
