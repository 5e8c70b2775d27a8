"""Recording a session: the sinks are closed whatever happens, and a second Ctrl-C waits."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.recording import interrupts_held, recorded
from oimi.scenarios.session.runner import Session, library_scenarios


def test_ctrl_c_is_ignored_while_the_files_are_being_finished() -> None:
    before = signal.getsignal(signal.SIGINT)
    with interrupts_held():
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    assert signal.getsignal(signal.SIGINT) is before


def test_an_error_mid_run_still_finishes_a_readable_recording(tmp_path: Path) -> None:
    from oimi.recorder.reader import open_recording

    greeting = next(p for p in library_scenarios() if p.stem == "greeting")
    session = Session(load_scenario(greeting))
    output = tmp_path / "cut.mcap"
    with pytest.raises(RuntimeError, match="stop here"), recorded(session, mcap=output, rrd=None):
        for tick in range(20):
            session.step(tick)
        raise RuntimeError("stop here")
    recording = open_recording(output)
    assert recording.recovery is None, "closed properly: summary and footer written"
    assert recording.summary["/world/state"] == 20
