"""The shipped Foxglove layout: every panel placed, every message path a real field of a
recorded topic's schema and the distance plot's found in a recording (so the plots and
timeline are not empty), the README links it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from oimi.pipeline.events import Topic
from oimi.recorder.reader import open_recording
from oimi.recorder.topics import FoxgloveTopic, foxglove_schema, schema_data
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session

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
        holding = [o for o in options if name in o.get("properties", {})]
        nested = [o for o in options if "properties" in o or "items" in o]
        if "items" in node:
            node = node["items"]
        elif holding or nested:  # a union: the option with the field (a register's change)
            node = (holding or nested)[0]
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


def picked(message: object, fields: str, variables: dict[str, str]) -> list[object]:
    """What a message path's fields pick out of one decoded message, as Foxglove does for
    the syntax the layout uses: fields, ``[:]`` and ``[n]``, ``{key==$variable}``."""
    nodes = [message]
    for part in fields.split("."):
        name, rest = re.fullmatch(r"(\w+)(.*)", part).groups()  # type: ignore[union-attr]
        nodes = [n[name] for n in nodes if isinstance(n, dict) and name in n]
        for op in re.findall(r"\[[^\]]*\]|\{[^}]*\}", rest):
            if op == "[:]":
                nodes = [item for n in nodes if isinstance(n, list) for item in n]
            elif op.startswith("["):
                nodes = [n[int(op[1:-1])] for n in nodes if isinstance(n, list) and n]
            else:
                key, variable = re.fullmatch(r"\{(\w+)==\$(\w+)\}", op).groups()  # type: ignore[union-attr]
                nodes = [
                    n for n in nodes if isinstance(n, dict) and n.get(key) == variables[variable]
                ]
    return nodes


def test_the_distance_plot_has_a_point_at_nearly_every_map_message_that_sees_the_person(
    tmp_path: Path,
) -> None:
    """A message path can name a real field and still find nothing: a ``/map`` delta leaves
    out the fields that repeat the pose just added (format 9), so the plot reads the pose."""
    scenario = tmp_path / "walk.toml"
    scenario.write_text(
        'name = "walk"\nseed = 0\nduration_s = 6.0\n[robot]\nx_m = 1.0\ny_m = 2.5\n'
        '[[humans]]\nid = "child"\nx_m = 4.0\ny_m = 2.5\n'
        'behaviour = [{ kind = "waypoints", waypoints = [[2.0, 2.5]], speed_mps = 0.4 }]\n'
    )
    session = Session(load_scenario(scenario))
    with recorded(session, mcap=tmp_path / "walk.mcap", rrd=None):
        session.run()
    maps = [
        json.loads(m.payload_bytes)
        for m in open_recording(tmp_path / "walk.mcap").iter_messages([Topic.MAP])
    ]
    variables = LAYOUT["globalVariables"]
    plot = LAYOUT["configById"]["Plot!distance"]
    person = variables["person1"]
    listing = [m for m in maps if picked(m, "humans[:]{id==$person1}", variables)]
    assert len(listing) > 20, f"the scenario's {person!r} is seen"
    for path in (p["value"] for p in plot["paths"] if p["value"].startswith("/map.")):
        if "$person1" in path:
            found = [m for m in listing if picked(m, path.partition(".")[2], variables)]
            assert len(found) >= 0.8 * len(listing), f"{path}: {len(found)} of {len(listing)}"
