"""Batch specs and options expand into tasks with stable names; bad input is named."""

from __future__ import annotations

from pathlib import Path

import pytest
from batch_scenarios import write_scenario
from oimi.analysis.metrics import run_name
from oimi.recorder.metadata import RecordingMetadata
from oimi.recorder.world_sampling import DEFAULT_WORLD_EVERY_N_TICKS
from oimi.scenarios.errors import ScenarioError

from oimi.batch.spec import (
    SpecError,
    check_unique,
    expand,
    expand_spec,
    load_spec,
    parse_param,
    parse_seed_range,
    task_name,
)


def test_scenarios_times_grid_times_seeds_in_order_with_stable_names(tmp_path: Path) -> None:
    a = write_scenario(tmp_path, "alpha")
    b = write_scenario(tmp_path, "beta")
    tasks = expand(
        [a, b],
        params={"robot.max_speed_mps": ["0.3", "0.4"]},
        seeds=2,
        seed_range=None,
        out_dir=tmp_path / "out",
    )
    assert [t.name for t in tasks] == [
        "alpha-robot.max_speed_mps=0.3-s1",
        "alpha-robot.max_speed_mps=0.3-s2",
        "alpha-robot.max_speed_mps=0.4-s1",
        "alpha-robot.max_speed_mps=0.4-s2",
        "beta-robot.max_speed_mps=0.3-s1",
        "beta-robot.max_speed_mps=0.3-s2",
        "beta-robot.max_speed_mps=0.4-s1",
        "beta-robot.max_speed_mps=0.4-s2",
    ]
    assert tasks[2].overrides == (("robot.max_speed_mps", "0.4"),)
    assert tasks[0].mcap == tmp_path / "out" / "alpha-robot.max_speed_mps=0.3-s1.mcap"


def test_a_seed_range_replaces_the_scenarios_seed(tmp_path: Path) -> None:
    path = write_scenario(tmp_path, "alpha")
    tasks = expand([path], params={}, seeds=None, seed_range=range(7, 10), out_dir=tmp_path)
    assert [(t.name, t.seed) for t in tasks] == [("alpha-s7", 7), ("alpha-s8", 8), ("alpha-s9", 9)]


def test_without_seed_options_a_scenario_runs_once_with_its_own_seed(tmp_path: Path) -> None:
    tasks = expand(
        [write_scenario(tmp_path, "alpha")],
        params={},
        seeds=None,
        seed_range=None,
        out_dir=tmp_path,
    )
    assert [(t.name, t.seed) for t in tasks] == [("alpha-s1", 1)]


def test_untidy_or_long_overrides_are_named_by_a_stable_hash() -> None:
    odd = task_name(Path("a.toml"), [("name", '"a b/c"')], 1)
    assert odd == task_name(Path("a.toml"), [("name", '"a b/c"')], 1)
    assert odd.startswith("a-p") and odd.endswith("-s1") and "/" not in odd
    long = task_name(Path("a.toml"), [(f"k{i}", "1") for i in range(20)], 1)
    assert len(long) < 30


def test_a_runs_name_is_the_one_oimi_analyse_gives_its_recording() -> None:
    """Batch files and analysis rows are joined by name: the hashed ones too."""
    for combo in [
        (("robot.max_speed_mps", "0.3"),),
        (("name", '"a b/c"'),),
        tuple((f"k{i:02}", "1") for i in range(20)),
        (("z", "1"), ("a", "2")),
    ]:
        params = RecordingMetadata(variation=dict(combo)).params
        assert task_name(Path("a.toml"), combo, 4) == run_name("a", params, 4)


def test_a_bad_override_fails_before_anything_runs(tmp_path: Path) -> None:
    path = write_scenario(tmp_path, "alpha")
    with pytest.raises(ScenarioError, match=r"override 'robot\.top_speed': no field 'top_speed'"):
        expand(
            [path], params={"robot.top_speed": ["1"]}, seeds=1, seed_range=None, out_dir=tmp_path
        )
    with pytest.raises(ScenarioError, match=r"max_speed_mps \(m/s\): must be > 0"):
        expand(
            [path],
            params={"robot.max_speed_mps": ["-1"]},
            seeds=1,
            seed_range=None,
            out_dir=tmp_path,
        )


def _alpha_beta_spec(tmp_path: Path, text: str) -> Path:
    """Scenarios ``alpha.toml`` and ``beta.toml`` and a spec file ``text`` beside them."""
    write_scenario(tmp_path, "alpha")
    write_scenario(tmp_path, "beta")
    spec = tmp_path / "spec.toml"
    spec.write_text(text)
    return spec


