"""The port through which the pipeline emits events; the edge supplies the sinks."""

from __future__ import annotations

from typing import Final, Protocol

from oimi.pipeline.events import Event, Topic

NS_PER_MS: Final = 1_000_000
"""Nanoseconds in a millisecond: an event's ``time_ns`` is its tick's ``time_ms`` times this."""


class Sink(Protocol):
    """Receives every event the pipeline emits, in order."""

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        """Take one event; ``time_ns`` is the simulated time in nanoseconds."""


class MemorySink:
    """Keeps every event in a list: for tests and in-process consumers."""

    def __init__(self) -> None:
        self.events: list[tuple[Topic, int, Event]] = []

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        self.events.append((topic, time_ns, message))

    def on(self, topic: Topic) -> list[Event]:
        """The events recorded on one topic, in order."""
        return [m for t, _, m in self.events if t == topic]


class FanOut:
    """Hands each event to several sinks in turn."""

    def __init__(self, *sinks: Sink) -> None:
        self.sinks = list(sinks)

    def add(self, sink: Sink) -> None:
        """Hand every later event to ``sink`` too."""
        self.sinks.append(sink)

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        for sink in self.sinks:
            sink.record(topic, time_ns, message)
