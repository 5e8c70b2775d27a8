"""Comparing a session being produced with a recorded one, message by message, streaming.

The :class:`Comparator` is a sink: each event the replay emits is encoded and
compared, byte for byte, with the next recorded message of its topic at the
same tick; only on a mismatch are both payloads decoded to find the first
differing field. The recording is read once, in file order, and only the
current tick's messages are held, so memory does not grow with the session.
"""

from __future__ import annotations

import enum
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from typing import Any, Final

import msgspec
from oimi.pipeline.events import Event, Topic, encode
from oimi.pipeline.jsontree import ABSENT, differences
from oimi.pipeline.sink import NS_PER_MS
from oimi.pipeline.texts import clipped
from oimi.recorder.errors import RecordingError
from oimi.recorder.reader import RecordedMessage, Recording
from oimi.recorder.world_sampling import recorded_sampling
from oimi.scenarios.session.watchdog import watching

Watch = Callable[[int, int], None]
"""Hears a replay's progress: ``(ticks replayed, the session's ticks)``."""
WATCH_TICKS: Final = 1000
"""How often a replay's progress is told (20 s of a 50 Hz session)."""
CONTEXT_MESSAGES: Final = 5
"""How many matched messages a divergence report shows before the difference."""
VALUE_CHARS: Final = 300
"""Longest value text in a report; longer values are cut with an ellipsis."""


class DivergenceKind(enum.StrEnum):
    CHANGED = "changed"
    """Both sessions have a message on the topic at the tick, and they differ."""
    MISSING = "missing"
    """The recording has a message the replay did not produce."""
    EXTRA = "extra"
    """The replay produced a message the recording does not have."""


class Seen(msgspec.Struct, frozen=True, kw_only=True):
    """A message compared equal, shown as context before a divergence."""

    topic: str
    tick: int
    time_ms: int
    payload: str
    """The payload's JSON, cut to ``VALUE_CHARS``."""


class Divergence(msgspec.Struct, frozen=True, kw_only=True):
    """The first difference between the recorded and the replayed session."""

    kind: DivergenceKind
    topic: str
    tick: int
    time_ms: int
    path: str
    """The first differing field, ``$.decisions[0].fired`` (``$`` for a whole message)."""
    recorded: str
    """The recorded value as JSON (``<none>`` when the recording has no message)."""
    replayed: str
    """The replayed value as JSON (``<none>`` when the replay produced no message)."""
    before: tuple[Seen, ...] = ()
    """The last messages compared equal, oldest first."""


class Comparison(msgspec.Struct, frozen=True, kw_only=True):
    """The outcome of a replay: messages compared per topic and the first divergence."""

    mode: str
    recording: str
    ticks: int
    """Ticks replayed."""
    compared: dict[str, int]
    """Messages compared equal, per topic (in ``Topic`` order)."""
    divergence: Divergence | None = None
    notes: tuple[str, ...] = ()
    """Differences of set-up between the recording and this code (versions, configuration)."""

    @property
    def ok(self) -> bool:
        return self.divergence is None


class Diverged(Exception):
    """Raised inside the replay at the first divergence, to stop it at once."""

    def __init__(self, divergence: Divergence) -> None:
        super().__init__(f"{divergence.kind} on {divergence.topic} at tick {divergence.tick}")
        self.divergence = divergence


# ------------------------------------------------------------------- field diffs


def first_difference(recorded: Any, replayed: Any, path: str = "$") -> tuple[str, Any, Any] | None:
    """The first differing leaf of two decoded JSON trees: (path, recorded, replayed)
    (:data:`~pipeline.jsontree.ABSENT` on the side where it does not exist)."""
    return next(differences(recorded, replayed, path, exact=True), None)


NONE_TEXT: Final = "<none>"


def value_text(value: Any) -> str:
    """A value as compact JSON, cut to ``VALUE_CHARS``."""
    text = "<absent>" if value is ABSENT else msgspec.json.encode(value).decode()
    return clipped(text, VALUE_CHARS)


def _payload_text(payload: bytes) -> str:
    return clipped(payload.decode("utf-8", errors="replace"), VALUE_CHARS)


# --------------------------------------------------------------------- comparator


