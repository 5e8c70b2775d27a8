"""One streaming pass over a recording, so memory does not grow with the session's length.

The per-tick topics (``/world/state``, ``/rules/decisions``) and ``/safety`` are
decoded one message at a time and folded into trackers (proximity and contacts
from ``pipeline.proximity``, rule episodes, the robot's figures, the supervisor's
interventions); only their results and a decimated sample for the plots (at most
:data:`MAX_SAMPLES` ticks) are kept. The light topics (progress, operator,
joystick, actuator commands, log) are loaded as tables by ``analysis.load``.
"""

from __future__ import annotations

import contextlib
import math
from typing import Final

import msgspec
import polars as pl
from oimi.pipeline.act.interventions import Interventions
from oimi.pipeline.events import (
    ActuatorCommands,
    RuleDecisions,
    SafetyIntervention,
    Topic,
    WorldState,
)
from oimi.pipeline.proximity import ContactEpisode, ProximityTracker, surface_distance
from oimi.pipeline.think.episodes import RuleEpisodes

STREAMED: Final = (Topic.WORLD_STATE.value, Topic.RULE_DECISIONS.value, Topic.SAFETY.value)
"""Topics folded message by message (never held as tables)."""
FOLDED: Final = (*STREAMED, Topic.ACTUATOR_COMMANDS.value)
"""Topics the folder reads: the streamed ones, and the actuator commands (a table too),
whose move commands tell a robot that drove into a person from one pushed into them."""

MAX_SAMPLES: Final = 4000
"""Ticks kept for the plots: every tick of a short session, evenly thinned beyond."""


def rule_episodes_frame(episodes: RuleEpisodes) -> pl.DataFrame:
    """The episodes as a table: rule, rulecode, started_ms, ended_ms, evaluations_fired."""
    return pl.DataFrame(
        episodes.rows,
        schema={
            "rule": pl.String,
            "rulecode": pl.Int64,
            "started_ms": pl.Int64,
            "ended_ms": pl.Int64,
            "evaluations_fired": pl.Int64,
        },
        orient="row",
    )


class SafetyEpisodes(Interventions):
    """The supervisor's interventions (``pipeline.act.safety``), as a table."""

    def frame(self, end_ms: int) -> pl.DataFrame:
        """One row per intervention (one still open ends at ``end_ms``)."""
        rows = [
            {
                **msgspec.structs.asdict(e),
                "ended_ms": e.ended_ms if e.ended_ms is not None else end_ms,
                "source": str(e.source),
                "zones": " → ".join(e.zones),
                "humans": ", ".join(e.humans),
            }
            for e in self.episodes
        ]
        schema = {
            "started_ms": pl.Int64,
            "ended_ms": pl.Int64,
            "source": pl.String,
            "zones": pl.String,
            "humans": pl.String,
            "min_surface_distance_m": pl.Float64,
            "requested_mps": pl.Float64,
            "allowed_mps": pl.Float64,
            "changes": pl.Int64,
        }
        rows = [{k: row[k] for k in schema} for row in rows]
        return pl.DataFrame(rows, schema=schema) if rows else pl.DataFrame(schema=schema)


class Samples:
    """Per-tick positions and surface distances, thinned to at most :data:`MAX_SAMPLES` ticks
    (every other kept tick is dropped and the stride doubled when full)."""

    def __init__(self) -> None:
        self.stride = 1
        self.ticks: list[list[tuple[int, str, str, float, float, float | None]]] = []
        self._seen = 0

    def update(self, state: WorldState) -> None:
        index, self._seen = self._seen, self._seen + 1
        if index % self.stride:
            return
        robot = state.robot
        rows = [(state.time_ms, "robot", "robot", robot.x_m, robot.y_m, None)]
        rows += [
            (state.time_ms, h.id, h.kind, h.x_m, h.y_m, surface_distance(robot, h))
            for h in state.humans
        ]
        self.ticks.append(rows)
        if len(self.ticks) > MAX_SAMPLES:
            self.ticks = self.ticks[::2]
            self.stride *= 2

    def frame(self) -> pl.DataFrame:
        return pl.DataFrame(
            [row for rows in self.ticks for row in rows],
            schema={
                "time_ms": pl.Int64,
                "id": pl.String,
                "kind": pl.String,
                "x_m": pl.Float64,
                "y_m": pl.Float64,
                "surface_distance_m": pl.Float64,
            },
            orient="row",
        )


class RobotFigures:
    """Distance travelled, speeds and contact ticks, accumulated tick by tick."""

    def __init__(self) -> None:
        self.distance_m = 0.0
        self.max_speed_mps = 0.0
        self.speed_sum = 0.0
        self.ticks = 0
        self.contact_ticks = 0
        self._last: tuple[float, float] | None = None

    def update(self, state: WorldState) -> None:
        robot = state.robot
        if self._last is not None:
            self.distance_m += math.hypot(robot.x_m - self._last[0], robot.y_m - self._last[1])
        self._last = (robot.x_m, robot.y_m)
        speed = math.hypot(robot.vx_mps, robot.vy_mps)
        self.max_speed_mps = max(self.max_speed_mps, speed)
        self.speed_sum += speed
        self.ticks += 1
        self.contact_ticks += len(state.contacts)


class Streamed(msgspec.Struct, kw_only=True, dict=True):
    """What the streaming pass kept of one recording."""

    tick_ms: int
    proximity: ProximityTracker
    contacts: list[ContactEpisode]
    rules: RuleEpisodes
    safety: SafetyEpisodes
    samples: Samples
    robot: RobotFigures
    last_ms: int
    world_ticks: int


class StreamFolder:
    """Folds streamed messages as the scan yields them; :meth:`result` when the scan ends."""

    def __init__(self, *, tick_ms: int) -> None:
        self.tick_ms = tick_ms
        self.proximity = ProximityTracker(tick_ms=tick_ms)
        self.rules = RuleEpisodes()
        self.safety = SafetyEpisodes()
        self.samples = Samples()
        self.robot = RobotFigures()
        self.last_ms = 0
        self._world = msgspec.json.Decoder(WorldState)
        self._decisions = msgspec.json.Decoder(RuleDecisions)
        self._safety = msgspec.json.Decoder(SafetyIntervention)
        self._commands = msgspec.json.Decoder(ActuatorCommands)

    def add(self, topic: str, data: bytes) -> None:
        if topic == Topic.WORLD_STATE:
            state = self._world.decode(data)
            self.proximity.update(state)
            self.samples.update(state)
            self.robot.update(state)
            self.last_ms = max(self.last_ms, state.time_ms)
        elif topic == Topic.RULE_DECISIONS:
            message = self._decisions.decode(data)
            self.rules.update(message)
            self.last_ms = max(self.last_ms, message.time_ms)
        elif topic == Topic.SAFETY:
            # a /safety message of another shape is not an intervention we can read
            with contextlib.suppress(msgspec.DecodeError):
                self.safety.update(self._safety.decode(data))
        elif topic == Topic.ACTUATOR_COMMANDS:
            self.proximity.command(self._commands.decode(data))

    def result(self) -> Streamed:
        return Streamed(
            tick_ms=self.tick_ms,
            proximity=self.proximity,
            contacts=self.proximity.finish(),
            rules=self.rules,
            safety=self.safety,
            samples=self.samples,
            robot=self.robot,
            last_ms=self.last_ms,
            world_ticks=self.robot.ticks,
        )
