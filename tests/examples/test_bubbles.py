"""The bubbles example extension (examples/bubbles): loaded, refused on collisions, compiled,
run, replayed in both modes and analysed."""

from __future__ import annotations

import os
import random
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import msgspec
import pytest
from oimi.pipeline.messages import Human, WorldMap
from oimi.pipeline.operator.generator import GeneratorView
from oimi.recorder.errors import RecordingError
from oimi.replay.rebuild import _attached_extensions
from oimi.replay.redrive import redrive
from oimi.replay.rerun import rerun
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.extensions import (
    ExtensionError,
    build_toolkit,
    load_extension,
    load_extensions,
)
from oimi.scenarios.simulation.humans import Arena, BehaviourView

import oimi

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "bubbles"
PACKAGE = EXAMPLE / "bubbles"
SCENARIO = EXAMPLE / "bubbles.toml"
SONG = PACKAGE / "activities" / "bubble_song.txt"


def oimi_cli(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "oimi", *args], capture_output=True, text=True, env=env, cwd=ROOT
    )


def write_extension(folder: Path, name: str, body: str) -> Path:
    path = folder / f"{name}.py"
    path.write_text(
        "from oimi.pipeline.think.functions import evaluation\n"
        "from oimi.pipeline.think.rules import Rule\n\n" + body
    )
    return path


def test_the_extension_adds_functions_a_rule_a_generator_a_behaviour_and_activities() -> None:
    toolkit = build_toolkit([load_extension(str(PACKAGE))])
    registries = toolkit.registries
    assert {"bubble_touch", "pops_at_least"} <= set(registries.functions.names())
    assert registries.rules.codes()[1000].__name__ == "PopReward"
    assert "bubbles" in registries.catalogue().names()
    assert list(toolkit.behaviours) == ["chase_bubbles"]
    assert toolkit.activity_folders == ((PACKAGE / "activities").resolve(),)
    assert toolkit.extensions[0].version == "1.0"


def test_a_rule_code_of_a_builtin_is_refused_naming_both(tmp_path: Path) -> None:
    path = write_extension(
        tmp_path,
        "clash_code",
        "class MyReward(Rule):\n    rulecode = 3\n\ndef register(ext):\n    ext.rule(MyReward)\n",
    )
    with pytest.raises(ExtensionError, match=r"rule code 3 of MyReward .*clash_code.* TouchReward"):
        build_toolkit([load_extension(str(path))])


def test_a_function_name_of_a_builtin_or_another_extension_is_refused(tmp_path: Path) -> None:
    path = write_extension(
        tmp_path,
        "clash_fn",
        '@evaluation("pops_at_least")\ndef mine(ctx) -> bool:\n    return True\n\n'
        "def register(ext):\n    ext.function(mine)\n",
    )
    clash = load_extension(str(path))
    with pytest.raises(ExtensionError, match=r"function 'pops_at_least' of extension 'clash_fn'"):
        build_toolkit([load_extension(str(PACKAGE)), clash])
    builtin = write_extension(
        tmp_path,
        "clash_builtin",
        '@evaluation("touched")\ndef mine(ctx) -> bool:\n    return True\n\n'
        "def register(ext):\n    ext.function(mine)\n",
    )
    with pytest.raises(ExtensionError, match=r"'touched' .* collides with oimi \(built-in\)"):
        build_toolkit([load_extension(str(builtin))])


