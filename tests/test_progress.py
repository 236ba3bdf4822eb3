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
