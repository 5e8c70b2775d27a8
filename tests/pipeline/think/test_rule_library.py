"""The therapy rule library, driven tick by tick through the Map Producer and the chain."""

from __future__ import annotations

import json

import msgspec
from oimi.pipeline.messages import (
    InstructionBlock,
    MapUpdate,
    Move,
    MutexCmd,
    Policy,
    RuleAction,
    RuleMessage,
    WorldMap,
)
from oimi.pipeline.registries import Registries
from oimi.pipeline.sense.producer import MapProducer
from oimi.pipeline.think import rulecodes
from oimi.pipeline.think.chain import RuleChain
from oimi.pipeline.think.library import WAITING_ACTIVITY

ALL = [
    ("kick_starter", rulecodes.KICK_STARTER),
    ("child_too_close", rulecodes.CHILD_TOO_CLOSE),
    ("child_left", rulecodes.CHILD_LEFT),
    ("touch_reward", rulecodes.TOUCH_REWARD),
    ("attention_lost", rulecodes.ATTENTION_LOST),
    ("battery_low", rulecodes.BATTERY_LOW),
    ("joystick_note", rulecodes.JOYSTICK_NOTE),
    ("obstacle_too_close", rulecodes.OBSTACLE_TOO_CLOSE),
    ("hug_reward", rulecodes.HUG_REWARD),
    ("toy_nearby", rulecodes.TOY_NEARBY),
    ("sensors_blind", rulecodes.SENSORS_BLIND),
]


def pose(seq: int, rho: float, theta: float, t: int) -> MapUpdate:
    msg = json.dumps({"positionrho": rho, "positiontheta": theta, "positionchangetime": t})
    return MapUpdate(
        objectid="Human/child", attributename="poses", policy=Policy.R, jsonmsg=msg, seq=seq
    )


def touch(seq: int, kind: str, t: int) -> MapUpdate:
    msg = json.dumps({"touchtype": kind, "duration": 500, "startingtime": t})
    return MapUpdate(
        objectid="RobotStatus", attributename="touch", policy=Policy.A, jsonmsg=msg, seq=seq
    )


def battery(seq: int, ms: int) -> MapUpdate:
    return MapUpdate(
        objectid="RobotStatus",
        attributename="batterytimeleft",
        policy=Policy.R,
        jsonmsg=str(ms),
        seq=seq,
    )


class Session:
    """A map, a producer and a chain with every library rule active, in a running activity."""

    def __init__(self) -> None:
        self.map = WorldMap()
        self.map.scriptinfo.currentactivity = "game"
        self.map.robotstatus.batterytimeleft = 3_600_000
        self.map.robotstatus.setfields = ["batterytimeleft"]
        self.producer = MapProducer(self.map)
        self.chain = RuleChain(Registries.build().rules)
        self.chain.apply(
            [
                RuleMessage(
                    rulecode=code,
                    id=name,
                    intopic="",
                    outtopic="",
                    action=RuleAction.A,
                    mutexcmd=MutexCmd.U if name == "joystick_note" else MutexCmd.M,
                )
                for name, code in ALL
            ]
        )

    def tick(self, now_ms: int, *updates: MapUpdate) -> dict[str, list[str]]:
        for update in updates:
            assert self.producer.submit(update) is None
        assert self.producer.consume(now_ms) == []
        decisions = self.chain.propagate(self.map, now_ms=now_ms)
        return {d.rule: [c.path for c in d.changes] for d in decisions if d.fired}


def test_the_library_decides_tick_by_tick_through_a_session() -> None:
    s = Session()
    s.map.scriptinfo.block = InstructionBlock(
        move=(Move(v_x=0.3, v_y=0, v_theta=0, wait_t=0, duration=2000),)
    )

    # The child plays in front at 1.2 m: kick_starter's condition holds, but it only acts in idle.
    assert s.tick(100, pose(1, 1.2, 0.0, 100)) == {"kick_starter": []}

    # The child steps within 0.5 m while the robot moves: stop and soften the lights.
    fired = s.tick(200, pose(2, 0.4, 0.0, 200))
    assert "scriptinfo.block.move" in " ".join(fired["child_too_close"])
    assert s.map.scriptinfo.block.move == () and s.map.scriptinfo.changed
    # Still close next tick, but the block is already softened: fires, changes nothing.
    s.map.scriptinfo.changed = False
    assert s.tick(220, pose(3, 0.4, 0.0, 220))["child_too_close"] == []

    # A caress: rewarded once, even though the touch stays in the register.
    fired = s.tick(300, pose(4, 1.0, 0.0, 300), touch(5, "C", 300))
    assert s.map.scriptinfo.block.flagged == "reward" and fired["touch_reward"]
    assert s.tick(320, pose(6, 1.0, 0.0, 320))["touch_reward"] == []

    # The child wanders off beyond 3 m: switch to the waiting script.
    s.tick(400, pose(7, 3.5, 0.0, 400))
    assert s.map.scriptinfo.overridecmd and s.map.scriptinfo.currentactivity == WAITING_ACTIVITY

    # Battery low: the LIFO is dropped and the idle activity forced.
    s.map.scriptinfo.overridecmd = False
    s.map.scriptinfo.currentactivity = "game"
    s.map.scriptinfo.script_vect = ["activities/next.json"]
    s.tick(500, battery(8, 60_000))
    assert (
        s.map.scriptinfo.script_vect == [] and s.map.scriptinfo.currentactivity == "idle_activity"
    )


