"""Golden files: a readable projection of a scenario's session, and a digest of all of it.

A golden file (``tests/golden/<scenario>.golden.txt``) has a header (scenario,
seed, ticks, message counts per topic, the sha256 digest of every payload in
order) and one line per decision that fired, actuator command, progress item,
chain change, operator command and state, joystick input, log entry, contact,
a world sample per second, and each expectation's verdict, with fixed number
formatting, so that a change of behaviour reads as a diff in a code review.
Rule decisions that did not fire are only counted; a fired decision (or a
contact) repeated unchanged at consecutive ticks is one line with its count
and last time. Sensor updates and the map are only counted and digested.

``python -m oimi.replay.golden --regenerate`` (``make golden``) rewrites the files on
purpose; ``--check`` compares (exit 1 with a unified diff on a difference).
"""

from __future__ import annotations

import argparse
import difflib
import hashlib
import shlex
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Final

from oimi.pipeline.errors import LocatedError
from oimi.pipeline.events import (
    ActuatorCommands,
    Event,
    JoystickInput,
    LogEntries,
    OperatorCommands,
    OperatorState,
    ReaderProgress,
    RuleChainState,
    RuleDecision,
    RuleDecisions,
    SafetyIntervention,
    Topic,
    WorldState,
    encode,
)
from oimi.pipeline.messages import ActuatorCommand, AudioCommand, LedCommand, MoveCommand
from oimi.pipeline.operator.commands import describe
from oimi.recorder.reader import open_recording
from oimi.recorder.world_sampling import WorldSampling
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.runner import Session, library_scenarios

GOLDEN_DIR: Final = Path(__file__).resolve().parents[1] / "tests" / "golden"
SUFFIX: Final = ".golden.txt"
WORLD_SAMPLE_MS: Final = 1000
"""One world line per this much simulated time."""
REGENERATE: Final = "make golden  (python -m oimi.replay.golden --regenerate)"
DIFF_LINES: Final = 200
"""Longest diff shown by ``check``."""


# ------------------------------------------------------------------------- digest


def digest_update(digest: hashlib._Hash, topic: str, time_ns: int, payload: bytes) -> None:
    """Add one message to a session digest: topic, log time and payload, each line-ended."""
    digest.update(f"{topic}\n{time_ns}\n".encode())
    digest.update(payload)
    digest.update(b"\n")


def digest_recording(path: str | Path) -> str:
    """The digest of a recording's messages (our topics, file order): equal to the golden
    file's digest when the recording is of the same session."""
    digest = hashlib.sha256()
    for message in open_recording(path).iter_messages():
        digest_update(digest, message.topic.value, message.time_ns, message.payload_bytes)
    return "sha256:" + digest.hexdigest()


# ---------------------------------------------------------------------- projection


def _num(value: float) -> str:
    text = f"{value:.3f}"
    return "0.000" if text == "-0.000" else text


def _time(time_ms: int) -> str:
    return f"{time_ms // 1000:05d}.{time_ms % 1000:03d}"


def _command(c: ActuatorCommand) -> str:
    clamped, requested = False, None
    match c:
        case MoveCommand():
            text = f"v=({_num(c.v_x)},{_num(c.v_y)},{_num(c.v_theta)})"
            clamped, requested = c.clamped, c.requested
        case LedCommand():
            text = f"rgb=({_num(c.r)},{_num(c.g)},{_num(c.b)})"
            clamped, requested = c.clamped, c.requested
        case AudioCommand():
            text = f"track={c.track_path or '-'}"
    flags = (" stop" if c.stop else "") + (" clamped" if clamped else "")
    if requested is not None:
        flags += " requested=(" + ",".join(_num(v) for v in requested) + ")"
    return f"command {c.channel} {c.source} {text}{flags}"


def _decision(d: RuleDecision) -> str:
    bindings = "".join(f" {k}={v}" for k, v in sorted(d.bindings.items()))
    changes = " changes=" + ",".join(c.path for c in d.changes) if d.changes else ""
    return f"decision {d.rule} fired{bindings}{changes}"


@dataclass
class _Line:
    time_ms: int
    text: str
    tick: int
    count: int = 1
    last_ms: int = 0

    def render(self) -> str:
        line = f"{_time(self.time_ms)} {self.text}"
        if self.count > 1:
            line += f"  (x{self.count} until {_time(self.last_ms)})"
        return line


