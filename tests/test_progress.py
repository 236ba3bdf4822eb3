"""The run's progress display: plain lines with a heartbeat, live bars, quiet, warnings repeated at the end."""
from __future__ import annotations

import io
import time

import pytest

from filmcal._progress import Progress


def test_log_mode_beats_at_least_every_interval_while_a_stage_runs():
    out = io.StringIO()
    progress = Progress("log", stream=out, interval_s=0.2)
    with progress.stage("curves", total=4) as st:
        time.sleep(0.05)
        st.advance(note="HS, smooth wheel")  # the first unit: a line at once
        time.sleep(1.1)  # a long unit: only the heartbeat speaks
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("[curves] 1/4 done") and "about" in lines[0] and "(HS, smooth wheel)" in lines[0]
    assert len(lines) >= 1 + 4  # 1.1 s of silence at a 0.2 s heartbeat: at least four more lines
    assert all(line.startswith("[curves] 1/4 done") for line in lines)


def test_quiet_prints_nothing_but_the_warnings_at_the_end():
    out = io.StringIO()
    progress = Progress("quiet", stream=out)
    with progress.stage("calibration", total=2) as st:
        st.log("[calibration] a message")
        st.advance()
    progress.warn("HS: the sampler's diagnostics failed")
    assert out.getvalue() == ""
    progress.summary()
    assert out.getvalue() == "warning: HS: the sampler's diagnostics failed\n"


def test_auto_is_log_off_a_terminal_and_modes_are_checked():
    assert Progress("auto", stream=io.StringIO()).mode == "log"
    with pytest.raises(ValueError, match="progress mode"):
        Progress("loud")


class _Clock:
    """A monotonic clock moved by hand (the plan's arithmetic, without sleeping)."""

    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def test_the_run_estimate_is_the_planned_work_left_at_the_speed_so_far(monkeypatch):
    """Plan 10 s + 30 s. The first stage takes 20 s (twice its plan): at its end 30 s of plan are left, at the
    speed so far (2 s per planned s) 60 s; halfway through the second stage at that speed, 30 s."""
    clock = _Clock()
    monkeypatch.setattr("filmcal._progress.time.monotonic", clock)
    progress = Progress("quiet", stream=io.StringIO())
    progress.plan({"one": 10.0, "two": 30.0})
    with progress.stage("one", total=4) as st:
        clock.t += 10.0
        st.advance(2)  # half of stage one in 10 s: the run is 5/40 done, 35 planned s left at 2 s each
        assert progress.run_fraction() == pytest.approx(5 / 40)
        assert progress.run_left_s() == pytest.approx(70.0)
        clock.t += 10.0
        st.advance(2)
    assert progress.run_fraction() == pytest.approx(10 / 40)
    assert progress.run_left_s() == pytest.approx(60.0)
    with progress.stage("two") as st:
        clock.t += 30.0
        st.update(0.5, note="FE run 300/600")  # inner work: half of stage two, at 2 s per planned s
        assert progress.run_fraction() == pytest.approx(25 / 40)
        assert progress.run_left_s() == pytest.approx(30.0)
        assert "run 62 % done, about 30 s left" in st.status() and "(FE run 300/600)" in st.status()


def test_a_stage_found_done_leaves_the_plan(monkeypatch):
    """A resumed run: the first stage returns at once with nothing computed; it must not make the run look fast."""
    clock = _Clock()
    monkeypatch.setattr("filmcal._progress.time.monotonic", clock)
    progress = Progress("quiet", stream=io.StringIO())
    progress.plan({"one": 100.0, "two": 10.0})
    with progress.stage("one"):
        progress.unplan("one")  # its work was found in the study
    with progress.stage("two", total=2) as st:
        clock.t += 5.0
        st.advance()
        assert progress.run_fraction() == pytest.approx(0.5)
        assert progress.run_left_s() == pytest.approx(5.0)


def test_log_lines_carry_the_run_and_inner_work_moves_them():
    out = io.StringIO()
    progress = Progress("log", stream=out, interval_s=60)
    progress.plan({"calibration": 100.0, "curves": 100.0})
    with progress.stage("calibration", total=6) as st:
        st.update(0.25, note="FE run 150/600")
    line = out.getvalue().splitlines()[0]
    assert line.startswith("[calibration] 0/6 done") and "(FE run 150/600)" in line and "run 12 % done" in line
