"""External commands' output: a run ends with the command, not with its leftovers, and reads a bounded amount.

`filmcal._parallel.run_guarded` waits for the command's own process (its
output goes to temporary files, not pipes that a background child would keep
open) and reads back at most the last `OUTPUT_CAP_BYTES` of each stream; a
campaign point whose JSON answer would be read from a truncated stdout fails
with the size in its reason.
"""
from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

import pytest

from filmcal._parallel import SerialExecutor, guarded, pid_alive, processes, run_guarded
from filmcal.campaign import Campaign, CommandModel, RunStore
from filmcal.campaign.command import ModelFailure


def wait_dead(pid: int, within_s: float = 3.0) -> bool:
    deadline = time.monotonic() + within_s
    while pid_alive(pid) and time.monotonic() < deadline:
        time.sleep(0.02)
    return not pid_alive(pid)


def run_point(tmp_path: Path, script: str, timeout_s: float | None = 30) -> tuple:
    """Run `script` (Python) as a one-point campaign; return its stored record and its work folder."""
    (tmp_path / "model.py").write_text(script + "\n")
    model = CommandModel(f"{sys.executable} {tmp_path / 'model.py'} {{x}}", tmp_path / "work", timeout_s=timeout_s)
    Campaign(model, tmp_path / "runs.sqlite", settings=model.settings(), executor=SerialExecutor(),
             group_by=()).run([{"x": 1.0}], progress=False)
    with RunStore(tmp_path / "runs.sqlite", readonly=True) as store:
        (record,) = store.records()
    (folder,) = (tmp_path / "work").iterdir()
    return record, folder


@pytest.mark.parametrize("timeout_s", [None, 10.0])
def test_a_background_child_neither_holds_up_the_point_nor_outlives_it(tmp_path, timeout_s):
    model = CommandModel("sleep 30 & echo $! > bg.pid; echo '{\"contact_radius_mm\": 1.0}'", tmp_path / "work",
                         timeout_s=timeout_s)
    start = time.monotonic()
    outputs = model({"x": 1.0}, point_id="p1")
    assert time.monotonic() - start < 8.0  # it used to wait the 30 s of the child (a timeout with a deadline)
    assert outputs == {"contact_radius_mm": 1.0}
    background = int((tmp_path / "work" / "p1" / "bg.pid").read_text())
    assert wait_dead(background)  # killed with the command's process group


@pytest.fixture
def escaper(tmp_path):
    """Run a command whose grandchild leaves the process group (setsid) and sleeps 30 s, started by
    `launcher` (e.g. ``env -i``); returns (run, seconds, the grandchild's pid). Kills it afterwards."""
    pid_file = tmp_path / "escaped.pid"

    def run(launcher: str = ""):
        escape = ("import os, pathlib, time; os.setsid(); pathlib.Path('escaped.pid').write_text(str(os.getpid())); "
                  "time.sleep(30)")
        command = (f"{launcher} {sys.executable} -c \"{escape}\" & "
                   "while [ ! -s escaped.pid ]; do sleep 0.01; done; echo done")
        start = time.monotonic()
        result = run_guarded(command, shell=True, cwd=tmp_path, timeout_s=10)
        assert not result.timed_out, result.stderr  # the grandchild never wrote its pid
        return result, time.monotonic() - start, int(pid_file.read_text())

    yield run
    if pid_file.exists() and pid_file.read_text():
        try:
            os.kill(int(pid_file.read_text()), signal.SIGKILL)
        except ProcessLookupError:
            pass


def test_a_grandchild_that_left_the_group_neither_holds_up_the_run_nor_outlives_it(escaper):
    """`setsid` takes a process out of the command's group; the run's mark in its environment still finds it."""
    run, seconds, escaped = escaper()
    assert seconds < 8.0
    assert (run.returncode, run.stdout, run.timed_out) == (0, "done\n", False)
    if sys.platform.startswith("linux"):
        assert wait_dead(escaped)


@pytest.mark.parametrize("launcher", ["env -i", "env -u FILMCAL_RUN_MARK"])
def test_a_grandchild_started_without_the_mark_outlives_the_run_but_does_not_hold_it_up(escaper, launcher):
    """The documented way out for a helper meant to outlive the run (and the limit: ``env -i``)."""
    run, seconds, escaped = escaper(launcher)
    assert seconds < 8.0
    assert (run.returncode, run.stdout) == (0, "done\n")
    if sys.platform.startswith("linux"):  # pid_alive reads /proc
        assert pid_alive(escaped)  # nothing marked it


def test_a_run_inside_a_run_keeps_the_outer_runs_mark(tmp_path, monkeypatch):
    """filmcal inside a guarded command: the inner command's processes carry both marks, so the outer sweep
    reaches them too."""
    monkeypatch.setenv(processes.RUN_MARK_VARIABLE, "outer")
    run = run_guarded([sys.executable, "-c", f"import os; print(os.environ['{processes.RUN_MARK_VARIABLE}'])"])
    outer, inner = run.stdout.strip().split(":")
    assert outer == "outer" and len(inner) == 24


def test_a_cancelled_task_still_stops_its_command(tmp_path):
    guarded._task_context.cancelled = lambda: True
    try:
        start = time.monotonic()
        run = run_guarded("sleep 30 & echo $! > bg.pid; wait", shell=True, cwd=tmp_path)
    finally:
        guarded._task_context.cancelled = None
    assert run.timed_out and run.returncode is None
    assert time.monotonic() - start < 5.0
    assert wait_dead(int((tmp_path / "bg.pid").read_text()))


