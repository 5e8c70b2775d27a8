"""The rule library for therapy sessions, written in the condition language.

Each rule's condition is its class attribute ``condition_text``; its body changes
the map (the current block and its ``changed`` flag, ``overridecmd``, variables,
attributes). Bodies are idempotent per situation, so a rule that keeps firing
does not keep restarting the actuators; a body that decides to do nothing returns
``Effect.UNCHANGED``, which spares the chain comparing the map, ``writes`` names
the parts of the map a body may change, and every body calls ``ctx.changing()`` before
its first change (``announces``): only then are those parts encoded, to compare after it.
"""

from __future__ import annotations

from typing import Final

from oimi.pipeline.messages import AudioOut, InstructionBlock, Led, Move, WorldMap
from oimi.pipeline.think import rulecodes
from oimi.pipeline.think.conditions import Evaluation
from oimi.pipeline.think.rules import Effect, Rule, RuleContext

IDLE_ACTIVITY: Final = "idle_activity"
WAITING_ACTIVITY: Final = "wait_for_child"


def replace_block(world_map: WorldMap, block: InstructionBlock) -> None:
    """Put ``block`` in place of the current one and ask the actuator to restart."""
    world_map.scriptinfo.block = block
    world_map.scriptinfo.changed = True


def force_switch(world_map: WorldMap, activity: str, *, goal: int = 0, action: int = 0) -> None:
    """Ask the Block Reader for a compulsory switch to ``activity`` (loop step 5)."""
    info = world_map.scriptinfo
    info.currentactivity = activity
    info.goalid, info.actionid, info.blockid = f"goal{goal}", f"act{action}", "blk0"
    info.overridecmd = True


def _led(r: float, g: float, b: float, *, duration: int, wait_t: int = 0) -> Led:
    return Led(r=r, g=g, b=b, turnas=1, wait_t=wait_t, duration=duration)


class KickStarter(Rule):
    """While idle, welcomes a child who comes in front within 2 m with a green glow, once."""

    housekeeping = True
    """Kept out of the analysis report by default: it keeps the session running, it is not
    something a therapist needs to see (``analysis.metrics.rule_episodes``)."""

    announces = True
    rulecode = rulecodes.KICK_STARTER
    condition_text = "{CLASS #Human L ?child B: infront (), B: closer_than (2.0)} ! {TRUE}"
    writes = ("humans", "scriptinfo")

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        child = found.entity(world_map, "?child")
        if child is None or child.attributes.get("welcomed") == "yes":
            return Effect.UNCHANGED
        if world_map.scriptinfo.currentactivity != IDLE_ACTIVITY:
            return Effect.UNCHANGED
        ctx.changing()
        child.attributes["welcomed"] = "yes"
        replace_block(
            world_map,
            InstructionBlock(led=(_led(0.1, 0.8, 0.3, duration=1500),), flagged="welcome"),
        )
        return Effect.CHANGED


def soften(
    world_map: WorldMap, found: Evaluation, ctx: RuleContext, alias: str | None = None
) -> Effect:
    """Stop moving and dim the lights, unless the block does not move or is already softened;
    the entity bound to ``alias``, if any, is marked with the time (``$too_close_at``)."""
    block = world_map.scriptinfo.block
    moving = block is not None and any(m.v_x or m.v_y or m.v_theta for m in block.move)
    if not moving or (block is not None and block.flagged == "softened"):
        return Effect.UNCHANGED
    ctx.changing()
    entity = found.entity(world_map, alias) if alias else None
    if entity is not None:
        entity.attributes["too_close_at"] = str(ctx.now_ms)
    replace_block(
        world_map,
        InstructionBlock(led=(_led(0.3, 0.15, 0.05, duration=2000),), flagged="softened"),
    )
    return Effect.CHANGED


