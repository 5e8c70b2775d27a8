"""A live session: the scenario's session, driven by the operator instead of its own start."""

from __future__ import annotations

from oimi.scenarios.loader import LoadedScenario
from oimi.scenarios.runner import RunResult, Session


class LiveSession(Session):
    """The scenario's activities are selected but not started: the operator gets them ready
    and starts them. Its recording says it was live, so a replay re-drives its inputs.

    The scenario's scripted expectations do not apply to what an operator did: the
    result has no verdicts, and the recorded scenario record has no ``duration_s`` or
    ``ticks`` (the session's own are in its ``session`` record, written at the end)."""

    def __init__(self, loaded: LoadedScenario, *, seed: int | None = None) -> None:
        super().__init__(loaded, seed=seed, autostart=False)

    def metadata(self) -> dict[str, dict[str, str]]:
        metadata = super().metadata()
        for key in ("duration_s", "ticks"):
            metadata["scenario"].pop(key, None)
        metadata["live"] = {
            "autostart": "false",
            "replay": "redrive: operator commands and joystick are recorded inputs",
        }
        return metadata

    def result(self) -> RunResult:
        """The session's summary; no verdicts (expectations are not applicable)."""
        return RunResult(summary=super().result().summary, verdicts=())
