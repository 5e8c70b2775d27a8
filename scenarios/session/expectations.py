"""Checking a scenario's expectations: a sink that watches the session as it streams by.

A figure that is not a finite number (a NaN position, a distance never measured) never
passes: a verdict on it fails and says what was seen.
"""

from __future__ import annotations

import math
from typing import Final

import msgspec
from oimi.pipeline.act.interventions import Interventions
from oimi.pipeline.events import (
    REJECTING_SOURCES,
    ActuatorCommands,
    BodyState,
    Event,
    Level,
    LogEntries,
    ProgressKind,
    ReaderProgress,
    RuleDecisions,
    SafetyIntervention,
    Topic,
    WorldState,
)
from oimi.pipeline.plurals import counted
from oimi.pipeline.proximity import ContactEpisode, Initiator, ProximityTracker
from oimi.pipeline.think.episodes import RuleEpisodes
from oimi.scenarios.schema import (
    ActivityCompleted,
    ActivityState,
    Between,
    ClosingSpeedAtContact,
    Expectation,
    GoalReached,
    MaxSpeed,
    MinDistance,
    NoRejectedInputs,
    NoRobotInitiatedContact,
    RobotInArena,
    RuleFired,
    SafetyIntervened,
    Scenario,
)


class Verdict(msgspec.Struct, frozen=True, kw_only=True):
    """One expectation's outcome, with the figures behind it."""

    name: str
    ok: bool
    detail: str


HANDLERS: Final = {
    Topic.WORLD_STATE: "_world",
    Topic.RULE_DECISIONS: "_decisions",
    Topic.READER_PROGRESS: "_progress",
    Topic.SAFETY: "_intervention",
    Topic.ACTUATOR_COMMANDS: "_commands",
    Topic.LOG: "_log",
}
"""The :class:`Tracker` method that reads each topic it reads."""


