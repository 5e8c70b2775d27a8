"""The shipped Foxglove layout: every panel placed, every message path a real field of a
recorded topic's schema (so the plots and timeline are not empty), the README links it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from oimi.pipeline.events import Topic
from oimi.recorder.topics import FoxgloveTopic, foxglove_schema, schema_data

ROOT = Path(__file__).resolve().parents[2]
LAYOUT = json.loads((ROOT / "docs" / "foxglove-layout.json").read_text())
SCHEMAS = {
    **{t.value: json.loads(schema_data(t)) for t in Topic},
    **{f.value: json.loads(foxglove_schema(f)[1]) for f in FoxgloveTopic},
}


def leaves(node: object) -> list[str]:
    if isinstance(node, str):
        return [node]
    return [*leaves(node["first"]), *leaves(node["second"])]


def message_paths() -> list[str]:
    return [
        path["value"]
        for config in LAYOUT["configById"].values()
        for path in config.get("paths", [])
    ]


def step(node: dict, name: str, path: str) -> dict:
    """The schema of field ``name`` of an object schema (through arrays and optionals)."""
    while "properties" not in node:
        options = node.get("anyOf", [])
        nested = [o for o in options if "properties" in o or "items" in o]
        if "items" in node:
            node = node["items"]
        elif nested:
            node = nested[0]
        else:
            raise AssertionError(f"{path}: no field {name!r} here")
    assert name in node["properties"], f"{path}: no field {name!r}"
    return node["properties"][name]


def test_every_panel_is_placed_and_every_placed_panel_is_configured() -> None:
    assert sorted(leaves(LAYOUT["layout"])) == sorted(LAYOUT["configById"])
    kinds = {panel.split("!")[0] for panel in LAYOUT["configById"]}
    assert {"3D", "Plot", "StateTransitions", "Log"} <= kinds


@pytest.mark.parametrize("path", message_paths())
def test_each_message_path_names_a_recorded_field(path: str) -> None:
    topic, _, fields = path.partition(".")
    assert topic in SCHEMAS, f"{path}: {topic} is not a recorded topic"
    node = SCHEMAS[topic]
    for part in fields.split("."):
        name = re.sub(r"\[[^\]]*\]|\{[^}]*\}", "", part)
        node = step(node, name, path)
        for key in re.findall(r"\{(\w+)==", part):  # a filter reads a field of the items
            step(node, key, path)


def test_the_3d_panel_shows_the_scene_and_the_log_panel_the_log() -> None:
    configs = LAYOUT["configById"]
    scene = next(c for k, c in configs.items() if k.startswith("3D!"))
    assert scene["topics"]["/foxglove/scene"]["visible"] is True
    assert scene["topics"]["/foxglove/arena"]["visible"] is True
    log = next(c for k, c in configs.items() if k.startswith("Log!"))
    assert log["topicToRender"] == FoxgloveTopic.LOG.value


def test_the_readme_and_the_foxglove_doc_link_the_layout() -> None:
    assert "docs/foxglove-layout.json" in (ROOT / "README.md").read_text()
    assert "(foxglove-layout.json)" in (ROOT / "docs" / "foxglove.md").read_text()
