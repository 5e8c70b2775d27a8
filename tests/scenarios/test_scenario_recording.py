"""Recording a session: the sinks are closed whatever happens, and a second Ctrl-C waits."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.interrupts import interrupts_held
from oimi.scenarios.session.recording import recorded
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
    ticks = [m.tick for m in recording.iter_messages(["/world/state"])]
    assert ticks == [*range(0, 20, 2), 19], "every second tick and the last, written at close"
    assert recording.summary["/world/state"] == 11


def test_ctrl_c_mid_run_stops_between_two_ticks_with_a_consistent_recording(
    tmp_path: Path,
) -> None:
    """The interrupt arrives inside tick 7 (from a sink's write, as a real Ctrl-C can);
    the run finishes that tick and stops, and the file's summary counts what it holds."""
    import os

    from oimi.recorder.reader import open_recording

    class InterruptOnce:
        def __init__(self) -> None:
            self.sent = False

        def record(self, topic: str, time_ns: int, event: object) -> None:
            if topic == "/world/state" and event.tick == 7 and not self.sent:  # type: ignore[attr-defined]
                self.sent = True
                os.kill(os.getpid(), signal.SIGINT)

        def close(self) -> None:
            pass

    greeting = next(p for p in library_scenarios() if p.stem == "greeting")
    session = Session(load_scenario(greeting))
    output = tmp_path / "stopped.mcap"
    stepped: list[int] = []
    with pytest.raises(KeyboardInterrupt), recorded(session, mcap=output, rrd=None):
        session.sink.add(InterruptOnce())
        session.run(progress=lambda tick, total: stepped.append(tick))
    assert stepped == list(range(1, 9)), "tick 7 (the 8th) finished, no later tick began"
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    recording = open_recording(output)
    assert recording.recovery is None
    ticks = [m.tick for m in recording.iter_messages(["/world/state"])]
    assert ticks == [0, 2, 4, 6, 7], "every second tick and the last, 7, written at close"
    assert recording.summary["/world/state"] == 5
