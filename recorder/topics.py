"""The MCAP channel table: our topics (in ``Topic`` order) and Foxglove's view topics."""

from __future__ import annotations

import enum
from functools import cache
from importlib import resources
from typing import Final

import msgspec
from oimi.pipeline.events import TOPIC_TYPES, Topic

SCHEMA_ENCODING: Final = "jsonschema"
MESSAGE_ENCODING: Final = "json"
METADATA_OIMI: Final = "oimi"
"""Name of the metadata record holding ``format_version`` (always written first)."""
FORMAT_VERSION_KEY: Final = "format_version"
SCENE_ATTACHMENT: Final = "oimi/scene.json"
"""Attachment holding the ``SceneGeometry`` as JSON (written when a scene is given)."""


class FoxgloveTopic(enum.StrEnum):
    """Channels written in addition to ours so Foxglove's 3D, transform and log panels work."""

    SCENE = "/foxglove/scene"
    """The robot, people and objects (every few ticks)."""
    ARENA = "/foxglove/arena"
    """The walls and the furniture, once (live: every second). A topic of its own because
    Foxglove, after a seek, shows each topic's last message before the new time: on the
    scene's topic the arena would vanish at the first seek."""
    TF = "/foxglove/tf"
    LOG = "/foxglove/log"


FOXGLOVE_SCHEMA_FILES: Final[dict[FoxgloveTopic, str]] = {
    FoxgloveTopic.SCENE: "SceneUpdate.json",
    FoxgloveTopic.ARENA: "SceneUpdate.json",
    FoxgloveTopic.TF: "FrameTransforms.json",
    FoxgloveTopic.LOG: "Log.json",
}


def schema_name(topic: Topic) -> str:
    """The schema name of one of our topics: ``oimi.<Struct name>``."""
    return f"oimi.{TOPIC_TYPES[topic].__name__}"


@cache
def schema_data(topic: Topic) -> bytes:
    """The JSON Schema of a topic's Struct, self-contained, encoded with sorted keys.

    ``msgspec.json.schema`` puts every Struct under ``$defs``; the references are
    inlined (like Foxglove's own schemas) so that viewers without ``$ref`` support
    can read it; a tagged union's ``discriminator`` (OpenAPI's, naming ``$defs``) is
    dropped, each member's tag ``enum`` says the same. Sorted keys keep the bytes stable
    from run to run.
    """
    schema = msgspec.json.schema(_described(TOPIC_TYPES[topic]))
    defs = schema.get("$defs", {})
    return msgspec.json.encode(_inline_refs(schema, defs, ()), order="sorted")


def _described(kind: type[msgspec.Struct]) -> type[msgspec.Struct]:
    """The Struct whose schema describes ``kind``'s JSON: ``kind`` itself, or for one with
    pre-encoded fields (``msgspec.Raw``, listed in its ``RAW_TYPES``) a twin of the same
    name in which each of them has the type it holds (optional, as when absent)."""
    held: dict[str, object] = getattr(kind, "RAW_TYPES", {})
    if not held:
        return kind
    fields: list[tuple[str, object] | tuple[str, object, object]] = []
    for field in msgspec.structs.fields(kind):
        if field.name in held:
            fields.append((field.name, held[field.name], None))
        elif field.required:
            fields.append((field.name, field.type))
        else:
            fields.append((field.name, field.type, field.default))
    return msgspec.defstruct(kind.__name__, fields, kw_only=True, omit_defaults=True)


def _inline_refs(node: object, defs: dict[str, object], seen: tuple[str, ...]) -> object:
    if isinstance(node, list):
        return [_inline_refs(item, defs, seen) for item in node]
    if not isinstance(node, dict):
        return node
    ref = node.get("$ref")
    if isinstance(ref, str) and ref.startswith("#/$defs/"):
        name = ref.removeprefix("#/$defs/")
        if name in seen:
            raise ValueError(f"recursive schema through {name!r} cannot be inlined")
        return _inline_refs(defs[name], defs, (*seen, name))
    return {
        k: _inline_refs(v, defs, seen)
        for k, v in node.items()
        if k not in ("$defs", "discriminator")
    }


@cache
def foxglove_schema(topic: FoxgloveTopic) -> tuple[str, bytes]:
    """``(title, JSON)`` of a Foxglove schema shipped in ``recorder/foxglove_schemas``: the
    file's JSON written compactly (the same keys in the same order)."""
    data = (
        resources.files("oimi.recorder") / "foxglove_schemas" / FOXGLOVE_SCHEMA_FILES[topic]
    ).read_bytes()
    schema = msgspec.json.decode(data)
    return schema["title"], msgspec.json.encode(schema)  # compact: written twice a file