class Comparator:
    """A sink comparing what a replay emits with a recording, topic by topic, tick by tick.

    ``compared``: the topics whose messages must match. The session lasts up to
    ``last_tick`` when it is given (then only the compared topics are read), else up to the
    last message read: the world's states are then read too, since
    a recording keeps the session's last one (:mod:`~recorder.world_sampling`). A compared
    ``/world/state`` is sampled as the recording says it was (a state it has at a tick is
    always compared: the session's last). The recorded inputs of the current tick are
    available through :meth:`inputs_at`.
    """

    def __init__(
        self,
        recording: Recording,
        *,
        compared: Iterable[Topic],
        context: int = CONTEXT_MESSAGES,
        last_tick: int | None = None,
    ) -> None:
        self.recording = recording
        self.topics = tuple(t for t in Topic if t in frozenset(compared))
        self._last_tick = last_tick
        read = set(self.topics)
        if last_tick is None:  # the session ends with the last world state read
            read.add(Topic.WORLD_STATE)
        self._stream: Iterator[RecordedMessage] = recording.iter_messages(
            t for t in Topic if t in read
        )
        self._sampling = (
            recorded_sampling(recording.meta.oimi, source=recording.path)
            if Topic.WORLD_STATE in self.topics
            else None
        )
        self._ahead: RecordedMessage | None = None
        self._index = 0
        self._exhausted = False
        self._buffers: dict[Topic, deque[tuple[int, RecordedMessage]]] = {
            t: deque() for t in self.topics
        }
        self._recent: deque[tuple[str, int, bytes]] = deque(maxlen=context)
        self._held = 0
        """Recorded messages buffered and not matched yet."""
        self.counts: dict[str, int] = {t.value: 0 for t in self.topics}
        self._fetch()

    # ------------------------------------------------------------------ the stream

    def _fetch(self) -> None:
        try:
            self._ahead = next(self._stream)
            self._index += 1
        except StopIteration:
            self._ahead = None
            self._exhausted = True

    def pull_through(self, tick: int) -> bool:
        """Buffer the recorded messages up to ``tick``; False once the session has ended
        before ``tick``. A damaged file stops the
        replay here with a ``RecordingError`` saying how far it matched."""
        lasted = False
        while self._ahead is not None and self._ahead.tick <= tick:
            message = self._ahead
            lasted = lasted or message.tick == tick
            buffer = self._buffers.get(message.topic)
            if buffer is not None:
                buffer.append((self._index, message))
                self._held += 1
            self._fetch()
        if self._exhausted and self.recording.recovery is not None:
            raise RecordingError(
                f"{self.recording.recovery}; the replay matched every message before tick"
                f" {tick}, where the readable part ends",
                source=self.recording.path,
            )
        if self._last_tick is not None:
            return tick <= self._last_tick
        return lasted or self._ahead is not None

    @property
    def buffered(self) -> int:
        """Recorded messages held, waiting for the replay (at most about one tick's)."""
        return self._held

    def inputs_at(self, topic: Topic, tick: int) -> list[Event]:
        """The recorded messages of ``topic`` at ``tick``, decoded (left for comparison)."""
        buffer = self._buffers[topic]
        return [m.decoded() for _, m in buffer if m.tick == tick] if buffer else []

    # -------------------------------------------------------------------- the sink

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        buffer = self._buffers.get(topic)
        if buffer is None:
            return
        recorded_here = bool(buffer) and buffer[0][1].tick == message.tick
        if (
            topic is Topic.WORLD_STATE
            and not self._sampling.keep(time_ns, message)  # type: ignore[union-attr]
            and not recorded_here
        ):
            return  # not kept, and not the session's last, which the recording keeps too
        payload = encode(message)
        if not recorded_here:
            self._diverge(
                DivergenceKind.EXTRA,
                topic,
                message.tick,
                time_ns,
                "$",
                NONE_TEXT,
                _payload_text(payload),
            )
        recorded = buffer[0][1]
        if payload != recorded.payload_bytes:
            path, old, new = first_difference(
                msgspec.json.decode(recorded.payload_bytes), msgspec.json.decode(payload)
            ) or ("$", ABSENT, ABSENT)
            self._diverge(
                DivergenceKind.CHANGED,
                topic,
                message.tick,
                time_ns,
                path,
                value_text(old),
                value_text(new),
            )
        if time_ns != recorded.time_ns:
            self._diverge(
                DivergenceKind.CHANGED,
                topic,
                message.tick,
                time_ns,
                "<log time ns>",
                str(recorded.time_ns),
                str(time_ns),
            )
        buffer.popleft()
        self._held -= 1
        self.counts[topic.value] += 1
        self._recent.append((topic.value, time_ns, payload))

    def finish_tick(self, tick: int) -> None:
        """Every recorded message up to ``tick`` must have been matched by now."""
        if not self._held:
            return
        left = [b[0] for b in self._buffers.values() if b and b[0][1].tick <= tick]
        if left:
            _, message = min(left, key=lambda entry: entry[0])
            self._diverge(
                DivergenceKind.MISSING,
                message.topic,
                message.tick,
                message.time_ns,
                "$",
                _payload_text(message.payload_bytes),
                NONE_TEXT,
            )

    def _diverge(
        self,
        kind: DivergenceKind,
        topic: Topic,
        tick: int,
        time_ns: int,
        path: str,
        recorded: str,
        replayed: str,
    ) -> None:
        before = tuple(
            Seen(
                topic=t,
                tick=_tick_of(payload),
                time_ms=ns // NS_PER_MS,
                payload=_payload_text(payload),
            )
            for t, ns, payload in self._recent
        )
        raise Diverged(
            Divergence(
                kind=kind,
                topic=topic.value,
                tick=tick,
                time_ms=time_ns // NS_PER_MS,
                path=path,
                recorded=recorded,
                replayed=replayed,
                before=before,
            )
        )