def test_spec_file_groups_expand_with_paths_relative_to_the_spec(tmp_path: Path) -> None:
    spec = _alpha_beta_spec(
        tmp_path,
        'scenarios = ["alpha.toml"]\nseeds = 2\n[params]\n"robot.max_speed_mps" = [0.3, 0.4]\n\n'
        '[[runs]]\nscenarios = ["beta.toml"]\nseed_range = "5:6"\n',
    )
    tasks = expand_spec(load_spec(spec), source=spec, out_dir=tmp_path / "out")
    assert [t.name for t in tasks] == [
        "alpha-robot.max_speed_mps=0.3-s1",
        "alpha-robot.max_speed_mps=0.3-s2",
        "alpha-robot.max_speed_mps=0.4-s1",
        "alpha-robot.max_speed_mps=0.4-s2",
        "beta-s5",
    ]


def test_command_line_params_and_seeds_replace_the_specs(tmp_path: Path) -> None:
    write_scenario(tmp_path, "alpha")
    spec = tmp_path / "spec.toml"
    spec.write_text('scenarios = ["alpha.toml"]\nseeds = 4\n[params]\n"robot.mass_kg" = [10, 30]\n')
    tasks = expand_spec(
        load_spec(spec),
        source=spec,
        out_dir=tmp_path,
        params={"robot.mass_kg": ["25"]},
        seeds=None,
        seed_range=range(2, 3),
    )
    assert [t.name for t in tasks] == ["alpha-robot.mass_kg=25-s2"]


def test_a_spec_with_an_unknown_key_is_an_error_at_its_line(tmp_path: Path) -> None:
    spec = tmp_path / "spec.toml"
    spec.write_text('scenarios = ["alpha.toml"]\n\n[[runs]]\nscenarios = []\nseed = 3\n')
    with pytest.raises(SpecError, match=r"spec.toml:5:1: Object contains unknown field `seed`"):
        load_spec(spec)


def test_a_spec_value_that_is_a_table_is_refused(tmp_path: Path) -> None:
    write_scenario(tmp_path, "alpha")
    spec = tmp_path / "spec.toml"
    spec.write_text('scenarios = ["alpha.toml"]\n[params]\n"robot" = [{ x_m = 1.0 }]\n')
    with pytest.raises(SpecError, match="must be a number, text, boolean or list"):
        expand_spec(load_spec(spec), source=spec, out_dir=tmp_path)


def test_two_scenario_files_with_one_stem_are_refused(tmp_path: Path) -> None:
    (tmp_path / "x").mkdir()
    first = write_scenario(tmp_path, "alpha")
    second = write_scenario(tmp_path / "x", "alpha")
    tasks = expand([first, second], params={}, seeds=1, seed_range=None, out_dir=tmp_path)
    with pytest.raises(SpecError, match="would both be named 'alpha-s1'"):
        check_unique(tasks)


@pytest.mark.parametrize(
    ("text", "message"),
    [("3", "expected A:B"), ("5:5", "A < B"), ("a:b", "expected A:B")],
)
def test_bad_seed_ranges_are_named(text: str, message: str) -> None:
    with pytest.raises(SpecError, match=message):
        parse_seed_range(text)


def test_params_split_at_the_first_equals_sign() -> None:
    assert parse_param("name= a=b ") == ("name", "a=b")
    with pytest.raises(SpecError, match="expected KEY=VALUE"):
        parse_param("robot.max_speed_mps")


def test_each_group_of_a_spec_may_set_its_world_sampling(tmp_path: Path) -> None:
    spec = _alpha_beta_spec(
        tmp_path,
        'scenarios = ["alpha.toml"]\nworld_every_n_ticks = 5\n\n'
        '[[runs]]\nscenarios = ["beta.toml"]\nworld_every_n_ticks = 1\n\n'
        '[[runs]]\nscenarios = ["beta.toml"]\nseed_range = "7:8"\n',
    )
    tasks = expand_spec(load_spec(spec), source=spec, out_dir=tmp_path)
    assert [(t.name, t.world_every_n_ticks) for t in tasks] == [
        ("alpha-s1", 5),
        ("beta-s1", 1),
        ("beta-s7", DEFAULT_WORLD_EVERY_N_TICKS),
    ]
    given = expand_spec(load_spec(spec), source=spec, out_dir=tmp_path, world_every_n_ticks=3)
    assert {t.world_every_n_ticks for t in given} == {3}, "--world-every replaces them all"


def test_a_spec_sampling_below_one_tick_is_an_error_at_its_line(tmp_path: Path) -> None:
    spec = tmp_path / "spec.toml"
    spec.write_text('scenarios = ["alpha.toml"]\n\n[[runs]]\nworld_every_n_ticks = 0\n')
    with pytest.raises(SpecError, match=r"spec.toml:4:\d+: Expected `int` >= 1"):
        load_spec(spec)
