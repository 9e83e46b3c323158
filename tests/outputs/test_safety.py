"""The bench never destroys or escapes: a user's files stay byte-identical whatever --out or a
scenario's names say, bad input is refused before any work with file, key and reason, and an
interrupted command leaves no temporary folders behind."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fogbench.cli import main
from helpers import SMALL_SCENARIO as SCENARIO, run_cli
from fogbench.outputs.folders import MARKER
from fogbench.scenario import ScenarioError, load_plan, load_scenario
from fogbench.scenario.load import RUNNER_SECTIONS

ROOT = Path(__file__).resolve().parents[2]


def snapshot(root: Path) -> dict[str, str]:
    """Every file under ``root`` (hidden ones included) with its SHA-256."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


cli = run_cli


@pytest.fixture
def home(tmp_path):
    """A user's folder: a scenario, a thesis folder, a notes file."""
    (tmp_path / "thesis").mkdir()
    (tmp_path / "thesis" / "ch1.tex").write_text("\\chapter{FOG}\n")
    (tmp_path / "notes.txt").write_text("do not lose me\n")
    (tmp_path / "scn").mkdir()
    (tmp_path / "scn" / "tiny.toml").write_text(SCENARIO)
    (tmp_path / "scn" / "my_notes.md").write_text("notes beside the scenario\n")
    return tmp_path


# --- --out never replaces what it did not write ------------------------------------------------
@pytest.mark.parametrize("out", ["thesis", "notes.txt", "..", ".", "/proc/x", "", "scn"])
@pytest.mark.parametrize("command", ["run", "simulate"])
def test_out_that_is_not_ours_is_refused_and_left_identical(home, out, command):
    before = snapshot(home)
    extra = ["--no-recording"] if command == "run" else []
    code, stdout, stderr = cli(command, str(home / "scn" / "tiny.toml"), "--out", out, "--quiet",
                               *extra, cwd=home)
    assert code == 2, stderr
    assert stderr.startswith("fogbench: error: --out") and "Traceback" not in stderr
    assert stderr.count("\n") == 1  # one line
    assert snapshot(home) == before  # nothing written, nothing removed or renamed
    assert not [p for p in home.parent.iterdir() if p.name.startswith(f".{home.name}.")]


def test_run_replaces_only_its_own_directory_and_cleans_stale_parts(home):
    out = home / "out"
    code, _, err = cli("run", "scn/tiny.toml", "--out", "out", "--quiet", "--no-recording",
                       cwd=home)
    assert code == 0, err
    marker = json.loads((out / MARKER).read_text())
    assert marker["kind"] == "run" and marker["scenario"] == "tiny"
    # a leftover of a killed run (ours: marker, dead pid) and a folder of the user's alike
    stale = home / ".out.abc123.part"
    stale.mkdir()
    (stale / MARKER).write_text(json.dumps({"kind": "run", "pid": 2**22 + 12345}))
    users = home / ".out.mine.part"
    users.mkdir()
    (users / "keep.txt").write_text("mine")
    (out / "extra_from_old_run.txt").write_text("x")
    code, _, err = cli("run", "scn/tiny.toml", "--out", "out", "--quiet", "--no-recording",
                       cwd=home)
    assert code == 0, err
    assert not stale.exists()                       # our own leftover: removed
    assert (users / "keep.txt").read_text() == "mine"  # not ours: untouched
    assert not (out / "extra_from_old_run.txt").exists()  # our old run dir: replaced whole
    assert (out / "metrics.json").exists()


def test_simulate_into_a_run_directory_is_refused(home):
    assert cli("run", "scn/tiny.toml", "--out", "r", "--quiet", "--no-recording",
               cwd=home)[0] == 0
    before = snapshot(home)
    code, _, err = cli("simulate", "scn/tiny.toml", "--out", "r", "--quiet", cwd=home)
    assert code == 2 and "fogbench run directory, not a simulation directory" in err
    assert snapshot(home) == before


