"""The Actuator (thesis 5.3, the "fake actuator"): runs instruction blocks chunk by chunk.

It takes the block the loop issues (section 4.2, step 1), runs its three channels
in parallel on the simulated clock, clamps what the script asks to the robot's
limits, ramps the body's velocity at the largest accelerations, and lets the
operator's joystick override, freeze or interrupt the block (see
``pipeline.act.joystick`` and ``docs/actuator-and-joystick.md``).

No clock, no threads, no IO: every time is a ``now_ms`` argument, which never goes
back. One :meth:`Actuator.step` per tick, after that tick's :meth:`Actuator.issue`
and :meth:`Actuator.joystick` calls.
"""

from __future__ import annotations

import math
from typing import Final

from oimi.pipeline.act.channels import CHANNEL_ORDER, Channel, ChannelCursor, Due, Phase
from oimi.pipeline.act.joystick import read_pad
from oimi.pipeline.act.limits import (
    STILL,
    RobotLimits,
    Velocity,
    clamp_velocity,
    fmt,
    ramp_velocity,
)
from oimi.pipeline.events import JoystickInput, MotionSource
from oimi.pipeline.messages import (
    ActuatorCommand,
    ActuatorOutputs,
    AudioCommand,
    AudioOut,
    InstructionBlock,
    Led,
    LedCommand,
    Message,
    Move,
    MoveCommand,
    Source,
)

LIGHTS_OFF: tuple[float, float, float] = (0.0, 0.0, 0.0)

_CHANNEL_RANK = {channel.value: rank for rank, channel in enumerate(CHANNEL_ORDER)}


class ActuatorStep(Message):
    """What the actuator did in one tick."""

    commands: tuple[ActuatorCommand, ...]
    """Commands issued this tick only (changes), in channel order move, led, audio."""
    outputs: ActuatorOutputs
    """What the body should do now: velocity after limits and ramp, LED colour, track."""
    done: bool
    """The current block is consumed (True when there is none)."""
    clamps: tuple[str, ...] = ()
    """A report for each value clamped this tick (one per issued command and value)."""
    notes: tuple[str, ...] = ()
    """Other things worth a log line: ignored joystick input, overridden script moves."""
    block: InstructionBlock | None = None
    """The block, when it started (or restarted) this tick."""


_NO_BLOCK: Final = ((0, 0, 0), True, math.inf)
"""With no block: its progress, that it is done, and no event due."""


