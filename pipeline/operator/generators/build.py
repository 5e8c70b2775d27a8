"""A small builder for generated scripts: labelled blocks, jumps by label, rule messages.

Jumps name labels; :meth:`ScriptBuilder.build` turns them into the thesis's
``goalX/actY/blkZ`` paths, so a generator never counts blocks by hand.
"""

from __future__ import annotations

from oimi.pipeline.messages import (
    Action,
    AudioOut,
    Block,
    Goal,
    InstructionBlock,
    JumpBlock,
    Led,
    Move,
    MutexCmd,
    RuleAction,
    RuleMessage,
    Script,
    TerminusBlock,
)
from oimi.pipeline.operator.generator import Colour, GeneratorFailure
from oimi.pipeline.texts import did_you_mean
from oimi.pipeline.think.rulecodes import RuleCode

RuleSpec = tuple[int, str, RuleAction]
"""``(rulecode, id, action)`` of one alfa/omega message."""


def _rule_messages(rules: tuple[RuleSpec, ...], mutex: list[MutexCmd]) -> tuple[RuleMessage, ...]:
    return tuple(
        RuleMessage(
            rulecode=int(code), id=rid, intopic="", outtopic="", action=action, mutexcmd=cmd
        )
        for (code, rid, action), cmd in zip(rules, mutex, strict=True)
    )


def alfa_messages(*rules: RuleSpec) -> tuple[RuleMessage, ...]:
    """Alfa messages: ``M`` for all but the last, which is ``U``."""
    mutex = [MutexCmd.M] * len(rules)
    if rules:
        mutex[-1] = MutexCmd.U
    return _rule_messages(rules, mutex)


def omega_messages(*rules: RuleSpec) -> tuple[RuleMessage, ...]:
    """Omega messages: ``L`` for the first, then ``M``."""
    mutex = [MutexCmd.M] * len(rules)
    if rules:
        mutex[0] = MutexCmd.L
    return _rule_messages(rules, mutex)


def safety_rules(action: RuleAction) -> tuple[RuleSpec, ...]:
    """The safety rules every moving activity loads (``A``) and removes (``R``): a child
    too close, and the camera offline."""
    return (
        (RuleCode.CHILD_TOO_CLOSE, "child_too_close", action),
        (RuleCode.SENSORS_BLIND, "sensors_blind", action),
    )


def move(
    *,
    v_x_mps: float = 0.0,
    v_y_mps: float = 0.0,
    v_theta_radps: float = 0.0,
    duration_ms: int,
    wait_ms: int = 0,
) -> Move:
    """One move item."""
    return Move(
        v_x=v_x_mps, v_y=v_y_mps, v_theta=v_theta_radps, wait_t=wait_ms, duration=duration_ms
    )


def led(colour: Colour, *, duration_ms: int, wait_ms: int = 0, on: bool = True) -> Led:
    """One LED item."""
    r, g, b = colour
    return Led(r=r, g=g, b=b, turnas=1 if on else 0, wait_t=wait_ms, duration=duration_ms)


def audio(track: str, *, duration_ms: int, wait_ms: int = 0) -> AudioOut:
    """One audio item."""
    return AudioOut(track_path=track, wait_t=wait_ms, duration=duration_ms)


class _Jump:
    """A jump whose targets are still labels."""

    def __init__(self, toparse: str, true_label: str, false_label: str):
        self.toparse = toparse
        self.true_label = true_label
        self.false_label = false_label


class ScriptBuilder:
    """Goals, actions and blocks appended in reading order; labels resolved at build. Its
    errors (a jump to an unknown label, a label used twice) are the generator's bugs:
    :class:`GeneratorFailure`, logged at ERROR, not a refusal."""

    def __init__(self, activityname: str):
        self._name = activityname
        self._alfa: tuple[RuleMessage, ...] = ()
        self._omega: tuple[RuleMessage, ...] = ()
        self._goals: list[tuple[str, list[list[Block | _Jump]]]] = []
        self._labels: dict[str, str] = {}

    def rules(self, *, alfa: tuple[RuleMessage, ...], omega: tuple[RuleMessage, ...]) -> None:
        self._alfa, self._omega = alfa, omega

    def goal(self, goalid: str) -> None:
        """Start a goal (and its first action)."""
        self._goals.append((goalid, [[]]))

    def action(self) -> None:
        """Start a new action in the current goal."""
        self._goals[-1][1].append([])

    def _add(self, block: Block | _Jump, label: str) -> None:
        goals = self._goals
        if not goals:
            raise GeneratorFailure("block added before any goal", source=self._name)
        actions = goals[-1][1]
        if label:
            if label in self._labels:
                raise GeneratorFailure(f"label {label!r} used twice", source=self._name)
            self._labels[label] = (
                f"goal{len(goals) - 1}/act{len(actions) - 1}/blk{len(actions[-1])}"
            )
        actions[-1].append(block)

    def instruction(
        self,
        *,
        moves: tuple[Move, ...] = (),
        leds: tuple[Led, ...] = (),
        sounds: tuple[AudioOut, ...] = (),
        label: str = "",
    ) -> None:
        self._add(InstructionBlock(move=moves, led=leds, audioout=sounds), label)

    def jump(self, toparse: str, *, true: str = "", false: str = "", label: str = "") -> None:
        """A jump block; ``true``/``false`` are labels (empty: the next block)."""
        self._add(_Jump(toparse, true, false), label)

    def terminus(self, *, label: str = "") -> None:
        self._add(TerminusBlock(), label)

    def _resolve(self, label: str) -> str:
        if not label:
            return ""
        if label not in self._labels:
            hint = did_you_mean(label, self._labels)
            raise GeneratorFailure(f"jump to unknown label {label!r}{hint}", source=self._name)
        return self._labels[label]

    def _block(self, b: Block | _Jump) -> Block:
        if isinstance(b, _Jump):
            return JumpBlock(
                toparse=b.toparse,
                truejump=self._resolve(b.true_label),
                falsejump=self._resolve(b.false_label),
            )
        return b

    def build(self) -> Script:
        return Script(
            activityname=self._name,
            alfarulemessages=self._alfa,
            omegarulemessages=self._omega,
            goals=tuple(
                Goal(
                    goalid=gid,
                    actions=tuple(
                        Action(blocks=tuple(self._block(b) for b in blocks)) for blocks in actions
                    ),
                )
                for gid, actions in self._goals
            ),
        )