# --- names that become paths ---------------------------------------------------------------------
@pytest.mark.parametrize("where,old,new", [
    ("[scenario]", 'name = "tiny"', 'name = "../scn"'),
    ("[scenario]", 'name = "tiny"', 'name = ""'),
    ("[scenario]", 'name = "tiny"', 'name = "."'),
    ("[scenario]", 'name = "tiny"', 'name = "a/b"'),
    ("[[runs]]", 'name = "a"', 'name = "../../x"'),
    ("[[protocols]]", 'name = "p"', 'name = "p/../../q"'),
    ("[[methods]]", 'name = "wavelet_soft"', 'name = "wavelet_soft"\nlabel = "../w"'),
])
def test_path_like_names_are_refused_at_load(home, where, old, new):
    p = home / "scn" / "tiny.toml"
    p.write_text(SCENARIO.replace(old, new, 1))
    before = snapshot(home)
    for args in (["run", str(p), "--no-recording"], ["simulate", str(p), "--out", "o"],
                 ["suite", "--scenarios", "scn", "--out", "rep", "--no-recording"]):
        code, _, err = cli(*args, "--quiet", cwd=home)
        assert code in (1, 2), err
        assert "tiny.toml" in err and where.strip("[]") in err and "name" in err
        assert "Traceback" not in err
        assert snapshot(home) == before


def test_two_scenarios_with_one_name_are_refused_by_the_suite(home):
    (home / "scn" / "copy.toml").write_text(SCENARIO)
    before = snapshot(home)
    code, _, err = cli("suite", "--scenarios", "scn", "--out", "rep", "--quiet", cwd=home)
    assert code == 2 and "names must be unique" in err
    assert "copy.toml" in err and "tiny.toml" in err
    assert snapshot(home) == before


def test_suite_never_overwrites_a_readme_it_did_not_write(home):
    (home / "rep").mkdir()
    (home / "rep" / "README.md").write_text("# my own report folder\n")
    before = snapshot(home)
    code, _, err = cli("suite", "--scenarios", "scn", "--out", "rep", "--quiet", cwd=home)
    assert code == 2 and "not a fogbench suite summary" in err
    assert snapshot(home) == before


# --- refused at load ------------------------------------------------------------------------------
BAD = [
    ('rate_dps = 10.0\nduration_s = 30.0',
     'rates_dps = [nan, 10.0]\nstep_s = 15.0', 'rate_steps', ["rates_dps", "finite", "index 0"]),
    ('preset = "tactical"', 'preset = "tactical"\ng_sens_dph_per_g = [nan, 0.0, 1.0]', None,
     ["g_sens_dph_per_g", "finite"]),
    ('preset = "tactical"', 'preset = "tactical"\ng2_sens_dph_per_g2 = [0, 0, inf, 0, 0, 0]', None,
     ["g2_sens_dph_per_g2", "finite"]),
    ('preset = "tactical"',
     'preset = "tactical"\nmisalignment_mrad = [[0, nan, 0], [0, 0, 0], [0, 0, 0]]', None,
     ["misalignment_mrad", "finite"]),
    ('fit = ["a"]', 'fit = [{ run = "a", segments = [0.5] }]', None,
     ["segments", "integers"]),
    ('preset = "tactical"', 'preset = "tactical"\narw_deg_rt_h = 1e12', None,
     ["arw_deg_rt_h", "<= 100"]),
    ('preset = "tactical"', 'preset = "tactical"\nbias_dph = -1e9', None,
     ["bias_dph", ">= -100000"]),
    ('duration_s = 30.0\n\n[[runs]]', 'duration_s = 1e9\n\n[[runs]]', None,
     ["samples", "limit", "'a'"]),
    ('name = "wavelet_soft"', 'name = "wavelet_soft"\nparams = { level = "four" }', None,
     ["[[methods]]", "wavelet_soft", "level"]),
    ('name = "wavelet_soft"', 'name = "wavelet_soft"\nparams = { wavelet = "db99" }', None,
     ["[[methods]]", "wavelet_soft", "wavelet"]),
    ('name = "wavelet_soft"', 'name = "kalman"\nparams = { smoother = "yes" }', None,
     ["[[methods]]", "kalman", "smoother"]),
    ('name = "wavelet_soft"', 'name = "kalman"\nparams = { arw_rad_rt_s = nan }', None,
     ["[[methods]]", "kalman", "arw_rad_rt_s"]),
]


