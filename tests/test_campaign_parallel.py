"""The executor abstraction `filmcal._parallel`: outcomes as they complete, deadlines, interrupts, orphans.

Worker processes import the task functions of this module by name.
"""
from __future__ import annotations

import _thread
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from filmcal._parallel import (
    LocalPoolExecutor,
    SerialExecutor,
    TaskTimeoutError,
    WorkerDiedError,
    open_executor,
    run_guarded,
)

TESTS_DIR = Path(__file__).resolve().parent


def square_or_misbehave(x: float) -> float:
    """x^2, except: 3 sleeps 30 s, 4 raises, 5 kills its worker, 6 finishes last but in time."""
    if x == 3:
        time.sleep(30)
    if x == 4:
        raise ValueError("four is not allowed")
    if x == 5:
        os._exit(7)
    if x == 6:
        time.sleep(1.0)
    return x * x


def sleep_s(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def _stat(pid: int) -> list[str] | None:
    """Fields of /proc/<pid>/stat after the command name (state, ppid, ...), or None if gone."""
    try:
        with open(f"/proc/{pid}/stat") as stream:
            return stream.read().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None


def alive(process: int | tuple[int, str]) -> bool:
    """True if the process exists and is not a zombie.

    `process` is a pid, or a ``(pid, start time)`` identity from `descendants`,
    which does not mistake a new process that reuses the pid for the old one.
    """
    pid, started = process if isinstance(process, tuple) else (process, None)
    fields = _stat(pid)
    if fields is None or fields[0] == "Z":
        return False
    return started is None or fields[19] == started


def descendants(root: int) -> set[tuple[int, str]]:
    """Identities ``(pid, start time)`` of all living descendants of `root` (from /proc)."""
    children: dict[int, list[tuple[int, str]]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            fields = _stat(int(entry))
            if fields is not None and len(fields) > 19:
                children.setdefault(int(fields[1]), []).append((int(entry), fields[19]))
    found: set[tuple[int, str]] = set()
    todo = [root]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child[0])
    return found


@pytest.fixture(scope="module")
def pool():
    with LocalPoolExecutor(2) as executor:
        yield executor


@pytest.mark.slow(reason="3 s: a 2 s deadline and a replaced worker")
def test_map_unordered_yields_every_outcome_as_it_completes(pool):
    progress: list[tuple[int, int]] = []
    outcomes = list(pool.map_unordered(square_or_misbehave, [6, 1, 2, 3, 4, 5, 7], timeout_s=2.0,
                                       progress=lambda done, total: progress.append((done, total))))
    by_task = {o.task: o for o in outcomes}
    assert sorted(by_task) == [1, 2, 3, 4, 5, 6, 7]
    assert [by_task[x].value for x in (1, 2, 6, 7)] == [1, 4, 36, 49]
    assert isinstance(by_task[3].error, TaskTimeoutError) and str(by_task[3].error) == "timeout after 2 s"
    assert isinstance(by_task[4].error, ValueError) and "four" in str(by_task[4].error)
    assert isinstance(by_task[5].error, WorkerDiedError) and "exit code 7" in str(by_task[5].error)
    assert progress == [(k, 7) for k in range(1, 8)]
    order = [o.task for o in outcomes]
    assert order.index(6) > order.index(2)  # delivered in order of completion, not of submission
    assert order[-1] == 3  # the overdue task is the last to end
    with pytest.raises(ValueError, match="four"):
        by_task[4].result()


def test_serial_executor_gives_the_same_outcomes_and_interrupts_python_code():
    outcomes = {o.task: o for o in SerialExecutor().map_unordered(square_or_misbehave, [1, 2, 3, 4], timeout_s=0.5)}
    assert outcomes[2].value == 4 and isinstance(outcomes[4].error, ValueError)
    assert isinstance(outcomes[3].error, TaskTimeoutError)


def test_open_executor_validates_and_sizes():
    with pytest.raises(ValueError, match="workers must be an integer >= 1"):
        open_executor(0)
    with pytest.raises(ValueError, match="not both"):
        open_executor(2, dask="tcp://127.0.0.1:8786")
    with pytest.raises(ValueError, match="scheduler address"):
        open_executor(dask="garbage")
    assert isinstance(open_executor(serial=True), SerialExecutor)


def test_run_guarded_kills_the_whole_process_group_at_the_deadline(tmp_path):
    start = time.monotonic()
    run = run_guarded("sleep 60 & echo $!; echo started >&2; sleep 60", shell=True, cwd=tmp_path, timeout_s=0.5)
    assert run.timed_out and run.returncode is None and "started" in run.stderr
    assert time.monotonic() - start < 5.0
    background = int(run.stdout.split()[0])
    deadline = time.monotonic() + 2.0
    while alive(background) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert not alive(background)  # the shell's background child died with it
    done = run_guarded([sys.executable, "-c", "import sys; print('out'); sys.exit(3)"], timeout_s=30)
    assert (done.returncode, done.stdout.strip(), done.timed_out) == (3, "out", False)


def test_ctrl_c_stops_a_map_within_two_seconds_and_keeps_what_finished():
    executor = LocalPoolExecutor(2)
    workers: set[int] = set()
    finished = []
    interrupted_at: list[float] = []

    def interrupt() -> None:
        interrupted_at.append(time.monotonic())
        _thread.interrupt_main()

    with pytest.raises(KeyboardInterrupt):
        for outcome in executor.map_unordered(sleep_s, [0.1, 0.1, 60.0, 60.0, 0.1], timeout_s=120):
            finished.append(outcome.task)
            workers |= set(executor.worker_pids())
            if len(finished) == 2:  # both workers are now in their 60 s tasks
                threading.Timer(0.5, interrupt).start()
    stopped_after_s = time.monotonic() - interrupted_at[0]
    assert stopped_after_s < 2.0, stopped_after_s
    assert finished == [0.1, 0.1]  # the tasks finished before the interrupt were delivered
    assert len(workers) == 2 and not [pid for pid in workers if alive(pid)]


PARENT_SCRIPT = textwrap.dedent("""
    import sys, time
    sys.path.insert(0, {tests!r})
    from filmcal._parallel import LocalPoolExecutor, run_guarded
    from test_campaign_parallel import sleep_s, guarded_shell

    if __name__ == "__main__":
        pool = LocalPoolExecutor(3)
        futures = [pool.submit(sleep_s, 600.0), pool.submit(guarded_shell), pool.submit(sleep_s, 600.0)]
        print("submitted", flush=True)
        time.sleep(600)
""")


def guarded_shell() -> int:
    """A shell with a background child, as a compound solver command would be."""
    return run_guarded("sleep 600 & sleep 600", shell=True, timeout_s=600).returncode


@pytest.mark.slow(reason="4 s: a parent with three workers, killed")
def test_workers_and_their_children_die_with_a_killed_parent(tmp_path):
    script = tmp_path / "parent.py"
    script.write_text(PARENT_SCRIPT.format(tests=str(TESTS_DIR)))
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout.readline().strip() == "submitted"
        deadline = time.monotonic() + 60
        seen: set[int] = set()
        # three workers, the resource tracker, the shell and its two sleeps
        while len(seen) < 7 and time.monotonic() < deadline:
            seen |= descendants(parent.pid)
            time.sleep(0.05)
        assert len(seen) >= 7, seen
    finally:
        parent.kill()
        parent.wait()
    killed = time.monotonic()
    while any(alive(pid) for pid in seen) and time.monotonic() - killed < 5.0:
        time.sleep(0.05)
    assert not [pid for pid in seen if alive(pid)]


INTERRUPTED_SCRIPT = textwrap.dedent("""
    import sys
    sys.path.insert(0, {tests!r})
    from filmcal._parallel import LocalPoolExecutor
    from test_campaign_parallel import sleep_s

    if __name__ == "__main__":
        pool = LocalPoolExecutor(2)
        print("started", flush=True)
        try:
            for outcome in pool.map_unordered(sleep_s, [30.0, 30.0]):
                pass
        except KeyboardInterrupt:
            sys.stderr.write("interrupted\\n")
""")


@pytest.mark.slow(reason="4 s: three interpreters interrupted while their workers start")
@pytest.mark.parametrize("delay_s", [0.05, 0.15, 0.3])
def test_ctrl_c_while_workers_start_prints_no_worker_traceback(tmp_path, delay_s):
    """A terminal's Ctrl-C reaches the whole process group, workers that are still starting included."""
    import signal

    script = tmp_path / "interrupted.py"
    script.write_text(INTERRUPTED_SCRIPT.format(tests=str(TESTS_DIR)))
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, start_new_session=True)
    assert parent.stdout.readline().strip() == "started"
    time.sleep(delay_s)
    os.killpg(parent.pid, signal.SIGINT)
    sent = time.monotonic()
    _, err = parent.communicate(timeout=30)
    assert err == "interrupted\n", err
    assert time.monotonic() - sent < 2.0


def test_descendant_pids_and_pid_alive_follow_a_process_tree():
    """A shell that starts a sleeper: both are descendants, only the shell a direct child; a killed and
    reaped process is no longer alive."""
    import subprocess as sp

    from filmcal._parallel import descendant_pids, pid_alive

    shell = sp.Popen(["sh", "-c", "sleep 30 & wait"])
    try:
        deadline = time.monotonic() + 5
        while len(descendant_pids(shell.pid)) < 1 and time.monotonic() < deadline:
            time.sleep(0.05)
        (sleeper,) = descendant_pids(shell.pid)
        assert shell.pid in descendant_pids(os.getpid(), direct=True)
        assert sleeper not in descendant_pids(os.getpid(), direct=True)
        assert sleeper in descendant_pids(os.getpid()) and pid_alive(sleeper)
    finally:
        os.kill(sleeper, signal.SIGKILL)
        shell.wait(timeout=10)
    assert not pid_alive(shell.pid)