class ChildTooClose(Rule):
    """A child closer than 0.8 m (centre to centre, a gap of about 0.25 m): stop moving and
    soften the lights (the block is replaced)."""

    announces = True
    rulecode = rulecodes.CHILD_TOO_CLOSE
    condition_text = "{CLASS #Human L ?child ?THIS>&positionrho OP< 0.8} ! {TRUE}"
    writes = ("humans", "scriptinfo")

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        return soften(world_map, found, ctx, "?child")


class ObstacleTooClose(Rule):
    """Furniture closer than 0.45 m (sonar): stop moving and soften the lights."""

    announces = True
    rulecode = rulecodes.OBSTACLE_TOO_CLOSE
    condition_text = "{CLASS #Obstacle L ?thing ?THIS>&positionrho OP< 0.45} ! {TRUE}"
    writes = ("obstacles", "scriptinfo")

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        return soften(world_map, found, ctx, "?thing")


class SensorsBlind(Rule):
    """The camera is offline: the robot cannot see a child coming, so it stops moving
    (the block is softened, as for a child too close) until the camera is back."""

    housekeeping = True
    """Kept out of the analysis report by default: it keeps the session running, it is not
    something a therapist needs to see (``analysis.metrics.rule_episodes``)."""

    announces = True
    rulecode = rulecodes.SENSORS_BLIND
    condition_text = "! {E: camera_offline ()}"
    writes = ("scriptinfo",)

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        return soften(world_map, found, ctx)


class ChildLeft(Rule):
    """The child tracked by the activity went farther than 3 m: switch to the waiting script."""

    announces = True
    rulecode = rulecodes.CHILD_LEFT
    condition_text = "{CLASS #Human U ?child} ! {E: far (?child, 3.0)}"
    writes = ("scriptinfo", "variables")

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        current = world_map.scriptinfo.currentactivity
        if current in (WAITING_ACTIVITY, IDLE_ACTIVITY) or world_map.scriptinfo.overridecmd:
            return Effect.UNCHANGED
        ctx.changing()
        world_map.variables["@left_during"] = current
        force_switch(world_map, WAITING_ACTIVITY)
        return Effect.CHANGED


def reward_touch(
    world_map: WorldMap, ctx: RuleContext, touchtype: str, block: InstructionBlock
) -> Effect:
    """Play ``block`` once for the latest touch of ``touchtype`` (remembered in a variable)."""
    touches = [t for t in world_map.robotstatus.touch if t.touchtype == touchtype]
    if not touches:
        return Effect.UNCHANGED
    key, stamp = f"@rewarded_{touchtype}", str(touches[-1].startingtime)
    if world_map.variables.get(key) == stamp:
        return Effect.UNCHANGED
    ctx.changing()
    world_map.variables[key] = stamp
    replace_block(world_map, block)
    return Effect.CHANGED


class TouchReward(Rule):
    """A caress (``C``) is rewarded with a rainbow of light and a chime, once per touch."""

    announces = True
    rulecode = rulecodes.TOUCH_REWARD
    condition_text = '! {E: touched ("C")}'
    writes = ("scriptinfo", "variables")
    reward = InstructionBlock(
        led=(
            _led(1.0, 0.2, 0.2, duration=400),
            _led(1.0, 0.8, 0.1, duration=400),
            _led(0.2, 1.0, 0.3, duration=400),
            _led(0.2, 0.4, 1.0, duration=400),
        ),
        audioout=(AudioOut(track_path="reward_chime.wav", wait_t=0, duration=1600),),
        flagged="reward",
    )

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        return reward_touch(world_map, ctx, "C", self.reward)


class HugReward(Rule):
    """A hug (``H``) is answered with a slow warm glow and a purr, once per hug."""

    announces = True
    rulecode = rulecodes.HUG_REWARD
    condition_text = '! {E: touched ("H")}'
    writes = ("scriptinfo", "variables")
    reward = InstructionBlock(
        led=(_led(1.0, 0.5, 0.2, duration=1500),),
        audioout=(AudioOut(track_path="purr.wav", wait_t=0, duration=1500),),
        flagged="reward",
    )

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        return reward_touch(world_map, ctx, "H", self.reward)


