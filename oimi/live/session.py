"""A live session: the scenario's session, driven by the operator instead of its own start."""

from __future__ import annotations

from collections.abc import Mapping

import msgspec

from oimi.recorder.metadata import LiveRecord, RecordingMetadata, ScenarioRecord
from oimi.scenarios.loader import LoadedScenario
from oimi.scenarios.session.runner import Body, RunResult, SensorInputs, Session


class LiveSession(Session):
    """The scenario's activities are selected but not started: the operator gets them ready
    and starts them. Its recording says it was live, so a replay re-drives its inputs.

    The scenario's scripted expectations do not apply to what an operator did: the
    result has no verdicts, and the recorded scenario record has no ``duration_s`` or
    ``ticks`` (the session's own are in its ``session`` record, written at the end)."""

    def __init__(
        self,
        loaded: LoadedScenario,
        *,
        seed: int | None = None,
        world: Body | None = None,
        sensors: SensorInputs | None = None,
        overrides: Mapping[str, str] | None = None,
    ) -> None:
        """``world`` and ``sensors``: a robot reached elsewhere; ``overrides``: the
        scenario varied (``Session``'s)."""
        super().__init__(
            loaded, seed=seed, autostart=False, world=world, sensors=sensors, overrides=overrides
        )

    def metadata(self) -> RecordingMetadata:
        metadata = super().metadata()
        scenario = metadata.scenario or ScenarioRecord()
        return msgspec.structs.replace(
            metadata,
            scenario=msgspec.structs.replace(scenario, duration_s=None, ticks=None),
            live=LiveRecord(
                autostart="false",
                replay="redrive: operator commands and joystick are recorded inputs",
            ),
        )

    def result(self) -> RunResult:
        """The session's summary; no verdicts (expectations are not applicable)."""
        return RunResult(summary=super().result().summary, verdicts=())
