"""A recording's expectations checked again (``oimi analyse``): the verdicts ``oimi run``
gave, for every kind of expectation the library's scenarios use."""

from __future__ import annotations

from pathlib import Path

import pytest
from oimi.replay.expectations import recorded_verdicts
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session

LIBRARY = Path(__file__).parents[2] / "scenarios" / "library"


@pytest.mark.parametrize("name", ["safety_script_without_rule", "caress_reward"])
def test_the_recording_gives_the_verdicts_the_run_gave(name: str, tmp_path: Path) -> None:
    session = Session(load_scenario(LIBRARY / f"{name}.toml"))
    path = tmp_path / f"{name}.mcap"
    with recorded(session, mcap=path, rrd=None):
        result = session.run()
    assert result.verdicts, "a scenario with expectations"
    assert recorded_verdicts(path) == [(v.name, v.ok, v.detail) for v in result.verdicts]