def test_run_guarded_keeps_the_end_of_a_stream_longer_than_the_cap(tmp_path, monkeypatch):
    monkeypatch.setattr(guarded, "OUTPUT_CAP_BYTES", 1000)
    run = run_guarded([sys.executable, "-c", "import sys; print('x' * 6000); print('{\"r_mm\": 1.0}'); "
                       "sys.stderr.write('é' * 1000 + 'a')"])
    assert (run.stdout_bytes, run.stdout_truncated, len(run.stdout.encode())) == (6015, True, 1000)
    assert run.stdout.endswith('x\n{"r_mm": 1.0}\n')
    # 2001 bytes, cut inside a character: the partial character is dropped, not replaced
    assert (run.stderr_bytes, run.stderr_truncated, run.stderr) == (2001, True, "é" * 499 + "a")
    small = run_guarded([sys.executable, "-c", "print('x' * 998)"])  # 999 bytes: all of it
    assert (small.stdout_bytes, small.stdout_truncated, small.stdout) == (999, False, "x" * 998 + "\n")


def test_more_stdout_than_filmcal_reads_fails_the_point_with_its_size(tmp_path, monkeypatch):
    monkeypatch.setattr(guarded, "OUTPUT_CAP_BYTES", 1000)
    record, folder = run_point(tmp_path, "print('x' * 6000); print('{\"r_mm\": 1.0}')")
    assert record.status == "failed", record.outputs
    assert "the command wrote 5.9 KiB on stdout, more than the 1000 bytes filmcal reads" in record.reason
    saved = (folder / "stdout.txt").read_text()
    assert saved.startswith("[filmcal: the command wrote 5.9 KiB here; only the last 1000 bytes were read")
    assert saved.endswith('{"r_mm": 1.0}\n') and len(saved) < 1200


def test_long_output_is_fine_when_the_answer_is_in_outputs_json(tmp_path, monkeypatch):
    monkeypatch.setattr(guarded, "OUTPUT_CAP_BYTES", 1000)
    record, _ = run_point(tmp_path, "import sys; open('outputs.json', 'w').write('{\"r_mm\": 4.0}'); "
                                    "print('x' * 6000); sys.stderr.write('y' * 6000)")
    assert (record.status, record.outputs) == ("ok", {"r_mm": 4.0})


def test_a_failure_with_long_stderr_reports_its_end(tmp_path, monkeypatch):
    monkeypatch.setattr(guarded, "OUTPUT_CAP_BYTES", 1000)
    record, folder = run_point(tmp_path, "import sys; print('x' * 6000); "
                                         "sys.stderr.write('\\n'.join(f'line {i}' for i in range(500))); sys.exit(1)")
    assert record.status == "failed"
    assert "exit status 1); stderr: line 495 | line 496 | line 497 | line 498 | line 499" in record.reason
    assert "wrote" not in record.reason  # the exit status is the reason, not the long stdout
    assert (folder / "stderr.txt").read_text().startswith("[filmcal: the command wrote 4.3 KiB here")


def test_a_model_failure_names_the_size_when_called_directly(tmp_path, monkeypatch):
    monkeypatch.setattr(guarded, "OUTPUT_CAP_BYTES", 2**20)
    model = CommandModel(f"{sys.executable} -c \"print('x' * (3 * 2**20))\"", tmp_path / "work")
    with pytest.raises(ModelFailure, match=r"wrote 3 MiB on stdout, more than the 1 MiB filmcal reads"):
        model({"x": 1.0}, point_id="p1")


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="the sweep reads /proc")
def test_the_sweep_kills_a_process_that_carries_the_mark_among_others_and_no_other():
    import subprocess

    env = dict(os.environ, **{processes.RUN_MARK_VARIABLE: "outer:inner"})
    marked = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"], env=env)
    try:
        time.sleep(0.2)
        assert processes._kill_marked("other") == 0 and processes._kill_marked("inn") == 0
        assert marked.poll() is None
        assert processes._kill_marked("outer") >= 1
        assert marked.wait(timeout=5) == -signal.SIGKILL
    finally:
        marked.kill()
        marked.wait()


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="the sweep reads /proc")
def test_the_sweep_reads_no_process_in_uninterruptible_sleep_and_kills_it_when_it_wakes(monkeypatch):
    """Reading a process's environment waits for its memory map's lock, which a process in state D may hold:
    the sweep must not read one while it is asleep (here its state is faked), and kills it once it wakes."""
    import builtins
    import subprocess

    env = dict(os.environ, **{processes.RUN_MARK_VARIABLE: "sleeper"})
    marked = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"], env=env)
    pid = str(marked.pid)
    wakes_at = time.monotonic() + 0.35
    real_state, real_open, reads_asleep = processes._process_state, builtins.open, []

    def state(entry):
        return "D" if entry.name == pid and time.monotonic() < wakes_at else real_state(entry)

    def watched_open(path, *args, **kwargs):
        if str(path) == f"/proc/{pid}/environ" and time.monotonic() < wakes_at:
            reads_asleep.append(path)
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr(processes, "_process_state", state)
    monkeypatch.setattr(builtins, "open", watched_open)
    try:
        time.sleep(0.2)
        assert processes._kill_marked("sleeper", asleep_wait_s=0.0) == 0  # asleep past the wait: left alone
        assert marked.poll() is None
        wakes_at = time.monotonic() + 0.35
        assert processes._kill_marked("sleeper", asleep_wait_s=2.0) == 1
        assert marked.wait(timeout=5) == -signal.SIGKILL
        assert reads_asleep == []
    finally:
        marked.kill()
        marked.wait()