def test_two_different_extensions_with_one_module_name_are_refused_naming_both(
    tmp_path: Path,
) -> None:
    """One import name cannot hold two extensions: the second was dropped silently."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    first = write_extension(tmp_path / "a", "mine", "def register(ext):\n    pass\n")
    second = write_extension(tmp_path / "b", "mine", "def register(ext):\n    return None\n")
    with pytest.raises(ExtensionError, match=r"a/mine.py' and .*b/mine.py' both import as module"):
        load_extensions([str(first), str(second)])
    assert len(load_extensions([str(first), str(first)])) == 1, "one extension named twice"


def test_compile_needs_the_extension_for_its_functions() -> None:
    refused = oimi_cli("compile", str(SONG))
    assert refused.returncode == 2 and "unknown function 'pops_at_least'" in refused.stderr
    assert refused.stderr.rstrip().endswith(
        "--extension MODULE (a module name, a .py file or a package folder; docs/extending.md)"
    ), "a hint"
    done = oimi_cli("compile", str(SONG), "--extension", str(PACKAGE))
    assert done.returncode == 0, done.stderr
    assert msgspec.json.decode(done.stdout)["activityname"] == "bubble_song"


def test_the_generator_adapts_to_the_child_distance_and_keeps_its_state() -> None:
    generator = build_toolkit([load_extension(str(PACKAGE))]).registries.generators["bubbles"]()
    goals = []
    for rho in (0.9, 3.0):
        generator.activate({})
        child = Human(id="c", creationtime=0, positionrho=rho)
        generator.see(GeneratorView(world_map=WorldMap(humans=[child]), now_ms=0))
        goals.append(generator.generate().goals[0].goalid)
        generator.shutdown()
    assert goals == ["bubbles_near", "bubbles_far"]
    assert generator.state["scripts"] == 2


def test_chasing_bubbles_is_seeded_and_no_faster_than_the_segment_speed() -> None:
    chase_bubbles = build_toolkit([load_extension(str(PACKAGE))]).behaviours["chase_bubbles"]

    def walk(seed: int) -> list[tuple[float, float]]:
        chase, rng = chase_bubbles({"near_m": 1.0, "far_m": 1.5}), random.Random(seed)
        arena = Arena(width_m=6.0, height_m=5.0, exit_m=(0.0, 2.5))
        view = BehaviourView((4.0, 2.5), (3.0, 2.5), 0, 0.02, 0.5, arena, rng)
        return [chase.velocity(view._replace(time_ms=t * 20)) for t in range(50)]

    steps = walk(1)
    assert steps == walk(1) and steps != walk(2)
    assert all((vx * vx + vy * vy) ** 0.5 <= 0.5 + 1e-9 for vx, vy in steps)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    output = tmp_path_factory.mktemp("bubbles") / "bubbles.mcap"
    outcome = oimi.run(SCENARIO, output=output)
    assert outcome.ok, outcome.result.verdicts
    assert outcome.summary.rules_fired["pop_reward"] >= 3
    return output


def test_the_run_records_the_extension_and_the_quiescence(recording: Path) -> None:
    frames = oimi.open_recording(recording)
    info = msgspec.json.decode(frames.metadata.extensions["bubbles"])
    assert info["module"] == "bubbles" and info["version"] == "1.0"
    assert "extensions/bubbles/rules.py" in frames.attachments
    log = frames["/log"].filter(frames["/log"]["source"] == "generators")["message"].to_list()
    assert "rule 'pop_reward' set generator 'bubbles' quiescent" in log
    assert frames["/operator/state"]["button"].to_list()[-1] == "get_ready"


@pytest.mark.parametrize("mode", [redrive, rerun])
def test_the_recording_replays_clean_from_its_attached_sources(recording: Path, mode) -> None:
    comparison = mode(recording)
    assert comparison.ok, comparison


def test_replay_refuses_missing_or_changed_sources(recording: Path, tmp_path: Path) -> None:
    frames = oimi.open_recording(recording)
    changed = dict(frames.attachments)
    changed["extensions/bubbles/rules.py"] += b"\n# changed\n"
    fake = SimpleNamespace(path=str(recording), meta=frames.metadata, attachments=changed)
    with pytest.raises(RecordingError, match="not the recorded ones"):
        _attached_extensions(fake, tmp_path / "changed")
    missing = {k: v for k, v in frames.attachments.items() if not k.startswith("extensions/")}
    fake = SimpleNamespace(path=str(recording), meta=frames.metadata, attachments=missing)
    with pytest.raises(RecordingError, match="sources are not attached"):
        _attached_extensions(fake, tmp_path / "missing")


def test_the_recording_appears_in_oimi_analyse(recording: Path, tmp_path: Path) -> None:
    done = oimi_cli("analyse", str(recording), "--out", str(tmp_path / "report"))
    assert done.returncode == 0, done.stderr
    assert "pop_reward" in done.stdout


def test_a_batch_passes_extensions_to_its_workers(tmp_path: Path) -> None:
    done = oimi_cli(
        "batch", str(SCENARIO), "--out", str(tmp_path), "--extension", str(PACKAGE), "-q"
    )
    assert done.returncode == 0, done.stderr
    assert "1 passed" in done.stdout + done.stderr


def test_installed_packages_offer_extensions_through_the_entry_point_group(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from importlib import metadata

    from oimi.scenarios import extensions

    monkeypatch.syspath_prepend(str(EXAMPLE))
    point = metadata.EntryPoint(name="bubbles", value="bubbles", group="oimi.extensions")
    monkeypatch.setattr(
        extensions.metadata,
        "entry_points",
        lambda group: [point] if group == extensions.ENTRY_POINT_GROUP else [],
    )
    (found,) = extensions.installed_extensions()
    assert found.name == "bubbles" and found.origin == "bubbles"
    assert "chase_bubbles" in build_toolkit([found]).behaviours


def test_an_unknown_custom_behaviour_is_refused_naming_the_known_ones(tmp_path: Path) -> None:
    text = SCENARIO.read_text().replace('name = "chase_bubbles"', 'name = "chase_ghosts"')
    text = text.replace('extensions = ["bubbles"]', f"extensions = [{str(PACKAGE)!r}]")
    bad = tmp_path / "unknown_behaviour.toml"
    bad.write_text(text)
    with pytest.raises(ScenarioError, match=r"unknown behaviour 'chase_ghosts' \(known: chase_"):
        oimi.load_scenario(bad)


def test_an_extension_bug_is_a_named_error_not_a_traceback(tmp_path: Path) -> None:
    path = write_extension(
        tmp_path,
        "buggy",
        'class Odd(Rule):\n    rulecode = 1001\n    condition_text = "! {E: nowhere ()}"\n\n'
        "def register(ext):\n    ext.rule(Odd)\n    ext.function(len)\n",
    )
    with pytest.raises(ExtensionError, match=r"'.*buggy.py': register failed: ValueError"):
        load_extension(str(path))
    path.write_text(path.read_text().replace("    ext.function(len)\n", ""))
    with pytest.raises(ExtensionError, match=r"Odd.condition_text: .*unknown function 'nowhere'"):
        build_toolkit([load_extension(str(path))])
    scenario = tmp_path / "s.toml"
    scenario.write_text('name = "s"\nextensions = ["buggy.py"]\n')
    done = oimi_cli("check", str(scenario))
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.startswith(f"{scenario}:2:1: Odd.condition_text: ")