class Tracker:
    """A sink that keeps only the figures the expectations and the summary need."""

    TOPICS = tuple(HANDLERS)
    """The topics :meth:`record` reads (what a replayed check needs)."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self._never_seen: dict[str, float] = {h.id: math.inf for h in scenario.humans}
        self.max_speed_mps = 0.0
        self.left_arena_ms: int | None = None
        self.episodes = RuleEpisodes()
        """Each rule's firing episodes and evaluations that held (the definitions ``oimi
        analyse`` uses)."""
        self.fired_at: dict[str, list[int]] = {
            e.rule: []
            for e in scenario.expect
            if isinstance(e, RuleFired) and (e.after_s is not None or e.by_s is not None)
        }
        """When each rule a windowed ``rule_fired`` names fired (ms; only those rules)."""
        self.goals_reached: dict[str, int] = {}
        self.activity_states: dict[str, list[tuple[int, str]]] = {}
        self.idle: set[str] = set()
        """The activities the reader fell back to as its idle activity."""
        self.rejections: list[str] = []
        self.errors: list[str] = []
        """Every ERROR on ``/log`` (a user's rule, function or generator that raised...)."""
        self.contacts = 0
        self.safety = Interventions()
        """The supervisor's episodes (the definition ``oimi analyse`` uses)."""
        self.last_ms = 0
        self._robot: BodyState | None = None
        """The robot's last entry read (its speed and place are checked once per entry)."""
        self.proximity = ProximityTracker(tick_ms=1000 // scenario.tick_hz, zones=False)
        """Surface distances and contact episodes (the definitions ``oimi analyse`` uses; no
        time in zones, which no expectation reads)."""
        self._handle = {topic: getattr(self, name) for topic, name in HANDLERS.items()}
        """:attr:`HANDLERS`, bound."""

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        self.last_ms = message.time_ms
        handle = self._handle.get(topic)
        if handle is not None:
            handle(message)

    def _decisions(self, message: RuleDecisions) -> None:
        self.episodes.update(message)
        if at := self.fired_at:  # a windowed rule_fired: when each of its rules fired
            for decision in message.decisions:
                if decision.fired and (times := at.get(decision.rule)) is not None:
                    times.append(message.time_ms)

    def _intervention(self, message: SafetyIntervention) -> None:
        self.safety.update(message)

    def _commands(self, message: ActuatorCommands) -> None:
        self.proximity.command(message)

    def _log(self, message: LogEntries) -> None:
        self.rejections += [
            f"{message.time_ms} ms {e.source}: {e.message}"
            for e in message.entries
            if e.level >= Level.WARNING and e.source in REJECTING_SOURCES
        ]
        self.errors += [
            f"{message.time_ms / 1000:.2f} s {e.source}: {e.message}"
            for e in message.entries
            if e.level >= Level.ERROR
        ]

    @property
    def min_distance_m(self) -> dict[str, float]:
        """Per human, the closest centre-to-centre distance (inf for a scenario's human
        never seen; NaN once a position was NaN)."""
        return self._never_seen | self.proximity.closest_centres_m

    def _world(self, state: WorldState) -> None:
        self.proximity.update(state)
        self.contacts += len(state.contacts)
        robot = state.robot
        if robot is self._robot:  # the world's same entry: a robot that did not move
            return
        self._robot = robot
        speed = math.hypot(robot.vx_mps, robot.vy_mps)
        if not speed <= self.max_speed_mps:  # a larger speed, or NaN (which sticks)
            self.max_speed_mps = speed if math.isfinite(self.max_speed_mps) else math.nan
        world = self.scenario.world
        inside = 0 <= robot.x_m <= world.width_m and 0 <= robot.y_m <= world.height_m
        if not inside and self.left_arena_ms is None:
            self.left_arena_ms = state.time_ms

    def _progress(self, progress: ReaderProgress) -> None:
        for item in progress.items:
            if item.kind == ProgressKind.GOAL_REACHED:
                self.goals_reached.setdefault(item.detail, progress.time_ms)
            elif item.kind in (ProgressKind.LOAD, ProgressKind.IDLE):
                if item.kind == ProgressKind.IDLE:
                    self.idle.add(item.activity)
                self._state(item.activity, progress.time_ms, "running")
            elif item.detail in ("completed", "interrupted"):
                self._state(item.activity, progress.time_ms, item.detail)

    def _state(self, activity: str, time_ms: int, state: str) -> None:
        self.activity_states.setdefault(activity, []).append((time_ms, state))

    def ran(self) -> dict[str, str]:
        """Each activity that ran, the idle activity aside, with its last state (``running``,
        ``completed`` or ``interrupted``), in the order they first ran."""
        return {
            activity: states[-1][1]
            for activity, states in self.activity_states.items()
            if activity not in self.idle
        }

    def state_at(self, activity: str, time_ms: int) -> str:
        """The activity's state at ``time_ms`` (``loaded`` before it first ran)."""
        state = "loaded"
        for when, value in self.activity_states.get(activity, ()):
            if when <= time_ms:
                state = value
        return state

    def contact_episodes(self, human: str | None = None) -> list[ContactEpisode]:
        """The contact episodes so far (open ones closed at the last tick seen)."""
        return [e for e in self.proximity.finish() if human in (None, e.human)]

    # --------------------------------------------------------------------- verdicts

    def verdicts(self) -> list[Verdict]:
        """Every expectation of the scenario, checked against what was seen."""
        return [self._check(expectation) for expectation in self.scenario.expect]

    def _check(self, e: Expectation) -> Verdict:
        end_ms = self.last_ms
        match e:
            case GoalReached():
                at = self.goals_reached.get(e.goal)
                deadline = _ms(e.by_s, end_ms)
                ok = at is not None and deadline is not None and at <= deadline
                seen = "never" if at is None else f"at {at / 1000:.2f} s"
                return self._verdict(
                    e, f"goal {e.goal} reached by {_s(deadline)} s", ok, f"reached {seen}"
                )
            case ActivityCompleted():
                deadline = _ms(e.by_s, end_ms)
                done = [t for t, s in self.activity_states.get(e.activity, ()) if s == "completed"]
                ok = bool(done) and deadline is not None and done[0] <= deadline
                seen = f"at {done[0] / 1000:.2f} s" if done else "never"
                name = f"activity {e.activity} completed"
                if e.by_s is not None:  # (without one: by the session's end)
                    name += f" by {_s(deadline)} s"
                return self._verdict(e, name, ok, f"completed {seen}")
            case RuleFired() if e.after_s is None and e.by_s is None:
                count = self.episodes.fired().get(e.rule, 0)
                ok, bound = _within(count, e.at_least, e.at_most)
                return self._verdict(e, f"rule {e.rule} fired {bound} times", ok, f"fired {count}")
            case RuleFired():
                start, stop = _ms(e.after_s, 0), _ms(e.by_s, end_ms)
                times = self.fired_at[e.rule] if start is not None and stop is not None else []
                count = sum(start <= at <= stop for at in times)
                ok, bound = _within(count, e.at_least, e.at_most)
                window = f"between {_s(start)} s and {_s(stop)} s"
                return self._verdict(
                    e, f"rule {e.rule} fired {bound} times {window}", ok, f"fired {count}"
                )
            case SafetyIntervened():
                count = sum(
                    (e.zone is None or e.zone in episode.zones)
                    and (e.source is None or e.source in episode.sources)
                    for episode in self.safety.episodes
                )
                ok, bound = _within(count, e.at_least, e.at_most)
                what = " ".join(str(x) for x in (e.source, e.zone) if x is not None)
                return self._verdict(
                    e,
                    f"safety supervisor intervened ({what or 'any'}) {bound} times",
                    ok,
                    counted(count, "episode"),
                )
            case MinDistance():
                centres_m = self.min_distance_m
                humans = [e.human] if e.human else list(centres_m)
                surfaces = e.between is Between.SURFACES
                closest_m = self.proximity.closest_m if surfaces else centres_m
                distances = [closest_m.get(h, math.inf) for h in humans]
                # a NaN position fails either measure (surfaces skip it; centres keep it)
                nan = any(math.isnan(centres_m.get(h, math.inf)) for h in humans)
                closest = math.nan if nan else min(distances, default=math.inf)
                measured = math.isfinite(closest) or not humans  # no humans: never closer
                ok = measured and _finite(e.at_least_m) and closest >= e.at_least_m
                who = e.human or "every human"
                how = "surface to surface" if surfaces else "centre to centre"
                seen = f"closest {closest:.3f} m ({how})" if humans else "no humans in the room"
                what = f"distance to {who} >= {e.at_least_m} m"
                return self._verdict(e, what, ok, seen)
            case MaxSpeed():
                ok = (
                    math.isfinite(self.max_speed_mps)
                    and _finite(e.at_most_mps)
                    and self.max_speed_mps <= e.at_most_mps + 1e-9
                )
                return self._verdict(
                    e, f"speed <= {e.at_most_mps} m/s", ok, f"max {self.max_speed_mps:.3f} m/s"
                )
            case NoRejectedInputs():
                first = self.rejections[0] if self.rejections else ""
                return self._verdict(
                    e,
                    "no rejected inputs",
                    not self.rejections,
                    f"{len(self.rejections)} rejected" + (f"; first: {first}" if first else ""),
                )
            case RobotInArena():
                ok = self.left_arena_ms is None
                return self._verdict(
                    e,
                    "robot stays in the arena",
                    ok,
                    "stayed in" if ok else f"left at {self.left_arena_ms} ms",
                )
            case ActivityState():
                when = _ms(e.at_s, end_ms)
                state = self.state_at(e.activity, when) if when is not None else "never checked"
                return self._verdict(
                    e,
                    f"activity {e.activity} is {e.state} at {_s(when)} s",
                    state == e.state,
                    f"was {state}",
                )
            case NoRobotInitiatedContact():
                episodes = self.contact_episodes(e.human)
                robot = [c for c in episodes if c.initiator is Initiator.ROBOT]
                first = robot[0] if robot else None
                where = f"; first: {first.human} at {first.start_ms / 1000:.2f} s" if first else ""
                return self._verdict(
                    e,
                    f"no robot-initiated contact with {e.human or 'anyone'}",
                    not robot,
                    f"{len(robot)} of {counted(len(episodes), 'contact')} robot-initiated{where}",
                )
            case ClosingSpeedAtContact():
                episodes = self.contact_episodes(e.human)
                fastest = max((c.closing_speed_mps for c in episodes), default=0.0)
                return self._verdict(
                    e,
                    f"closing speed at contact <= {e.at_most_mps} m/s",
                    fastest <= e.at_most_mps + 1e-9,
                    f"{counted(len(episodes), 'contact')}, fastest {fastest:.3f} m/s",
                )
        raise AssertionError(f"unhandled expectation {e!r}")

    @staticmethod
    def _verdict(e: Expectation, default_name: str, ok: bool, detail: str) -> Verdict:
        return Verdict(name=e.name or default_name, ok=ok, detail=detail)


def _within(count: int, at_least: int, at_most: int | None) -> tuple[bool, str]:
    """Whether ``count`` is within the bounds, and the bounds as text (``>= 1 and <= 3``)."""
    ok = count >= at_least and (at_most is None or count <= at_most)
    bound = f">= {at_least}" + (f" and <= {at_most}" if at_most is not None else "")
    return ok, bound


def _ms(seconds: float | None, default_ms: int) -> int | None:
    """A deadline in ms; None when ``seconds`` is not a finite number (it never passes)."""
    if seconds is None:
        return default_ms
    return round(seconds * 1000) if _finite(seconds) else None


def _s(time_ms: int | None) -> str:
    return "nan" if time_ms is None else f"{time_ms / 1000:.2f}"


def _finite(value: float) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)
