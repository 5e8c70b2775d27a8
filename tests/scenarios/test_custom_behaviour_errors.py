"""An extension's human behaviour that fails is bad input, named and placed, not a traceback:
a factory that raises stops the world being built; a ``velocity`` that raises or returns
anything but two finite numbers stops the run (``oimi run`` exits 2, the recording closed,
saying why it stopped)."""

from __future__ import annotations

from pathlib import Path

import pytest
from oimi.pipeline.messages import ActuatorOutputs
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.simulation.world import World, stream_rng

import oimi
from oimi.cli import main

EXTENSION = """NAME = "beh"


class Wobble:
    def __init__(self, options):
        self.value = options.get("value", "pair")
        if self.value == "ctor":
            raise ValueError("unknown option for Wobble")

    def velocity(self, view):
        return RETURNS[self.value]()


def boom():
    raise RuntimeError("boom")


RETURNS = {
    "pair": lambda: (0.1, 0.0),
    "teleport": lambda: (150.0, 0.0),
    "list": lambda: [0.1, 0.0],
    "float": lambda: 0.5,
    "strs": lambda: ("a", "b"),
    "nan": lambda: (float("nan"), 0.0),
    "none": lambda: None,
    "object": lambda: object(),
    "three": lambda: (1.0, 2.0, 3.0),
    "raise": boom,
}


def register(ext):
    ext.behaviour("wobble", Wobble)
"""
VELOCITY_LINE = 1 + EXTENSION.splitlines().index("    def velocity(self, view):")
CTOR_LINE = 1 + EXTENSION.splitlines().index(
    '            raise ValueError("unknown option for Wobble")'
)
BOOM_LINE = 1 + EXTENSION.splitlines().index('    raise RuntimeError("boom")')

SCENARIO = """name = "beh"
seed = 1
duration_s = 1.0
extensions = ["beh.py"]
[robot]
x_m = 3.0
y_m = 2.5
[[humans]]
id = "child"
x_m = 4.5
y_m = 2.5
behaviour = [{SEGMENT}]
"""
SEGMENT = '{{ kind = "custom", name = "wobble", options = {{ value = "{value}" }} }}'


def scenario_file(folder: Path, value: str, *, as_event: bool = False) -> Path:
    (folder / "beh.py").write_text(EXTENSION)
    segment = SEGMENT.format(value=value)
    text = SCENARIO.replace("{SEGMENT}", "" if as_event else segment)
    if as_event:
        text += (
            f'[[events]]\nat_s = 0.5\nkind = "behaviour"\nhuman = "child"\nsegment = {segment}\n'
        )
    path = folder / f"{value}.toml"
    path.write_text(text)
    return path


def world(folder: Path, value: str, *, as_event: bool = False) -> World:
    loaded = load_scenario(scenario_file(folder, value, as_event=as_event))
    rng = stream_rng(loaded.scenario.seed, "world")
    return World(loaded.scenario, rng, behaviours=loaded.toolkit.behaviours)


def step(w: World, ticks: int) -> None:
    for tick in range(ticks):
        w.step(ActuatorOutputs(), tick=tick)


@pytest.mark.parametrize(
    ("as_event", "place"),
    [(False, "12:50: humans[0].behaviour[0]"), (True, "17:47: events[0].segment")],
    ids=["timeline", "event"],
)
def test_a_factory_that_raises_is_refused_at_its_options_when_loading(
    tmp_path: Path, as_event: bool, place: str
) -> None:
    """As ``oimi check`` does: the scenario does not load (nor would the world build)."""
    with pytest.raises(ScenarioError) as caught:
        world(tmp_path, "ctor", as_event=as_event)
    assert str(caught.value) == (
        f"{tmp_path / 'ctor.toml'}:{place}.options: human 'child': behaviour 'wobble' could not"
        f" start: ValueError: unknown option for Wobble (beh.py:{CTOR_LINE})"
    )


@pytest.mark.parametrize("value", ["pair", "list"])
def test_a_pair_of_numbers_moves_the_human(tmp_path: Path, value: str) -> None:
    w = world(tmp_path, value)
    step(w, 10)
    assert w.humans[0].xy[0] > 4.5


def test_a_velocity_faster_than_the_human_walks_is_capped_at_their_max_speed(
    tmp_path: Path,
) -> None:
    """The safety supervisor assumes a person walks at most their ``max_speed_mps`` (1.0 m/s
    here, the default): a behaviour may not teleport them behind the robot at 150 m/s."""
    w = world(tmp_path, "teleport")
    step(w, 10)
    travelled = w.humans[0].xy[0] - 4.5
    assert 0.15 < travelled <= 10 * 0.02 * 1.0 + 1e-9


@pytest.mark.parametrize(
    ("value", "shown"),
    [
        ("float", "0.5"),
        ("strs", "('a', 'b')"),
        ("nan", "(nan, 0.0)"),
        ("none", "None"),
        ("object", "<object object>"),
        ("three", "(1.0, 2.0, 3.0)"),
    ],
)
def test_a_velocity_that_is_not_two_finite_numbers_stops_the_run(
    tmp_path: Path, value: str, shown: str
) -> None:
    w = world(tmp_path, value)
    with pytest.raises(ScenarioError) as caught:
        step(w, 1)
    assert str(caught.value) == (
        f"human 'child': behaviour 'wobble' returned {shown}, not a velocity pair (vx, vy)"
        f" of finite numbers (beh.py:{VELOCITY_LINE})"
    )


def test_a_velocity_that_raises_stops_the_run_where_it_raised(tmp_path: Path) -> None:
    w = world(tmp_path, "raise")
    with pytest.raises(ScenarioError) as caught:
        step(w, 1)
    assert str(caught.value) == (
        f"human 'child': behaviour 'wobble' raised RuntimeError: boom (beh.py:{BOOM_LINE})"
    )


def test_oimi_run_stops_with_exit_2_and_a_located_message_and_closes_the_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "float.mcap"
    assert main(["run", "-q", str(scenario_file(tmp_path, "float")), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.endswith(
        "human 'child': behaviour 'wobble' returned 0.5, not a velocity pair (vx, vy)"
        f" of finite numbers (beh.py:{VELOCITY_LINE})\n"
    )
    assert str(tmp_path) not in err and "Traceback" not in err
    assert not list(tmp_path.glob("*.partial.*")), "the recording was closed and named"
    recording = oimi.open_recording(out)
    assert "beh" in recording.metadata.extensions, "and it reads"
    stopped = recording.metadata.stopped
    assert stopped is not None and stopped.reason == err.removeprefix("error: ").strip()
    assert main(["info", str(out)]) == 0
    assert f"stopped     before its end: {stopped.reason}\n" in capsys.readouterr().out
