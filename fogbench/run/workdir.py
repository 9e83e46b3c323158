"""The replicates' work folder (``.<run>.replicates/`` beside the run directory): each
replicate's document written atomically as it completes, checked (scenario digest, fogbench
version, its own checksum) before ``--resume`` keeps it."""

from __future__ import annotations

import hashlib
import json
import re
import os
import shutil
from pathlib import Path

from fogbench.outputs.files import atomic_write_text, json_ready, versions
from fogbench.outputs.folders import MARKER, Claim, OutDirError, _marker
from fogbench.scenario.environment import method_environment

__all__ = ["MonteCarloError", "replicate_doc", "WorkDir", "scenario_digest"]


class MonteCarloError(ValueError):
    """A Monte Carlo run cannot go on as asked (e.g. ``--resume`` on another scenario)."""


def _device_digest(text: str) -> str | None:
    """The SHA-256 of the device file a scenario's text holds (``[fog] device = ...``, written
    into the text by the loader), or None."""
    m = re.search(r"^# \[fog\] device = .*\(sha256 ([0-9a-f]{64})\):$", text, re.M)
    return m.group(1) if m else None


def scenario_digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def _overrides_text(overrides: dict | None) -> str:
    """What a claim-map point adds to its scenario file's text for the digests."""
    return "" if not overrides else "\n" + json.dumps(overrides, sort_keys=True)


def replicate_doc(res, wall_s: float) -> dict:
    """What a replicate leaves: every scored piece's metrics (and per seed, with K > 1)."""
    prots: dict = {}
    for it in res.scored:
        p = prots.setdefault(it.protocol, {"runs": {}, "seeds": {}})
        p["runs"][it.run] = {lab: _clean(m) for lab, m in it.metrics.items()}
        if it.seed_metrics:
            p["seeds"][it.run] = {lab: [_clean(m) for m in ms]
                                  for lab, ms in it.seed_metrics.items()}
    return {"replicate": int(res.metrics.get("replicate", 0)),
            "method_seeds": int(res.metrics.get("method_seeds", 1)),
            "wall_s": wall_s, "protocols": prots}


_clean = json_ready