@pytest.mark.parametrize("old,new,kind,words", BAD, ids=[b[3][0] for b in BAD])
def test_bad_values_are_refused_at_load_naming_file_and_key(home, old, new, kind, words):
    text = SCENARIO.replace(old, new, 1)
    if kind:
        text = text.replace('type = "rate"', f'type = "{kind}"', 1)
    assert text != SCENARIO
    p = home / "scn" / "tiny.toml"
    p.write_text(text)
    t0 = time.monotonic()
    with pytest.raises(ScenarioError) as exc:
        load_plan(load_scenario(p, extra_sections=RUNNER_SECTIONS))
    assert time.monotonic() - t0 < 30  # refused, not simulated (a generous bound, not a timing)
    msg = str(exc.value)
    assert msg.startswith(str(p))
    for w in words:
        assert w in msg, f"{w!r} not in {msg}"


@pytest.mark.parametrize("content,words", [
    (SCENARIO.replace('[fog]', '# Température de la chambre\n[fog]').encode("latin-1"),
     ["line 6", "not UTF-8"]),
    (bytes(range(256)) * 4, ["line 2, column 118", "not UTF-8", "0x80"]),
])
def test_non_utf8_files_are_refused_naming_the_file_and_line(home, content, words):
    p = home / "scn" / "tiny.toml"
    p.write_bytes(content)
    code, _, err = cli("check", str(p))
    assert code == 2 and str(p) in err and "Traceback" not in err
    for w in words:
        assert w in err


def test_check_a_folder_checks_every_scenario_in_it(home):
    """``fogbench check DIR`` reads every *.toml of the folder (as the suite does), reports each,
    and exits 2 when one is bad; an empty folder is an error, not a silent success."""
    (home / "scn" / "broken.toml").write_text(SCENARIO.replace('preset = "tactical"',
                                                               'preset = "nope"'))
    code, out, err = cli("check", "scn", cwd=home)
    assert code == 2
    assert "tiny.toml: ok" in out and "broken.toml" in err and "nope" in err
    (home / "empty").mkdir()
    code, out, err = cli("check", "empty", cwd=home)
    assert code == 2 and "no scenario file" in err
    # two files with one scenario name: refused as the suite refuses them
    (home / "scn" / "broken.toml").unlink()
    (home / "scn" / "copy.toml").write_text(SCENARIO)
    code, out, err = cli("check", "scn", cwd=home)
    assert code == 2 and "'tiny'" in err and "unique" in err


def test_a_suite_says_at_once_why_a_scenario_is_not_run(home):
    """Replicates an interrupted run left are kept (never deleted unasked): the next suite
    without --resume does not run that scenario, says why before the others start, and ends
    with a non-zero status."""
    left = home / "rep" / ".tiny.replicates"
    left.mkdir(parents=True)
    (left / ".fogbench.json").write_text('{"kind": "replicates", "pid": 999999999}')
    (left / "r00001.json").write_text("{}")
    before = snapshot(left)
    (home / "scn" / "other.toml").write_text(SCENARIO.replace('name = "tiny"', 'name = "other"'))
    code, _, err = cli("suite", "--scenarios", "scn", "--out", "rep", "--no-recording",
                       cwd=home)
    assert code != 0
    first = err.index("tiny is not run")
    assert "--resume" in err[first:first + 400]
    assert first < err.index("fogbench suite: 1 scenario(s)")     # before the work starts
    assert (home / "rep" / "other" / "metrics.json").exists()    # the other one ran
    assert snapshot(left) == before