class Actuator:
    """Executes instruction blocks and joystick input into body outputs and commands."""

    def __init__(self, limits: RobotLimits, *, tick_ms: int):
        if tick_ms <= 0:
            raise ValueError(f"actuator: tick_ms must be positive, got {tick_ms}")
        self._limits = limits
        self._tick_ms = tick_ms
        self._last_ms: int | None = None
        self._last_step_ms: int | None = None
        # the block and its clock (block time = now - start - time spent frozen)
        self._block: InstructionBlock | None = None
        self._cursors: dict[Channel, ChannelCursor] = {}
        self._progress, self._done, self._due_ms = _NO_BLOCK
        """:attr:`progress`, :attr:`done` and when the block's next event falls due (block
        time), noted whenever the block or one of its cursors changes (:meth:`_note_cursors`)."""
        self._start_ms = 0
        self._frozen_ms = 0
        self._frozen_since: int | None = None
        self._started: InstructionBlock | None = None
        self._block_source = MotionSource.SCRIPT
        # the body
        self._target = STILL
        self._velocity = STILL
        self._led = LIGHTS_OFF
        self._audio = ""
        self._brake = False
        """The body must take this tick's velocity at once (a protective stop)."""
        self._outputs: ActuatorOutputs | None = None
        """The last tick's outputs (reused while nothing in them changed)."""
        # the pad
        self._lock = False
        self._blocking = False
        self._x_held = False
        self._interrupted = False
        self._driving: Velocity | None = None
        """The joystick's velocity while it holds the move channel (lock held), else None."""
        # what this tick produced so far
        self._commands: list[ActuatorCommand] = []
        self._clamps: list[str] = []
        self._notes: list[str] = []

    # ----------------------------------------------------------------- public

    @property
    def block(self) -> InstructionBlock | None:
        """The block being executed (or consumed and kept until the next one)."""
        return self._block

    @property
    def done(self) -> bool:
        """The current block is consumed (True when there is none)."""
        return self._done

    @property
    def progress(self) -> tuple[int, int, int]:
        """Indices of the move, LED and audio items being executed (``submove``,
        ``subled``, ``subaout``); a finished channel gives its item count."""
        return self._progress

    @property
    def velocity(self) -> Velocity:
        """The body-frame velocity the last step's outputs ask for (``v_x``, ``v_y``,
        ``v_theta``; the same object while it does not change)."""
        return self._velocity

    @property
    def engaged(self) -> bool:
        """The operator holds the safety lock: the joystick drives."""
        return self._lock

    @property
    def motion_source(self) -> MotionSource:
        """Who drives the body now: the joystick (lock held), a rule's block or the script."""
        return MotionSource.JOYSTICK if self._driving is not None else self._block_source

    @property
    def frozen(self) -> bool:
        """The block's clock stands still (blocking mode or interrupted)."""
        return self._interrupted or (self._lock and self._blocking)

    def issue(
        self,
        block: InstructionBlock | None,
        *,
        changed: bool,
        now_ms: int,
        forced: bool = False,
    ) -> None:
        """Loop step 1: hand the actuator the map's block.

        A block that differs from the current one starts from its beginning, and so
        does the same block when ``changed`` is set; the same block again is a no-op.
        ``None`` drops the current block. Whatever the old block left on (moving,
        lights, track) is stopped. ``forced``: a rule put the block in the map.
        """
        self._advance(now_ms)
        if block is None:
            if self._block is not None:
                self._stop_what_is_on()
                self._block = None
                self._cursors = {}
                self._note_cursors()
            return
        if self._block is not None and not changed and block == self._block:
            return
        if self._block is not None:
            self._stop_what_is_on()
        self._block = block
        self._started = block
        self._block_source = MotionSource.RULE if forced else MotionSource.SCRIPT
        channels = block.channel_items()
        self._cursors = {channel: ChannelCursor(items) for channel, items in channels.items()}
        self._note_cursors()
        self._start_ms = now_ms
        self._frozen_ms = 0
        self._frozen_since = now_ms if self.frozen else None
        for channel, items in channels.items():
            for i, item in enumerate(items):
                if item.wait_t < 0 or item.duration < 0:
                    self._notes.append(
                        f"{channel}[{i}]: negative wait_t {item.wait_t} or duration "
                        f"{item.duration} ms counted as 0"
                    )

    def joystick(self, pad: JoystickInput, *, now_ms: int) -> None:
        """Take the pad's new state (see ``pipeline.act.joystick`` for the mapping)."""
        self._advance(now_ms)
        state = read_pad(pad, self._limits)
        self._notes.extend(state.notes)
        if not state.lock:
            if self._lock:
                self._lock = False
                self._blocking = False
                self._x_held = False
                self._driving = None
                self._target = self._velocity = STILL  # at once, not ramped down
                self._brake = True
                self._commands.append(MoveCommand(source=Source.SAFETY, stop=True))
                why = f" ({pad.release})" if pad.release is not None else ""
                self._notes.append(f"joystick: safety lock released{why}, robot stopped")
                self._refreeze(now_ms)
            elif not state.neutral:
                self._notes.append("joystick: input ignored without the safety lock (LB)")
            return
        engaged = not self._lock
        self._lock = True
        if engaged:
            self._notes.append("joystick: safety lock engaged, the joystick drives")
            if self._interrupted:
                self._interrupted = False
                self._notes.append("joystick: block execution resumed")
        if state.interrupt and not self._x_held and not self._interrupted:
            self._interrupted = True
            self._notes.append(
                "joystick: block execution interrupted until the next engagement of the lock"
            )
        self._x_held = state.interrupt
        if state.blocking != self._blocking:
            mode = "blocking (block frozen)" if state.blocking else "non-blocking"
            self._notes.append(f"joystick: {mode} mode")
        self._blocking = state.blocking
        self._refreeze(now_ms)
        if engaged or state.velocity != self._driving:
            self._driving = state.velocity
            self._target = state.velocity
            v_x, v_y, v_theta = state.velocity
            self._commands.append(
                MoveCommand(source=Source.JOYSTICK, v_x=v_x, v_y=v_y, v_theta=v_theta)
            )

    def step(self, *, now_ms: int) -> ActuatorStep:
        """Advance to ``now_ms`` (once per tick): issue what fell due, ramp the body."""
        self._advance(now_ms)
        if self._block is not None and not self.frozen:
            block_ms = self._block_ms(now_ms)
            if block_ms >= self._due_ms:  # (an event falls due: not at most ticks)
                for channel in CHANNEL_ORDER:
                    cursor = self._cursors[channel]
                    if cursor.due(block_ms):
                        for due in cursor.take_due(block_ms):
                            self._run(channel, due)
                self._note_cursors()
        elapsed_ms = self._tick_ms if self._last_step_ms is None else now_ms - self._last_step_ms
        self._last_step_ms = now_ms
        if self._velocity is not self._target:  # the ramp returns the target itself on reaching it
            self._velocity = ramp_velocity(
                self._velocity, self._target, self._limits, dt_ms=elapsed_ms
            )
        outputs = self._outputs
        v_x, v_y, v_theta = self._velocity
        if (
            outputs is None
            or outputs.v_x is not v_x
            or outputs.v_y is not v_y
            or outputs.v_theta is not v_theta
            or outputs.led is not self._led
            or outputs.audio is not self._audio
            or outputs.brake is not self._brake
        ):  # a frozen struct holding the same objects: a quiet tick hands on the last one
            outputs = self._outputs = ActuatorOutputs(
                v_x=v_x,
                v_y=v_y,
                v_theta=v_theta,
                led=self._led,
                audio=self._audio,
                brake=self._brake,
            )
        commands, clamps, notes = self._commands, self._clamps, self._notes
        result = ActuatorStep(
            commands=tuple(sorted(commands, key=lambda c: _CHANNEL_RANK[c.channel]))
            if commands
            else (),
            outputs=outputs,
            clamps=tuple(clamps) if clamps else (),
            notes=tuple(notes) if notes else (),
            done=self.done,
            block=self._started,
        )
        if commands:
            commands.clear()
        if clamps:
            clamps.clear()
        if notes:
            notes.clear()
        self._started = None
        self._brake = False
        return result

    def hold(self, velocity: Velocity) -> None:
        """The safety supervisor let only ``velocity`` through this tick: it is the body's
        velocity now, and the next ramp starts from it."""
        self._velocity = velocity

    # ---------------------------------------------------------------- internal

    def _note_cursors(self) -> None:
        """Note :attr:`progress`, :attr:`done` and when the next event falls due (once a
        block starts, ends or one of its channels moves on: not at every tick)."""
        if self._block is None:
            self._progress, self._done, self._due_ms = _NO_BLOCK
            return
        cursors = self._cursors
        move, led, audio = [cursors[channel].index for channel in CHANNEL_ORDER]
        self._progress = (move, led, audio)
        self._done = all(cursor.done for cursor in cursors.values())
        self._due_ms = min([cursor.next_ms for cursor in cursors.values()])

    def _advance(self, now_ms: int) -> None:
        if self._last_ms is not None and now_ms < self._last_ms:
            raise ValueError(f"actuator: time went back from {self._last_ms} ms to {now_ms} ms")
        self._last_ms = now_ms

    def _refreeze(self, now_ms: int) -> None:
        """Start or end a frozen stretch of the block's clock after a pad change."""
        if self.frozen and self._frozen_since is None:
            self._frozen_since = now_ms
        elif not self.frozen and self._frozen_since is not None:
            self._frozen_ms += now_ms - self._frozen_since
            self._frozen_since = None

    def _block_ms(self, now_ms: int) -> int:
        """The block's own clock: time since it started, less the time spent frozen."""
        frozen_now = 0 if self._frozen_since is None else now_ms - self._frozen_since
        return now_ms - self._start_ms - self._frozen_ms - frozen_now

    def _stop_what_is_on(self) -> None:
        """Stop the channels the old block left on (the joystick keeps its move)."""
        if self._driving is None and self._target != STILL:
            self._commands.append(MoveCommand(source=Source.SCRIPT, stop=True))
            self._target = STILL
        if self._led != LIGHTS_OFF:
            self._commands.append(LedCommand(source=Source.SCRIPT, stop=True))
            self._led = LIGHTS_OFF
        if self._audio:
            self._commands.append(
                AudioCommand(source=Source.SCRIPT, track_path=self._audio, stop=True)
            )
            self._audio = ""

    def _run(self, channel: Channel, due: Due) -> None:
        assert self._block is not None
        label = f"{channel}[{due.item}]"
        if channel is Channel.MOVE:
            self._run_move(self._block.move[due.item], due.phase, label)
        elif channel is Channel.LED:
            self._run_led(self._block.led[due.item], due.phase, label)
        else:
            self._run_audio(self._block.audioout[due.item], due.phase)

    def _run_move(self, item: Move, phase: Phase, label: str) -> None:
        if self._driving is not None:
            what = "command" if phase is Phase.ACT else "stop"
            self._notes.append(f"{label}: script {what} overridden by the joystick")
            return
        if phase is Phase.STOP:
            self._commands.append(MoveCommand(source=Source.SCRIPT, stop=True))
            self._target = STILL
            return
        requested = Velocity(float(item.v_x), float(item.v_y), float(item.v_theta))
        velocity, reports = clamp_velocity(requested, self._limits, what=label)
        self._clamps.extend(reports)
        self._commands.append(
            MoveCommand(
                source=Source.SCRIPT,
                v_x=velocity.v_x,
                v_y=velocity.v_y,
                v_theta=velocity.v_theta,
                clamped=bool(reports),
                requested=tuple(requested) if reports else None,
            )
        )
        self._target = velocity

    def _run_led(self, item: Led, phase: Phase, label: str) -> None:
        if phase is Phase.STOP:
            self._commands.append(LedCommand(source=Source.SCRIPT, stop=True))
            self._led = LIGHTS_OFF
            return
        colour: list[float] = []
        reports: list[str] = []
        asked = (float(item.r), float(item.g), float(item.b))
        for name, value in zip("rgb", asked, strict=True):
            within = min(1.0, max(0.0, value)) if math.isfinite(value) else 0.0
            if within != value:
                reports.append(f"{label}: {name} {fmt(value)} outside [0, 1], clamped to {within}")
            colour.append(within)
        self._clamps.extend(reports)
        r, g, b = colour if item.turnas != 0 else LIGHTS_OFF
        self._commands.append(
            LedCommand(
                source=Source.SCRIPT,
                r=r,
                g=g,
                b=b,
                clamped=bool(reports),
                requested=asked if reports else None,
            )
        )
        self._led = (r, g, b)

    def _run_audio(self, item: AudioOut, phase: Phase) -> None:
        stop = phase is Phase.STOP
        self._commands.append(
            AudioCommand(source=Source.SCRIPT, track_path=item.track_path, stop=stop)
        )
        self._audio = "" if stop else item.track_path