class _Stamp(msgspec.Struct):
    tick: int


_stamp: Final = msgspec.json.Decoder(_Stamp)


def _tick_of(payload: bytes) -> int:
    return _stamp.decode(payload).tick


def compare_ticks(
    comparator: Comparator,
    step: Callable[[int], None],
    *,
    mode: str,
    notes: Iterable[str] = (),
    watch: Watch | None = None,
    total: int | None = None,
) -> Comparison:
    """Run ``step(tick)`` from tick 0 for as long as the recording lasts, the comparator
    receiving what it emits; stop at the first divergence. A user's code that holds a
    tick is stopped by the watchdog, as it was when the session ran. ``watch(tick,
    total)`` hears the progress every :data:`WATCH_TICKS` ticks and at the end, when the
    session's ``total`` ticks are known."""
    tick = 0
    divergence = None
    watch = watch if total else None
    try:
        with watching() as watchdog:
            while comparator.pull_through(tick):
                step(tick)
                watchdog.feed()
                comparator.finish_tick(tick)
                tick += 1
                if watch is not None and not tick % WATCH_TICKS:
                    watch(min(tick, total), total)  # type: ignore[arg-type]
    except Diverged as stop:
        divergence = stop.divergence
        tick += 1
    if watch is not None:
        watch(min(tick, total), total)  # type: ignore[arg-type]
    return Comparison(
        mode=mode,
        recording=comparator.recording.path,
        ticks=tick,
        compared=dict(comparator.counts),
        divergence=divergence,
        notes=tuple(notes),
    )


# ------------------------------------------------------------------------ report


def format_report(comparison: Comparison) -> str:
    """The human-readable outcome: counts when identical, the divergence otherwise."""
    lines = [f"{comparison.mode} replay of {comparison.recording}: {comparison.ticks} ticks"]
    lines += [f"note: {note}" for note in comparison.notes]
    d = comparison.divergence
    if d is None:
        total = sum(comparison.compared.values())
        lines.append(f"identical: {total} messages compared")
        width = max((len(t) for t in comparison.compared), default=0)
        lines += [f"  {t:<{width}}  {n}" for t, n in comparison.compared.items()]
        return "\n".join(lines)
    lines.append(
        f"DIVERGENCE ({d.kind}) on {d.topic} at tick {d.tick} (t = {d.time_ms / 1000:.3f} s)"
    )
    lines.append(f"  field:    {d.path}")
    lines.append(f"  recorded: {d.recorded}")
    lines.append(f"  replayed: {d.replayed}")
    if d.before:
        lines.append("  before it (matched):")
        lines += [f"    tick {s.tick} {s.topic}: {s.payload}" for s in d.before]
    total = sum(comparison.compared.values())
    lines.append(f"{total} messages matched before the divergence")
    return "\n".join(lines)
