"""A live session: the scenario's session, driven by the operator instead of its own start."""

from __future__ import annotations

from scenarios.loader import LoadedScenario
from scenarios.runner import Session


class LiveSession(Session):
    """The scenario's activities are selected but not started: the operator gets them ready
    and starts them. Its recording says it was live, so a replay re-drives its inputs."""

    def __init__(self, loaded: LoadedScenario, *, seed: int | None = None) -> None:
        super().__init__(loaded, seed=seed, autostart=False)

    def metadata(self) -> dict[str, dict[str, str]]:
        metadata = super().metadata()
        metadata["live"] = {
            "autostart": "false",
            "replay": "redrive: operator commands and joystick are recorded inputs",
        }
        return metadata
