"""``oimi info``: what a recording holds, read through ``recorder.reader``.

The scenario, seed and tick rate from the metadata; the session fields of a live
session; the true duration and tick count from the last world state; topics with
message counts; metadata records, extensions and attachments; and whether the file
is complete or damaged (and how much of it could be read).
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
from typing import Any

from oimi import jsonout
from oimi.pipeline.events import Topic
from oimi.recorder.metadata import ScenarioRecord
from oimi.recorder.reader import Recording, open_recording

SESSION_FIELDS = ("date", "child", "therapist", "notes")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", type=Path, help="session recording (.mcap)")
    jsonout.add_json_argument(parser)


def run(args: argparse.Namespace) -> int:
    info = describe(open_recording(args.recording))
    print(format_info(info))
    jsonout.emit(args, {"command": "info", "ok": True, **info})
    return 0


def describe(recording: Recording) -> dict[str, Any]:
    """Everything ``oimi info`` shows, as plain data (the ``--json`` summary)."""
    meta = recording.meta
    scenario = meta.scenario or ScenarioRecord()
    tick_hz = meta.tick_hz or 50
    last_tick = None
    for message in recording.iter_messages([Topic.WORLD_STATE], check_indexes=True):
        last_tick = message.tick
    ticks = 0 if last_tick is None else last_tick + 1
    recovery = recording.recovery
    live = meta.session
    return {
        "file": recording.path,
        "size_bytes": os.path.getsize(recording.path),
        "complete": recovery is None,
        "recovery": None
        if recovery is None
        else {
            "messages": recovery.messages,
            "stopped_at_byte": recovery.stopped_at_byte,
            "file_size": recovery.file_size,
            "reason": recovery.reason,
        },
        "recording_id": meta.oimi.recording_id or "",
        "oimi_version": meta.oimi.version or "",
        "format_version": recording.format_version,
        "scenario": scenario.name or "",
        "scenario_file": scenario.file or "",
        "seed": scenario.seed_number,
        "tick_hz": tick_hz,
        "live": meta.live is not None,
        "from_bag": meta.from_bag,
        "stopped": meta.stopped.reason if meta.stopped is not None else None,
        "session": {field: getattr(live, field) or "" for field in SESSION_FIELDS}
        if live is not None
        else None,
        "ticks": ticks,
        "duration_s": ticks / tick_hz,
        "world_every_n_ticks": meta.oimi.world_every,
        "variation": meta.variation,
        "topics": dict(recording.summary),
        "messages": sum(recording.summary.values()),
        "metadata_records": list(recording.metadata),
        "extensions": meta.extensions,
        "attachments": {name: len(data) for name, data in recording.attachments.items()},
    }


def format_info(info: dict[str, Any]) -> str:
    """The human-readable form of :func:`describe`."""
    lines = [f"file        {info['file']} ({info['size_bytes']:,} bytes)"]
    if info["complete"]:
        lines.append("state       complete")
    else:
        recovery = info["recovery"]
        lines.append(
            f"state       DAMAGED or partial: {recovery['messages']:,} messages readable, stopped"
            f" at byte {recovery['stopped_at_byte']:,} of {recovery['file_size']:,}"
        )
        lines.append(f"            because {recovery['reason']}")
    seed = "-" if info["seed"] is None else info["seed"]
    source = info["scenario_file"] or "-"
    lines.append(f"scenario    {info['scenario'] or '-'} ({source}), seed {seed}")
    live, from_bag = info["live"], info["from_bag"]
    kind = "live session" if live else "driven over a rosbag2" if from_bag else "scripted run"
    lines.append(f"recording   {info['recording_id'] or '-'} ({kind})")
    lines.append(
        f"duration    {info['duration_s']:.2f} s, {info['ticks']:,} ticks at {info['tick_hz']} Hz"
        + ("" if info["complete"] else " (up to the damage)")
    )
    if info["stopped"] is not None:
        lines.append(f"stopped     before its end: {info['stopped']}")
    every = info["world_every_n_ticks"]
    sampled = f"every {every} ticks, at every contact and at the last tick"
    lines.append(f"world state {'every tick' if every == 1 else sampled if every else '?'}")
    if info["session"] is not None:
        for field in SESSION_FIELDS:
            lines.append(f"{field:<12}{info['session'][field] or '-'}")
    for key, value in info["variation"].items():
        lines.append(f"variation   {key} = {value}")
    lines.append(f"written by  oimi {info['oimi_version'] or '?'}, format {info['format_version']}")
    extensions = ", ".join(extension_text(k, v) for k, v in info["extensions"].items())
    lines.append(f"extensions  {extensions or 'none'}")
    lines.append(f"metadata    {', '.join(info['metadata_records'])}")
    lines.append(f"topics      {len(info['topics'])} ({info['messages']:,} messages)")
    width = max((len(topic) for topic in info["topics"]), default=0)
    lines.extend(f"  {topic:<{width}}  {count:>9,}" for topic, count in info["topics"].items())
    lines.append(f"attachments {len(info['attachments'])}")
    lines.extend(f"  {name}  ({size:,} bytes)" for name, size in info["attachments"].items())
    return "\n".join(lines)


def extension_text(name: str, record: str) -> str:
    """``peek 0.1 (module peek, digest c22d7481291a0390)``: one extension of the
    ``extensions`` record, whose value is JSON text (shown as found when it is not)."""
    try:
        fields = json.loads(record)
    except ValueError:
        fields = None
    if not isinstance(fields, dict):
        return f"{name} {record}".strip()
    version = fields.get("version") or "?"
    module, digest = fields.get("module") or "?", fields.get("digest") or "?"
    return f"{name} {version} (module {module}, digest {digest})"
