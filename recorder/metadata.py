"""A recording's metadata: its MCAP metadata records as one typed Struct.

MCAP metadata is a list of named records of string keys and string values. Every
record oimi writes is a field of :class:`RecordingMetadata` and every key a field of
its record's Struct; :meth:`RecordingMetadata.records` encodes them (only what was
set, records in a fixed order) and :meth:`RecordingMetadata.from_records` decodes
them, so no other module spells a record's or a key's name. Values stay the strings
the file holds (a damaged byte must not make the whole metadata unreadable); typed
readings such as :attr:`ScenarioRecord.seed_number` say ``None`` when a value does not
read. Records oimi does not know are kept in ``other``.
"""

from __future__ import annotations

from typing import Final

import msgspec
from oimi.recorder.errors import RecordingError


class _Record(msgspec.Struct, frozen=True, kw_only=True, omit_defaults=True):
    """A metadata record: keys that were written are strings, the others ``None``."""


class OimiRecord(_Record):
    """``oimi``: the writer, always written first (the sink adds ``format_version``)."""

    version: str | None = None
    """oimi's version."""
    format_version: str | None = None
    """The recording format version (``pipeline.events.FORMAT_VERSION``)."""
    world_every_n_ticks: str | None = None
    """Format 4: ``/world/state`` kept every this many ticks (``recorder.world_sampling``)."""
    rule_registry: str | None = None
    function_registry: str | None = None
    recording_id: str | None = None

    @property
    def world_every(self) -> int | None:
        """``world_every_n_ticks`` as a number (1 when not written: every tick, before
        format 4), or None when it does not read as a positive integer."""
        if self.world_every_n_ticks is None:
            return 1
        every = _integer(self.world_every_n_ticks)
        return every if every is not None and every >= 1 else None


class ScenarioRecord(_Record):
    """``scenario``: the scenario run (its file is attached as ``scenario/FILE``)."""

    name: str | None = None
    file: str | None = None
    seed: str | None = None
    tick_hz: str | None = None
    duration_s: str | None = None
    ticks: str | None = None

    @property
    def seed_number(self) -> int | None:
        """The seed, or None when it is missing or not an integer."""
        return _integer(self.seed)


class ConfigurationRecord(_Record):
    """``configuration``: the pipeline, robot and sensor settings, each as JSON text."""

    pipeline: str | None = None
    robot: str | None = None
    sensors: str | None = None


class LiveRecord(_Record):
    """``live``: the session was driven by an operator (``oimi serve``)."""

    autostart: str | None = None
    replay: str | None = None


BAG_ROLE: Final = "bag"
"""The ``ros2`` record's role of a session driven over a rosbag2's inputs."""


class Ros2Record(_Record):
    """``ros2``: the session ran at the ROS 2 edge."""

    role: str | None = None
    """``bridge`` (live, on a robot), ``sim`` (the world only) or ``bag`` (a rosbag2's
    inputs driven through a scenario's pipeline)."""
    replay: str | None = None
    domain_id: str | None = None
    interface: str | None = None


class SessionRecord(_Record):
    """``session``: a live session's identity and fields, rewritten at its end with its
    duration and tick count."""

    recording_id: str | None = None
    date: str | None = None
    child: str | None = None
    therapist: str | None = None
    notes: str | None = None
    duration_s: str | None = None
    ticks: str | None = None


class StoppedRecord(_Record):
    """``stopped``: written as a session's recording closes when the session did not run
    to its end (Ctrl-C, a scenario's behaviour that failed), saying why; none otherwise.
    Optional and written last: a reader that does not know it keeps it as ``other``."""

    reason: str | None = None


class RecordingMetadata(msgspec.Struct, frozen=True, kw_only=True, omit_defaults=True):
    """Every metadata record of a recording; ``None`` (or empty) when not written."""

    oimi: OimiRecord = OimiRecord()
    scenario: ScenarioRecord | None = None
    configuration: ConfigurationRecord | None = None
    variation: dict[str, str] = {}
    """The scenario's ``--param`` overrides, ``path -> value``."""
    extensions: dict[str, str] = {}
    """Per extension used, its module, version and digest as JSON text."""
    live: LiveRecord | None = None
    ros2: Ros2Record | None = None
    session: SessionRecord | None = None
    stopped: StoppedRecord | None = None
    other: dict[str, dict[str, str]] = {}
    """Records oimi does not know, kept as read."""

    def records(self) -> dict[str, dict[str, str]]:
        """The MCAP metadata records to write, in this Struct's field order."""
        encoded = msgspec.to_builtins(self)
        other = encoded.pop("other", {})
        return {**encoded, **other}

    @classmethod
    def from_records(
        cls, records: dict[str, dict[str, str]], *, source: str = ""
    ) -> RecordingMetadata:
        """The metadata of ``records`` as read from a file; a :class:`RecordingError` when a
        known record is not a string table."""
        known = {name: record for name, record in records.items() if name in _KNOWN}
        other = {name: record for name, record in records.items() if name not in _KNOWN}
        try:
            return msgspec.convert({**known, "other": other}, cls)
        except msgspec.ValidationError as error:
            raise RecordingError(f"metadata: {error}", source=source) from None

    @property
    def from_bag(self) -> bool:
        """Whether the session was driven over a rosbag2's inputs (it has no people)."""
        return self.ros2 is not None and self.ros2.role == BAG_ROLE

    @property
    def tick_hz(self) -> int | None:
        """The recorded tick rate, or None when none (or no number) was recorded."""
        return None if self.scenario is None else _integer(self.scenario.tick_hz)

    @property
    def params(self) -> str:
        """The run's parameter overrides as ``key=value,...`` (sorted; empty for none)."""
        return ",".join(f"{k}={v}" for k, v in sorted(self.variation.items()))


_KNOWN: Final = frozenset(
    f.name for f in msgspec.structs.fields(RecordingMetadata) if f.name != "other"
)
"""The record names that have a field (all but ``other``)."""


def _integer(text: str | None) -> int | None:
    if text is None or not text.lstrip("-").isdigit():
        return None
    return int(text)
