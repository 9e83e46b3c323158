"""The never-replace rule at the moment of writing: a file that appears where a command will
write, or changes there, after the command checked the place and before it puts its outputs in
place, is left as it is and nothing is written; the command ends with the one error line."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from fogbench.outputs.folders import Outputs, OutDirError


def _own(path: Path) -> bool:
    return path.read_text().startswith("# mine")


def test_a_file_that_appears_before_the_commit_survives_and_nothing_is_written(tmp_path):
    out = Outputs(False, "device fit")
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    out.target(a, recognise=_own)
    out.target(b, recognise=_own)
    out.write_text(a, "# mine a\n")
    out.write_text(b, "# mine b\n")
    b.write_text("the user's own\n")            # saved while the command ran
    with pytest.raises(OutDirError, match="appeared or changed"):
        out.commit()
    out.discard()
    assert b.read_text() == "the user's own\n"
    assert not a.exists()                        # all or nothing
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.toml"]


def test_a_file_replaced_only_while_it_is_still_the_one_checked(tmp_path):
    p = tmp_path / "dev.toml"
    p.write_text("# mine, an earlier fit\n")
    out = Outputs(True, "device fit")
    out.target(p, recognise=_own)
    out.write_text(p, "# mine, the new fit\n")
    p.write_text("# mine, but edited by the user meanwhile\n")
    os.utime(p, ns=(1, 1))                       # a different modification time, for sure
    with pytest.raises(OutDirError, match="appeared or changed"):
        out.commit()
    out.discard()
    assert p.read_text() == "# mine, but edited by the user meanwhile\n"
    # and without interference the same replacement goes through
    out = Outputs(True, "device fit")
    out.target(p, recognise=_own)
    out.write_text(p, "# mine, the new fit\n")
    out.commit()
    assert p.read_text() == "# mine, the new fit\n"


def test_two_commands_into_one_output_the_second_is_refused(tmp_path):
    p = tmp_path / "dev.toml"
    first, second = Outputs(False, "device fit"), Outputs(False, "device fit")
    first.target(p, recognise=_own)
    second.target(p, recognise=_own)             # both checked while it was absent
    first.write_text(p, "# mine, the first\n")
    second.write_text(p, "# mine, the second\n")
    first.commit()
    with pytest.raises(OutDirError):
        second.commit()
    second.discard()
    assert p.read_text() == "# mine, the first\n"
    assert [q.name for q in tmp_path.iterdir()] == ["dev.toml"]
