"""Tiny scenario files for the batch tests (2 s simulated each)."""

from __future__ import annotations

from pathlib import Path

TINY = """\
name = "{name}"
seed = 1
duration_s = 2.0

[robot]
x_m = 3.0
y_m = 2.5

[[humans]]
id = "child"
role = "child"
x_m = {child_x_m}
y_m = 2.6
behaviour = [{{ kind = "wander", speed_mps = 0.3 }}]

[[activities]]
generator = "greeting"

[[expect]]
kind = "max_speed"
at_most_mps = 0.5

[[expect]]
kind = "min_distance"
human = "child"
at_least_m = {at_least_m}
"""


def write_scenario(
    folder: Path, name: str, *, child_x_m: float = 5.0, at_least_m: float = 0.5
) -> Path:
    """A 2 s scenario: a wandering child, the greeting activity, two expectations."""
    path = folder / f"{name}.toml"
    path.write_text(TINY.format(name=name, child_x_m=child_x_m, at_least_m=at_least_m))
    return path