class AttentionLost(Rule):
    """No child in front for 5 s: a call-back block (a wiggle, a warm light, a call), every 10 s."""

    announces = True
    rulecode = rulecodes.ATTENTION_LOST
    condition_text = "{CLASS #Human L ?child} ! {E: attention_low (?child, 5000)}"
    writes = ("scriptinfo", "variables")
    repeat_ms: Final = 10_000

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        last = int(world_map.variables.get("@called_back_at", str(-self.repeat_ms)))
        if ctx.now_ms - last < self.repeat_ms:
            return Effect.UNCHANGED
        ctx.changing()
        world_map.variables["@called_back_at"] = str(ctx.now_ms)
        wiggle = (
            Move(v_x=0.0, v_y=0.0, v_theta=0.6, wait_t=0, duration=400),
            Move(v_x=0.0, v_y=0.0, v_theta=-0.6, wait_t=0, duration=400),
        )
        replace_block(
            world_map,
            InstructionBlock(
                move=wiggle,
                led=(_led(1.0, 0.6, 0.1, duration=800),),
                audioout=(AudioOut(track_path="come_play.wav", wait_t=0, duration=1500),),
                flagged="call_back",
            ),
        )
        return Effect.CHANGED


class BatteryLow(Rule):
    """Battery below 2 minutes: drop the waiting activities and go to the idle activity."""

    announces = True
    rulecode = rulecodes.BATTERY_LOW
    condition_text = "! {E: battery_below (120000)}"
    writes = ("scriptinfo",)

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        info = world_map.scriptinfo
        if info.currentactivity == IDLE_ACTIVITY and not info.script_vect:
            return Effect.UNCHANGED
        ctx.changing()
        info.script_vect = []
        force_switch(world_map, IDLE_ACTIVITY)
        return Effect.CHANGED


class JoystickNote(Rule):
    """Notes in the map when the operator took the robot over with the joystick."""

    housekeeping = True
    """Kept out of the analysis report by default: it keeps the session running, it is not
    something a therapist needs to see (``analysis.metrics.rule_episodes``)."""

    announces = True
    rulecode = rulecodes.JOYSTICK_NOTE
    condition_text = "! {E: joystick_engaged ()}"
    writes = ("variables",)

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        since = str(world_map.robotstatus.joystick_engagedtime)
        if world_map.variables.get("@joystick_engaged_since") == since:
            return Effect.UNCHANGED
        ctx.changing()
        world_map.variables["@joystick_engaged_since"] = since
        count = int(world_map.variables.get("@joystick_takeovers", "0")) + 1
        world_map.variables["@joystick_takeovers"] = str(count)
        return Effect.CHANGED


class ToyNearby(Rule):
    """The target toy is within 1 m: noted on the toy (``$nearby_since``) for scripts to use."""

    announces = True
    rulecode = rulecodes.TOY_NEARBY
    condition_text = "{CLASS #Object L ?toy ?THIS>&istarget OP= 1} ! {E: near (?toy, 1.0)}"
    writes = ("objects",)

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        toy = found.entity(world_map, "?toy")
        if toy is None or "nearby_since" in toy.attributes:
            return Effect.UNCHANGED
        ctx.changing()
        toy.attributes["nearby_since"] = str(ctx.now_ms)
        return Effect.CHANGED


BUILTIN_RULES: Final[tuple[type[Rule], ...]] = (
    KickStarter,
    ChildTooClose,
    ChildLeft,
    TouchReward,
    AttentionLost,
    BatteryLow,
    JoystickNote,
    ObstacleTooClose,
    HugReward,
    ToyNearby,
    SensorsBlind,
)
"""The shipped rule classes, in rule-code order (a session's rule registry starts from them)."""