def test_a_utf8_byte_order_mark_is_accepted(home):
    p = home / "scn" / "tiny.toml"
    p.write_bytes(b"\xef\xbb\xbf" + SCENARIO.encode())
    assert load_scenario(p, extra_sections=RUNNER_SECTIONS).name == "tiny"


def test_a_broken_file_in_the_suite_folder_does_not_stop_a_named_scenario(home):
    (home / "scn" / "broken.toml").write_bytes(b"[scenario]\nname = \"\xff\"\n")
    code, _, err = cli("suite", "--scenarios", "scn", "--scenario", "tiny", "--out", "rep",
                       "--quiet", "--no-recording", cwd=home)
    assert code == 0, err
    assert "skipped" in err and "broken.toml" in err
    assert (home / "rep" / "tiny" / "metrics.json").exists()


# --- a valid scenario must not crash --------------------------------------------------------------
def test_short_run_with_thermal_section_writes_its_report(home, tmp_path):
    p = home / "scn" / "tiny.toml"
    p.write_text(SCENARIO.replace("[[runs]]", "[thermal]\nstart_c = 20.0\n[[thermal.steps]]\n"
                                  "ramp_to_c = 25.0\nrate_c_per_min = 10.0\n\n[[runs]]", 1))
    code, _, err = cli("run", str(p), "--out", "o", "--quiet", "--no-recording", cwd=home)
    assert code == 0, err
    assert (home / "o" / "report.md").exists() and (home / "o" / "metrics.json").exists()


# --- the command line ------------------------------------------------------------------------------
@pytest.mark.parametrize("args,flag", [
    (["bench", "--seconds", "0"], "--seconds"), (["bench", "--seconds", "-1"], "--seconds"),
    (["bench", "--seconds", "nan"], "--seconds"), (["bench", "--repeats", "0"], "--repeats"),
    (["suite", "--jobs", "0"], "--jobs"), (["suite", "--jobs", "-1"], "--jobs"),
    (["suite", "--jobs", "two"], "--jobs"),
])
def test_every_flag_is_validated_naming_it(args, flag, capsys):
    with pytest.raises(SystemExit) as exc:
        main(args)
    assert exc.value.code == 2
    assert flag in capsys.readouterr().err


def test_simulate_unknown_run_is_bad_input_exit_2_before_any_work(home):
    before = snapshot(home)
    code, _, err = cli("simulate", "scn/tiny.toml", "--out", "o", "--run", "nope", cwd=home)
    assert code == 2 and "--run" in err and "nope" in err
    assert snapshot(home) == before


def _part_dirs(root: Path) -> list[Path]:
    return [p for p in root.rglob(".*") if p.name.endswith((".part", ".old"))]


