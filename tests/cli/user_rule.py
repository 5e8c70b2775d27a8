"""A scenario whose one script loads an extension's rule (code 1010) that fires when the
child touches the robot at 1.00 s (tick 50); the scenario's operator starts the script, so
that a live session runs it too."""

from __future__ import annotations

from pathlib import Path

EXTENSION = """
from oimi.pipeline.think.rules import Rule

NAME = "{name}"


class {cls}(Rule):
    rulecode = 1010
    condition_text = '! {{E: touched ("C")}}'

    def act(self, world_map, found, ctx):
{body}


def register(ext):
    ext.rule({cls})
"""

SCRIPT = """[{name}_script]
[alfa:1010, {name}, "", "", A, U]
[goal:g]
[action]
[b#one#blk_inst: MV() LD("0.3, 0.7, 1, 1, 0, 3000") AO()]
[b#end#blk_terminus]
"""

SCENARIO = """name = "{name}"
seed = 1
duration_s = 4.0
tick_hz = 50
extensions = ["{name}.py"]
[robot]
x_m = 3.0
y_m = 2.5
theta_rad = 0.0
[[humans]]
id = "child"
x_m = 3.8
y_m = 2.5
[[activities]]
script = "{name}.txt"
[[events]]
at_s = 0.0
kind = "operator"
command = {{ cmd = "get_ready" }}
[[events]]
at_s = 0.02
kind = "operator"
command = {{ cmd = "start" }}
[[events]]
at_s = 1.0
kind = "touch"
human = "child"
touchtype = "C"
duration_ms = 300
"""


def extension(name: str, body: str) -> str:
    """The extension's source: rule ``name`` (class ``name.title()``) whose body is ``body``
    (lines indented by 8 spaces)."""
    return EXTENSION.format(name=name, cls=name.title(), body=body)


def rule_scenario(folder: Path, name: str, body: str) -> Path:
    """Write the extension ``name.py``, its script and the scenario ``name.toml``."""
    (folder / f"{name}.py").write_text(extension(name, body))
    (folder / f"{name}.txt").write_text(SCRIPT.format(name=name))
    path = folder / f"{name}.toml"
    path.write_text(SCENARIO.format(name=name))
    return path