class Projection:
    """A sink building a session's golden text and digest as the session runs."""

    def __init__(self) -> None:
        self.lines: list[_Line] = []
        self.counts: dict[str, int] = {t.value: 0 for t in Topic}
        self.digest = hashlib.sha256()
        self.unfired = 0
        self._runs: dict[str, _Line] = {}
        self._sampling = WorldSampling()
        """The world states a recording keeps: those the digest and the counts take."""

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        if topic is not Topic.WORLD_STATE or self._sampling.keep(time_ns, message):
            self._digest(topic, time_ns, message)
        t, tick = message.time_ms, message.tick
        match message:
            case RuleDecisions():
                for decision in message.decisions:
                    if not decision.fired:
                        self.unfired += 1
                    elif decision.changes:
                        self._add(t, tick, _decision(decision))
                    else:
                        self._repeat(t, tick, _decision(decision))
            case ActuatorCommands():
                for command in message.commands:
                    self._add(t, tick, _command(command))
            case ReaderProgress():
                for item in message.items:
                    detail = f" {item.detail}" if item.detail else ""
                    self._add(t, tick, f"progress {item.kind} {item.activity} {item.path}{detail}")
                if not message.items:
                    place = f"{message.goalid}/{message.actionid}/{message.blockid}"
                    self._add(t, tick, f"place {message.activity} {place}")
            case RuleChainState():
                applied = ",".join(f"{m.action}:{m.id}" for m in message.applied)
                self._add(
                    t,
                    tick,
                    f"chain applied={applied or '-'} active={','.join(message.active) or '-'}"
                    f" held={','.join(message.held) or '-'}"
                    f" removed={','.join(message.removed) or '-'}"
                    + (" locked" if message.locked else ""),
                )
            case OperatorCommands():
                for c in message.commands:
                    self._add(t, tick, f"operator #{c.id} {describe(c)}")
            case OperatorState():
                activities = ",".join(f"{a.name}:{a.state}" for a in message.activities)
                self._add(t, tick, f"operator-state {message.button} {activities or '-'}")
                for r in message.replies:
                    reason = f" {r.reason}" if r.reason else ""
                    self._add(t, tick, f"reply #{r.id} {'ok' if r.ok else 'refused'}{reason}")
            case JoystickInput():
                self._add(
                    t,
                    tick,
                    f"joystick left=({_num(message.left_x)},{_num(message.left_y)})"
                    f" right_x={_num(message.right_x)} buttons={','.join(message.buttons) or '-'}",
                )
            case LogEntries():
                for e in message.entries:
                    ref = f" [{e.ref}]" if e.ref else ""
                    self._add(t, tick, f"log {e.level.name} {e.source} {e.message}{ref}")
            case SafetyIntervention():
                human = f" {message.human}" if message.human else ""
                distance = message.surface_distance_m
                at = f" at={_num(distance)}" if distance is not None else ""
                self._add(
                    t,
                    tick,
                    f"safety {message.phase} {message.source} {message.zone}{human}{at}"
                    f" requested=({','.join(_num(v) for v in message.requested)})"
                    f" allowed=({','.join(_num(v) for v in message.allowed)})",
                )
            case WorldState():
                if t % WORLD_SAMPLE_MS == 0:
                    bodies = [message.robot, *message.humans, *message.objects]
                    where = " ".join(
                        f"{b.id}=({_num(b.x_m)},{_num(b.y_m)},{_num(b.theta_rad)})" for b in bodies
                    )
                    self._add(t, tick, f"world {where}")
                for human in message.contacts:
                    self._repeat(t, tick, f"contact {human}")
            case _:
                pass  # sensor updates, the map: counted and digested only

    def _digest(self, topic: Topic, time_ns: int, message: Event) -> None:
        digest_update(self.digest, topic.value, time_ns, encode(message))
        self.counts[topic.value] += 1

    def _add(self, time_ms: int, tick: int, text: str) -> None:
        self.lines.append(_Line(time_ms, text, tick))

    def _repeat(self, time_ms: int, tick: int, text: str) -> None:
        run = self._runs.get(text)
        if run is not None and run.tick == tick - 1:
            run.tick, run.count, run.last_ms = tick, run.count + 1, time_ms
            return
        line = _Line(time_ms, text, tick, last_ms=time_ms)
        self._runs[text] = line
        self.lines.append(line)

    def text(self, *, header: Sequence[str], footer: Sequence[str] = ()) -> str:
        """The golden file: header, counts, digest, the projected lines, the footer (the
        session's last world state, if not kept, is digested here, as a recording writes
        it at its close)."""
        if (last := self._sampling.last()) is not None:
            self._digest(Topic.WORLD_STATE, *last)
        out = [*header]
        out += [f"messages {topic} {count}" for topic, count in self.counts.items()]
        out.append(f"decisions-not-fired {self.unfired}")
        out.append(f"digest sha256:{self.digest.hexdigest()}")
        out.append("---")
        out += [line.render() for line in self.lines]
        out.append("---")
        out += footer
        return "\n".join(out) + "\n"


# ------------------------------------------------------------------------ scenarios


def project_scenario(path: Path) -> str:
    """Run a scenario file in-process and return its golden text."""
    session = Session(load_scenario(path))
    projection = Projection()
    session.sink.add(projection)
    result = session.run()
    s = session.scenario
    header = (
        f"# golden projection of scenario {s.name} ({path.name})",
        f"# regenerate on purpose with: {REGENERATE}",
        f"scenario {s.name} seed={s.seed} ticks={s.ticks} tick_ms={s.tick_ms}",
    )
    footer = [f"verdict {'PASS' if v.ok else 'FAIL'} {v.name}: {v.detail}" for v in result.verdicts]
    return projection.text(header=header, footer=footer)