def test_attention_lost_calls_back_at_most_every_ten_seconds() -> None:
    s = Session()
    # The child is seen, but far to the side, for long enough.
    for t in range(0, 6000, 500):
        s.tick(t, pose(1 + t, 2.0, 2.0, t))
    assert s.map.scriptinfo.block is not None and s.map.scriptinfo.block.flagged == "call_back"
    first = s.map.variables["@called_back_at"]
    s.tick(7000, pose(99999, 2.0, 2.0, 7000))
    assert s.map.variables["@called_back_at"] == first


def test_joystick_note_counts_takeovers_once_per_engagement() -> None:
    s = Session()
    s.map.robotstatus.joystick_engaged = True
    s.map.robotstatus.joystick_engagedtime = 100
    s.tick(100)
    s.tick(120)
    assert s.map.variables["@joystick_takeovers"] == "1"
    assert s.map.variables["@joystick_engaged_since"] == "100"
    s.map.robotstatus.joystick_engagedtime = 500  # released, then engaged again
    s.tick(500)
    assert s.map.variables["@joystick_takeovers"] == "2"


def test_kick_starter_welcomes_a_child_once_and_only_while_idle() -> None:
    s = Session()
    s.tick(100, pose(1, 1.5, 0.1, 100))
    assert s.map.scriptinfo.block is None, "not idle: no welcome"
    s.map.scriptinfo.currentactivity = "idle_activity"
    s.tick(200, pose(2, 1.5, 0.1, 200))
    assert s.map.scriptinfo.block.flagged == "welcome"
    s.map.scriptinfo.block = None
    s.tick(300, pose(3, 1.5, 0.1, 300))
    assert s.map.scriptinfo.block is None, "welcomed once"


def sighting(seq: int, objectid: str, rho: float, t: int) -> MapUpdate:
    msg = json.dumps({"positionrho": rho, "positiontheta": 0.0, "positionchangetime": t})
    return MapUpdate(
        objectid=objectid, attributename="poses", policy=Policy.R, jsonmsg=msg, seq=seq
    )


def test_furniture_too_close_stops_a_moving_block() -> None:
    s = Session()
    s.map.scriptinfo.block = InstructionBlock(
        move=(Move(v_x=0.0, v_y=0.2, v_theta=0, wait_t=0, duration=2000),)
    )
    s.tick(100, sighting(1, "Obstacle/shelf", 0.6, 100))
    assert s.map.scriptinfo.block.move
    s.tick(200, sighting(2, "Obstacle/shelf", 0.4, 200))
    assert s.map.scriptinfo.block.flagged == "softened" and s.map.scriptinfo.block.move == ()


def test_a_hug_gets_its_own_reward_once() -> None:
    s = Session()
    s.tick(100, touch(1, "H", 100))
    assert s.map.scriptinfo.block.flagged == "reward" and s.map.variables["@rewarded_H"] == "100"
    s.map.scriptinfo.block = None
    s.tick(200)
    assert s.map.scriptinfo.block is None


def test_the_target_toy_within_reach_is_noted_on_the_toy() -> None:
    s = Session()
    target = MapUpdate(
        objectid="Object/ball", attributename="istarget", policy=Policy.R, jsonmsg="s_true", seq=1
    )
    s.tick(100, target, sighting(2, "Object/ball", 1.5, 100))
    assert "nearby_since" not in s.map.objects[0].attributes
    s.tick(200, sighting(3, "Object/ball", 0.8, 200))
    assert s.map.objects[0].attributes["nearby_since"] == "200"


def test_a_camera_offline_stops_a_moving_block_until_it_is_back() -> None:
    s = Session()
    s.map.scriptinfo.block = InstructionBlock(
        move=(Move(v_x=0.2, v_y=0.0, v_theta=0, wait_t=0, duration=2000),)
    )
    online = MapUpdate(
        objectid="Camera/front", attributename="isonline", policy=Policy.R, jsonmsg="s_true", seq=1
    )
    s.tick(100, online)
    assert s.map.scriptinfo.block.move
    s.tick(200, msgspec.structs.replace(online, jsonmsg="s_false", seq=2))
    assert s.map.scriptinfo.block.flagged == "softened" and s.map.scriptinfo.block.move == ()


def test_battery_low_does_not_fire_before_any_battery_reading() -> None:
    """Issue 16 ruling on thesis 4.3/4.5: an attribute never updated is unknown, and a
    condition on an unknown value is false (battery_below, rule code 5)."""
    s = Session()
    s.map = WorldMap()  # no battery sensor: batterytimeleft was never set
    s.map.scriptinfo.currentactivity = "game"
    s.map.scriptinfo.script_vect = ["activities/next.json"]
    s.producer = MapProducer(s.map)
    assert "battery_low" not in s.tick(100)
    assert s.map.scriptinfo.currentactivity == "game" and not s.map.scriptinfo.overridecmd
    assert "battery_low" in s.tick(200, battery(1, 60_000))
    assert s.map.scriptinfo.currentactivity == "idle_activity"