# ---------------------------------------------------------------------------------------------
# The work folder: one file per completed replicate, resumable
class WorkDir:
    """``.<run dir name>.replicates`` beside the run directory: ``r00000.json``, ... and the
    marker naming the scenario (its text's SHA-256), the fogbench version, K and the methods.

    The folder is claimed when it is opened, before any work: an exclusive ``flock`` on the
    folder itself, held until this process ends (the kernel releases it even after kill -9),
    so a second run into the same place is refused at once. Every replicate file carries a
    SHA-256 of its content and of the scenario it belongs to (``sha256``): a file edited,
    relabelled or copied from another scenario's run is refused by ``--resume``, naming it."""

    def __init__(self, out: Path, sc, method_seeds: int, methods: list[str] | None,
                 tag: str | None = None):
        self.out = Path(out)
        self.path = self.out.parent / (f".{self.out.name}.replicates" if tag is None else
                                       f".{self.out.name}.{tag}.replicates")
        self.identity = {"kind": "replicates", "scenario": sc.name,
                         "scenario_file": str(sc.path), "scenario_sha256": scenario_digest(sc.text),
                         "fogbench": versions().get("fogbench"), "method_seeds": method_seeds,
                         "methods": sorted(methods) if methods else None,
                         "method_environment": method_environment() or None,
                         "device_sha256": _device_digest(sc.text)}
        self._claim = Claim(self.path, self._busy)

    def _mismatch(self, found: dict, where: Path) -> str | None:
        if "device_sha256" in found and found["device_sha256"] != self.identity["device_sha256"]:
            # the scenario's text holds its device file's: name the file that changed
            return (f"--resume: {where} holds replicates of another device file, or of the "
                    "scenario's device file before it was edited (device_sha256: "
                    f"{found['device_sha256']!r}, now {self.identity['device_sha256']!r}); "
                    "refused. Run without --resume to start afresh")
        for key, what in (("scenario_sha256", "another scenario file (or an edited one)"),
                          ("fogbench", "another fogbench version"),
                          ("method_seeds", "another method_seeds"), ("methods", "other methods"),
                          ("method_environment", "other --with-method / --fit-timeout-s")):
            if found.get(key) != self.identity[key]:
                return (f"--resume: {where} holds replicates of {what} "
                        f"({key}: {found.get(key)!r}, now {self.identity[key]!r}); refused. Run "
                        "without --resume to start afresh")
        return None

    def _busy(self, path):
        found = _marker(path, kinds=("replicates",)) or {}
        return MonteCarloError(f"{path} is being filled by another fogbench process"
                               + (f" (pid {found['pid']})" if found.get("pid") else "")
                               + "; wait for it or give another --out")

    def release(self) -> None:
        self._claim.release()

    def open(self, resume: bool) -> dict[int, dict]:
        """Claim the folder and check it; return the completed replicates (empty unless
        ``resume``).

        Nothing is deleted: replicates a previous run left are kept unless the user resumes
        them or removes the folder; a folder another live process is filling is refused; a
        folder that is not ours is refused untouched.
        """
        found = _marker(self.path, kinds=("replicates",))
        if (self.path.exists() or self.path.is_symlink()) and found is None and not (
                self.path.is_dir() and not self.path.is_symlink()
                and not os.listdir(self.path)):
            raise OutDirError(f"{self.path} exists and is not a fogbench replicates folder; it "
                              "was left untouched. Move it away or give another --out")
        created = self._claim.acquire()
        try:
            done = self._open(resume)
            self._write_marker()
        except BaseException:
            if created:
                self.remove()
            else:
                self.release()
            raise
        return done

    def _open(self, resume: bool) -> dict[int, dict]:
        found = _marker(self.path, kinds=("replicates",))
        done: dict[int, dict] = {}
        if not resume:
            left = sorted(self.path.glob("r*.json")) if found is not None else []
            if left:
                raise MonteCarloError(
                    f"{self.path} holds {len(left)} replicate(s) of an earlier run that did not "
                    "finish; give --resume to keep them and compute the rest, or remove the "
                    "folder to start afresh")
            return done
        prev = self.out / "replicates"
        if found is not None and any(self.path.glob("r*.json")):
            src, ident = self.path, found
        elif (self.out / MARKER).exists() and prev.is_dir():
            src, ident = prev, _read_json(prev / "identity.json")
        elif found is not None:
            src, ident = self.path, found
        else:
            raise MonteCarloError(f"--resume: nothing to resume for {self.out} (neither "
                                  f"{self.path} nor {prev} holds replicates)")
        msg = self._mismatch(ident or {}, src)
        if msg:
            raise MonteCarloError(msg)
        for f in sorted(src.glob("r*.json")):
            doc = self._checked(f)
            done[doc["replicate"]] = doc
        if src != self.path:
            for doc in done.values():
                self.write(doc)
        return done

    def _checked(self, f: Path) -> dict:
        """A stored replicate, refused (naming the file) unless its checksum, its scenario and
        its file name agree with its content."""
        doc = _read_json(f)
        why = None
        if not isinstance(doc, dict):
            why = "not a replicate file (not a JSON object)"
        elif doc.get("sha256") != _doc_sha256(doc):
            why = ("its content does not match its checksum (key 'sha256'): it was edited or "
                   "damaged" if "sha256" in doc else "it has no checksum (key 'sha256')")
        elif doc.get("scenario_sha256") != self.identity["scenario_sha256"]:
            why = "it belongs to another scenario file (key 'scenario_sha256')"
        elif not isinstance(doc.get("replicate"), int) or \
                f.name != f"r{doc['replicate']:05d}.json":
            why = f"it holds replicate {doc.get('replicate')!r}, not the one its name says"
        if why:
            raise MonteCarloError(f"--resume: {f}: {why}; refused. Remove the file to compute "
                                  "that replicate again, or run without --resume")
        return doc

    def _write_marker(self) -> None:
        atomic_write_text(self.path / MARKER, json.dumps({**self.identity, "pid": os.getpid()},
                                                         indent=2))

    def write(self, doc: dict) -> None:
        if not (self.path / MARKER).exists():
            self.path.mkdir(parents=True, exist_ok=True)
            self._write_marker()
        body = {k: v for k, v in _clean(doc).items() if k != "sha256"}
        body["scenario_sha256"] = self.identity["scenario_sha256"]
        body["sha256"] = _doc_sha256(body)
        atomic_write_text(self.path / f"r{doc['replicate']:05d}.json", json.dumps(body))

    def copy_into(self, run_tmp: Path, keep: list[int]) -> None:
        """Copy the replicates ``keep`` into the new run directory; the work folder stays until
        the run directory is in place (:meth:`remove`), so a failed rename loses nothing."""
        dest = run_tmp / "replicates"
        dest.mkdir()
        for r in keep:
            f = self.path / f"r{r:05d}.json"
            if f.exists():
                shutil.copyfile(f, dest / f.name)
        atomic_write_text(dest / "identity.json", json.dumps(self.identity, indent=2))

    def remove(self) -> None:
        self._claim.remove()

    def remove_if_empty(self) -> None:
        """After a failure before any replicate was stored: leave nothing behind."""
        if self.path.is_dir() and not any(self.path.glob("r*.json")):
            self.remove()
        else:
            self.release()


def _doc_sha256(doc: dict) -> str:
    """SHA-256 of a replicate file's content without its ``sha256`` key (canonical JSON)."""
    body = {k: v for k, v in doc.items() if k != "sha256"}
    return hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":"))
                          .encode()).hexdigest()


def _read_json(path: Path):
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError, RecursionError):
        return None