def golden_path(scenario: Path, directory: Path = GOLDEN_DIR) -> Path:
    return directory / f"{scenario.stem}{SUFFIX}"


def regenerate_command(scenario: Path, directory: Path = GOLDEN_DIR) -> str:
    """The command that rewrites this one golden file on purpose: a library scenario's by
    name, another's by its path and folder (``make golden`` rewrites only the library's)."""
    command = "python -m oimi.replay.golden --regenerate"
    in_library = scenario.resolve() in {s.resolve() for s in library_scenarios()}
    if in_library and directory.resolve() == GOLDEN_DIR.resolve():
        return f"{command} {scenario.stem}  (every library scenario: make golden)"
    return f"{command} {shlex.quote(str(scenario))} --dir {shlex.quote(str(directory))}"


class GoldenCheck:
    """The outcome of checking one scenario against its golden file."""

    def __init__(self, scenario: Path, golden: Path, problem: str = "") -> None:
        self.scenario = scenario
        self.golden = golden
        self.problem = problem
        """Empty when the session matches; else why not (a unified diff included)."""

    @property
    def ok(self) -> bool:
        return not self.problem


def check(scenario: Path, directory: Path = GOLDEN_DIR) -> GoldenCheck:
    """Run ``scenario`` and compare its projection with its golden file."""
    golden = golden_path(scenario, directory)
    if not golden.is_file():
        return GoldenCheck(
            scenario,
            golden,
            f"no golden file {golden} for {scenario.name}:"
            f" run {regenerate_command(scenario, directory)}",
        )
    expected = golden.read_text(encoding="utf-8")
    actual = project_scenario(scenario)
    if actual == expected:
        return GoldenCheck(scenario, golden)
    diff = list(
        difflib.unified_diff(
            expected.splitlines(),
            actual.splitlines(),
            fromfile=f"{golden.name} (golden)",
            tofile=f"{scenario.name} (this code)",
            lineterm="",
        )
    )
    if len(diff) > DIFF_LINES:
        diff = [*diff[:DIFF_LINES], f"... {len(diff) - DIFF_LINES} more diff lines"]
    return GoldenCheck(
        scenario,
        golden,
        f"{scenario.name} behaves differently from {golden}; if the change is intended,"
        f" run {regenerate_command(scenario, directory)}\n" + "\n".join(diff),
    )


def regenerate(scenarios: Iterable[Path], directory: Path = GOLDEN_DIR) -> list[Path]:
    """Write the golden file of each scenario; return the files written."""
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for scenario in scenarios:
        path = golden_path(scenario, directory)
        path.write_text(project_scenario(scenario), encoding="utf-8")
        written.append(path)
    return written


def stale_goldens(scenarios: Iterable[Path], directory: Path = GOLDEN_DIR) -> list[Path]:
    """Golden files whose scenario is not among ``scenarios``."""
    wanted = {golden_path(s, directory) for s in scenarios}
    return sorted(p for p in directory.glob(f"*{SUFFIX}") if p not in wanted)


# ---------------------------------------------------------------------------- CLI


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m oimi.replay.golden", description=__doc__)
    action = parser.add_mutually_exclusive_group(required=True)
    action.add_argument("--regenerate", action="store_true", help="rewrite the golden files")
    action.add_argument("--check", action="store_true", help="compare; exit 1 on a difference")
    parser.add_argument(
        "scenarios",
        nargs="*",
        type=Path,
        help="scenario files, or the library's by name (greeting); default: all the library's",
    )
    parser.add_argument("--dir", type=Path, default=GOLDEN_DIR, help="golden files' folder")
    args = parser.parse_args(argv)
    try:
        scenarios = [_named(path) for path in args.scenarios] or library_scenarios()
        if args.regenerate:
            for path in regenerate(scenarios, args.dir):
                print(f"wrote {path}")
            if not args.scenarios:
                for path in stale_goldens(scenarios, args.dir):
                    path.unlink()
                    print(f"removed {path} (its scenario is gone)")
            return 0
        failed = 0
        for scenario in scenarios:
            result = check(scenario, args.dir)
            print(f"{'ok' if result.ok else 'FAILED'} {scenario.name}")
            if not result.ok:
                failed += 1
                print(result.problem)
        return 1 if failed else 0
    except LocatedError as error:
        print(error, file=sys.stderr)
        return 2


def _named(path: Path) -> Path:
    """A scenario file as given, or the library's scenario of that name (``greeting``)."""
    if path.exists() or path.suffix or len(path.parts) > 1:
        return path
    shipped = {scenario.stem: scenario for scenario in library_scenarios()}
    if path.name not in shipped:
        known = ", ".join(shipped)
        raise LocatedError(
            f"no such file, nor a library scenario (one of {known})", source=str(path)
        )
    return shipped[path.name]


if __name__ == "__main__":
    sys.exit(main())