def _signal_suite(cwd, sig, ready, *, wait_s, after_s, timeout_s, hung, script=False):
    """Start ``fogbench suite`` on ``cwd/scn`` with two workers, wait until ``ready(stderr so
    far)`` (at most ``wait_s``), then ``after_s`` more, and signal it: SIGINT to the whole
    process group (as Ctrl-C does), SIGTERM to the main process. Returns (exit status, stderr
    before the signal, stderr after); fails the test if it does not end within ``timeout_s``.
    ``script``: run the installed console script (as a user types ``fogbench``), whose main
    module the forkserver imports again before it forks the workers."""
    exe = [str(Path(sys.executable).with_name("fogbench"))] if script else \
        [sys.executable, "-m", "fogbench"]
    proc = subprocess.Popen([*exe, "suite", "--scenarios", "scn",
                             "--out", "rep", "--jobs", "2", "--no-recording"], cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    t0 = time.monotonic()
    seen = ""
    while time.monotonic() - t0 < wait_s and not ready(seen):
        line = proc.stderr.readline()
        if not line:
            break
        seen += line
    time.sleep(after_s)
    if sig == signal.SIGINT:
        os.killpg(proc.pid, signal.SIGINT)
    else:
        proc.send_signal(signal.SIGTERM)
    try:
        _, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail(hung)
    return proc.returncode, seen, err


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupted_suite_exits_cleanly_and_leaves_no_temporary_folders(home, sig, code):
    """Ctrl-C or SIGTERM while two workers simulate: the main process ends the workers, says so
    in one line, no worker prints a traceback, and no hidden .part folder is left."""
    # 300 s of table motion: about 1 s of MuJoCo per run here, so the signal lands mid-way
    long = SCENARIO.replace("duration_s = 30.0", "duration_s = 300.0").replace(
        'type = "hold"', 'type = "rate"\nrate_dps = 5.0')
    (home / "scn" / "tiny.toml").write_text(long)
    (home / "scn" / "tiny2.toml").write_text(long.replace('name = "tiny"', 'name = "tiny2"'))
    # signal once both workers are simulating
    returncode, seen, err = _signal_suite(home, sig, lambda seen: seen.count("simulate") >= 2,
                                          wait_s=60, after_s=0.5, timeout_s=60,
                                          hung="the suite hung after the signal")
    err = seen + err
    assert returncode == code, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert _part_dirs(home) == []


SLOW = """
[scenario]
name = "slow"
sample_rate_hz = 10.0
[fog]
preset = "tactical"
[thermal]
start_c = 20.0
[[thermal.steps]]
ramp_to_c = 25.0
rate_c_per_min = 10.0
[[runs]]
name = "a"
seed = 1
[[runs.motion]]
type = "hold"
duration_s = 60.0
[[runs]]
name = "b"
seed = 2
[[runs.motion]]
type = "hold"
duration_s = 60.0
[[protocols]]
name = "p"
fit = ["a"]
score = ["b"]
[[methods]]
name = "bp"
params = { max_epochs = 5000000, goal = 0.0 }
[montecarlo]
replicates = 3
"""


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupt_stops_workers_in_the_middle_of_a_replicate(tmp_path, sig, code):
    """The workers are busy with replicates that take minutes (5 million epochs of gradient
    descent) when the signal comes: the suite ends them and exits at once with its one line,
    instead of waiting at exit for the replicates in flight (Python 3.11's pool forgets its
    workers on shutdown)."""
    (tmp_path / "scn").mkdir()
    (tmp_path / "scn" / "slow.toml").write_text(SLOW)
    # replicate 0 fits here while the others are in the pool
    returncode, seen, err = _signal_suite(tmp_path, sig, lambda seen: "fit bp" in seen,
                                          wait_s=120, after_s=1.0, timeout_s=30,
                                          hung="the suite waited for the replicates in flight "
                                               "after the signal")
    assert "fit bp" in seen, seen
    assert returncode == code, seen + err
    assert ("interrupted" if sig == signal.SIGINT else "terminated (SIGTERM)") in err
    # no traceback from fogbench's code (under load, multiprocessing's own helper process has
    # been seen to print a BrokenPipeError as the pool is torn down: not ours to silence)
    assert "KeyboardInterrupt" not in err and "fogbench/" not in err, err
    assert _part_dirs(tmp_path) == []


@pytest.mark.parametrize("name", ["allan.json", "allan_gyro_z_dps.png"])
def test_two_options_naming_one_output_file_are_refused_and_nothing_is_written(tmp_path, name):
    """allan --out D --kalibr D/allan.json: the Kalibr file and the folder's allan.json (or a
    figure) are one file; the second write would replace the first without a word."""
    import numpy as np

    log = tmp_path / "log.csv"
    rng = np.random.default_rng(1)
    t = np.arange(2000) / 100.0
    lines = ["time_s,gyro_z_dps"] + [f"{a:.2f},{b:.6e}" for a, b in
                                     zip(t, rng.normal(0, 0.01, t.size))]
    log.write_text("\n".join(lines) + "\n")
    before = snapshot(tmp_path)
    code, _, err = cli("allan", str(log), "--out", str(tmp_path / "d"), "--kalibr",
                       str(tmp_path / "d" / name))
    assert code == 2, err
    assert "--out and --kalibr both write this file" in err or \
        "--kalibr and --out both write this file" in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert snapshot(tmp_path) == before


def test_an_error_names_the_line_of_the_file_when_blank_lines_lie_between_rows(tmp_path):
    """pandas skips blank lines: row k is then not line k + 2 of the file."""
    log = tmp_path / "log.csv"
    rows = [f"{i},0.1,{20 + i % 7},1" for i in range(100)]
    rows[40] += "\n"                      # one blank line after row 40 (line 42)
    rows[70] += "\n\n"                    # two after row 70
    rows.append("100,0.1,20,x")           # the bad cell: line 2 + 100 + 3 blank lines = 105
    log.write_text("time_s,gyro_z_dps,temp_c,table_rate_dps\n" + "\n".join(rows) + "\n")
    assert log.read_text().splitlines()[104] == "100,0.1,20,x"     # line 105, counted by hand
    before = snapshot(tmp_path)
    # the reference column is read by calibrate itself (it once crashed there: TypeError)
    code, _, err = cli("calibrate", "poly_temp", str(log), "--reference", "table_rate_dps",
                       "--out", str(tmp_path / "m"))
    assert code == 2, err
    assert "line 105, column 'table_rate_dps': non-numeric value 'x'" in err, err
    # and by the reader, for a column of the log
    code, _, err = cli("allan", str(log), "--column",
                       "gyro_z=table_rate_dps:dps")
    assert code == 2 and "line 105" in err, err
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("moment", range(10))
def test_the_suite_stopped_at_any_of_ten_moments_prints_no_traceback(home, moment):
    """SIGINT to the process group or SIGTERM to the main process at ten moments of a suite on
    two workers (while they start, simulate, fit, score and as the reports are written): one
    line, 130 or 143, never a worker's traceback. Run as the console script: the forkserver
    imports its main module, and with it the command line's signal handlers, which the workers
    then inherited (a SIGTERM from the parent raised Terminated in a worker's loop, whose
    traceback multiprocessing printed); a worker's SIGTERM now ends it silently."""
    long = SCENARIO.replace("duration_s = 30.0", "duration_s = 120.0").replace(
        'type = "hold"', 'type = "rate"\nrate_dps = 5.0')
    (home / "scn" / "tiny.toml").write_text(long)
    (home / "scn" / "tiny2.toml").write_text(long.replace('name = "tiny"', 'name = "tiny2"'))
    sig = signal.SIGINT if moment % 2 == 0 else signal.SIGTERM
    returncode, seen, err = _signal_suite(home, sig, lambda seen: "suite" in seen,
                                          wait_s=60, after_s=0.4 * moment, timeout_s=60,
                                          hung="the suite hung after the signal", script=True)
    err = seen + err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert returncode in ((130 if sig == signal.SIGINT else 143), 0), err
    assert _part_dirs(home) == []


def test_a_worker_ends_on_sigterm_silently_whatever_handler_it_inherited():
    """A worker whose process inherited the command line's handlers (the forkserver imports
    the console script's main module, and with it fogbench.cli, which installs them) is set by
    the pool's initializer to end on SIGTERM without raising Terminated in its loop (whose
    traceback multiprocessing would print)."""
    code = ("import os, signal, sys, time\n"
            "from fogbench.outputs import interrupts\n"
            "interrupts.install()\n"
            "from fogbench.run.engines import _worker_init\n"
            "_worker_init(os.getppid())\n"
            "print(signal.getsignal(signal.SIGTERM) == signal.SIG_DFL, flush=True)\n"
            "time.sleep(30)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "True"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == -signal.SIGTERM and err == ""
