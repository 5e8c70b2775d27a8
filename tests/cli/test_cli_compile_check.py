"""`oimi compile` and `oimi check` through oimi.cli.main, and once through `python -m oimi`."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from oimi.pipeline.script import load_script_json
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.errors import RuleSyntaxError

from oimi.cli import main
from oimi.extension_args import EXTENSION_HINT

ROOT = Path(__file__).parents[2]
ACTIVITIES = ROOT / "scenarios" / "library" / "activities"
LISTING = ROOT / "tests" / "pipeline" / "script" / "fixtures" / "listing_4_1.json"
BAD = '[a]\n[goal:g]\n[action]\n[b##blk_inst: MV() LD("1, 2, 0, 1, 0, 0") AO()]\n'


def listing():
    return load_script_json(LISTING.read_bytes(), source="listing")


def test_compile_prints_json_equal_to_listing_4_1(capsys):
    assert main(["compile", str(ACTIVITIES / "test_act.txt")]) == 0
    out = capsys.readouterr().out
    assert load_script_json(out, source="stdout") == listing()
    assert json.loads(out)["goal0"]["act0"]["blk2"]["truejump"] == "goal0/act0/blk4"


def test_compile_writes_the_output_file(tmp_path, capsys):
    out = tmp_path / "test_act.json"
    assert main(["compile", str(ACTIVITIES / "test_act.txt"), "-o", str(out)]) == 0
    assert load_script_json(out.read_bytes(), source=str(out)) == listing()
    assert capsys.readouterr().out == ""
    assert [p.name for p in tmp_path.iterdir()] == ["test_act.json"]
    assert out.stat().st_mode & 0o044  # readable by others like any new file, not 0600


def test_compile_error_is_located_and_writes_nothing(tmp_path, capsys):
    script = tmp_path / "bad.txt"
    script.write_text(BAD, encoding="utf-8")
    out = tmp_path / "out.json"
    assert main(["compile", str(script), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{script}:4:27: goal0/act0/blk0.led[0].g: colour g must be between")
    assert "^" in err
    assert not out.exists()


def test_compile_error_leaves_an_existing_output_untouched(tmp_path):
    script = tmp_path / "bad.txt"
    script.write_text(BAD, encoding="utf-8")
    out = tmp_path / "out.json"
    out.write_text("previous", encoding="utf-8")
    assert main(["compile", str(script), "-o", str(out), "--overwrite"]) == 2
    assert out.read_text(encoding="utf-8") == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.txt", "out.json"]


def test_compile_of_a_missing_file_is_an_error(tmp_path, capsys):
    assert main(["compile", str(tmp_path / "none.txt")]) == 2
    assert "cannot read the file" in capsys.readouterr().err


def test_check_reports_every_file_and_fails_if_any_failed(tmp_path, capsys):
    bad = tmp_path / "bad.txt"
    bad.write_text(BAD, encoding="utf-8")
    binary = tmp_path / "blob.json"
    binary.write_bytes(b"\x89PNG\x00\x00")
    good = [ACTIVITIES / "test_act.txt", ACTIVITIES / "idle_activity.json"]
    assert main(["check", str(good[0]), str(bad), str(binary), str(good[1])]) == 2
    captured = capsys.readouterr()
    assert captured.out.splitlines() == [f"{good[0]}: ok", f"{good[1]}: ok"]
    errors = [line for line in captured.err.splitlines() if not line.startswith(" ")]
    assert errors[0].startswith(f"{bad}:4:27: ")
    assert errors[1].startswith(f"{binary}:1:5: not a text script")


TWO_PROBLEMS = """name = "two"
duration_s = 2.0

[world]
width_m = 4.0
height_m = 4.0

[robot]
x_m = 9.0

[[humans]]
id = "ada"
x_m = 2.0
y_m = 7.5
"""


def test_check_and_run_list_every_problem_of_a_scenario_each_placed(tmp_path, capsys):
    """A designer fixes a scenario in one pass: not one problem per attempt."""
    scenario = tmp_path / "two.toml"
    scenario.write_text(TWO_PROBLEMS, encoding="utf-8")
    expected = [
        f"{scenario}:9:1: robot.x_m (m): the robot starts at (9, 2), outside the arena"
        " (x 0.3 to 3.7 m, y 0.3 to 3.7 m, for its radius)",
        f"{scenario}:13:1: humans[0].x_m (m): human 'ada' starts at (2, 7.5), outside the arena"
        " (x 0 to 4 m, y 0 to 4 m)",
    ]
    assert main(["check", str(scenario)]) == 2
    assert [line for line in capsys.readouterr().err.splitlines() if line in expected] == expected
    assert main(["run", str(scenario), "-o", str(tmp_path / "two.mcap")]) == 2
    assert capsys.readouterr().err.splitlines() == expected
    assert not (tmp_path / "two.mcap").exists()


def test_an_unknown_extension_rule_code_says_how_to_load_its_extension(tmp_path, capsys):
    """Codes from 1000 are extensions': the warning said only 'not in the rule library'."""
    script = tmp_path / "s.txt"
    script.write_text('[s]\n[alfa:1001,cheer,"","",A,U]\n[goal:g]\n[action]\n[b##blk_terminus]\n')
    assert main(["check", str(script)]) == 0, "a warning, not a failure"
    assert capsys.readouterr().err.startswith(
        f"{script}:2:7: rule code 1001 (cheer) is not in the rule library (codes from 1000 are"
        " extensions' rules: name the extension with --extension, or in the scenario's"
        " extensions) (warning)"
    )
    assert main(["check", str(ACTIVITIES / "example_act.txt")]) == 0
    assert "extension" not in capsys.readouterr().err, "code 16 is oimi's range: no such hint"


def test_check_passes_good_files(capsys):
    files = [str(p) for p in sorted(ACTIVITIES.iterdir()) if p.suffix in (".txt", ".json")]
    assert main(["check", *files]) == 0
    assert capsys.readouterr().out.count(": ok") == len(files)


def test_check_conditions_given_on_the_command_line(capsys):
    assert main(["check", "--condition", "! {TRUE}", "--condition", "! {E: f (}"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "<condition 1>: ok\n"
    assert captured.err.startswith("<condition 2>:1:10: ")


def test_a_bad_condition_shows_its_line_with_a_caret_as_a_script_does(capsys):
    """A condition's error had only its place: a script's shows the line and a caret."""
    assert main(["check", "--condition", "{CLASS #Humen U ?c} ! {TRUE}"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "<condition 1>:1:8: unknown class '#Humen' (expected #Human, #Obstacle, #Object,"
        " #Activity); did you mean #Human?",
        "    {CLASS #Humen U ?c} ! {TRUE}",
        "           ^",
    ]
    assert main(["check", "--condition", "{CLASS #Human U ?c}\n ! {E: nearr (?c, 1)}"]) == 2
    assert capsys.readouterr().err.splitlines()[1:] == ["     ! {E: nearr (?c, 1)}", "           ^"]


def test_an_alias_no_clause_binds_is_a_warning_naming_the_nearest_bound_one(capsys):
    """A mistyped alias compiles (another rule may bind it in scope U) and is never bound
    here: its calls are false. It is a warning, with the alias the condition binds."""
    typo = "{CLASS #Human U ?child} ! {E: near (?kid, 1)}"
    assert main(["check", "--condition", typo, "--condition", "! {E: near (?child, 1)}"]) == 0
    captured = capsys.readouterr()
    assert captured.out == "<condition 1>: ok\n<condition 2>: ok\n"
    assert captured.err.splitlines() == [
        "<condition 1>:1:37: ?kid is bound by no CLASS clause of this condition: it has a value"
        " only where another rule bound it in scope U (did you mean ?child?) (warning)",
        "<condition 2>:1:13: ?child is bound by no CLASS clause of this condition: it has a"
        " value only where another rule bound it in scope U (warning)",
    ]
    bound = "{CLASS #Human U ?c}, {ATT ?c $d L F: distance (?c)} ! {E: less_than (?c>$d, 2)}"
    assert main(["check", "--condition", bound]) == 0
    assert capsys.readouterr().err == ""


def test_a_long_unbound_alias_is_quoted_cut_as_an_error_quotes_a_long_word(capsys):
    """(A fuzz example, seed 2416: a 20,000-character alias was quoted whole.)"""
    alias = "?" + "x" * 20_000
    assert main(["check", "--condition", f"! {{E: near ({alias}, 1)}}"]) == 0
    (warning,) = capsys.readouterr().err.splitlines()
    assert warning.startswith("<condition 1>:1:13: ?xxx") and "x…x" in warning
    assert len(warning) < 300 and warning.endswith("in scope U (warning)")


def test_an_unknown_function_hints_at_extensions_unless_it_is_a_near_miss(capsys):
    assert main(["check", "--condition", "! {E: pops_at_least (2)}"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == EXTENSION_HINT
    assert main(["check", "--condition", "! {E: closer_thn (1)}"]) == 2
    assert "hint:" not in capsys.readouterr().err, "a typo's suggestion is enough"


def test_a_condition_over_several_lines_is_placed_at_its_line_and_column(capsys):
    text = "{CLASS #Human U ?c}\n ! {E: nearr (?c, 1)}"
    assert main(["check", "--condition", text]) == 2
    assert capsys.readouterr().err.startswith("<condition 1>:2:8: unknown function 'nearr'")


def test_check_places_a_bad_jump_condition_in_the_script_file(tmp_path, capsys):
    condition = "! {E: no_such_function ()}"
    with pytest.raises(RuleSyntaxError) as caught:
        compile_condition(condition)
    inner = caught.value.column
    script = tmp_path / "jump.txt"
    line = f"[b##blk_jump: CND({condition}) TRJMP() FLSJMP()]"
    script.write_text(f"[a]\n[goal:g]\n[action]\n{line}\n", encoding="utf-8")
    assert main(["check", str(script)]) == 2
    start = line.index("CND(") + len("CND(") + 1
    column = start + inner - 1
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith(f"{script}:4:{column}: ")
    assert lines[1:3] == [f"    {line}", "    " + " " * (column - 1) + "^"], "the line, a caret"
    assert lines[3:] == [EXTENSION_HINT], "then, once, where such a function may come from"


def test_check_places_a_bad_json_condition_at_its_value(tmp_path, capsys):
    condition = "! {E: no_such_function ()}"
    with pytest.raises(RuleSyntaxError) as caught:
        compile_condition(condition)
    inner = caught.value.column
    text = LISTING.read_text(encoding="utf-8").replace(
        '"toparse": "! {TRUE}"', f'"toparse": "{condition}"', 1
    )
    script = tmp_path / "jump.json"
    script.write_text(text, encoding="utf-8")
    assert main(["check", str(script)]) == 2
    line_no = text[: text.index(condition)].count("\n") + 1
    column = text.index(condition) - text.rfind("\n", 0, text.index(condition))
    assert capsys.readouterr().err.startswith(f"{script}:{line_no}:{column + inner - 1}: ")


def test_check_warns_about_an_alfa_change_no_omega_restores(capsys):
    assert main(["check", str(ACTIVITIES / "example_act.txt")]) == 0, "a warning, not a failure"
    lines = capsys.readouterr().err.splitlines()
    assert lines[1] == (
        f"{ACTIVITIES / 'example_act.txt'}:5:10: the alfa adds my_rule (A) and no omega message"
        " names it: it stays in the chain after the script ends (warning)"
    ), "kick_starter, which the omega recovers, is not named"
    assert len(lines) == 2


@pytest.mark.parametrize(
    ("alfa", "omega", "warned"),
    [
        (
            "[alfa:1, r, , , R, U]",
            "",
            "the alfa removes r (R) and no omega message names it: it stays out of the chain",
        ),
        ("[alfa:1, r, , , C, U]", "", "the alfa recovers r (C)"),
        ("[alfa:1, r, , , B, U]", "", "the alfa brings back r (B)"),
        ("[alfa:1, r, , , A, U]", "[omega:1, r, , , R, L]", None),
        ("[alfa:1, r, , , D, U]", "", None),  # held for a future usage, by design
    ],
)
def test_check_names_each_alfa_change_left_after_the_script(tmp_path, capsys, alfa, omega, warned):
    script = tmp_path / "s.txt"
    script.write_text(f"[s]\n{alfa}\n{omega}\n[goal:g]\n[action]\n[b##blk_terminus]\n")
    assert main(["check", str(script)]) == 0
    err = capsys.readouterr().err
    if warned is None:
        assert err == ""
    else:
        assert err.startswith(f"{script}:2:10: {warned}")


def test_check_warns_about_rule_codes_the_library_does_not_know(capsys):
    assert main(["check", str(ACTIVITIES / "example_act.txt")]) == 0, "a warning, not a failure"
    err = capsys.readouterr().err
    assert err.startswith(f"{ACTIVITIES / 'example_act.txt'}:5:7: rule code 16 (my_rule)")
    assert err.rstrip().endswith("(warning)")


def test_check_and_run_warn_about_a_sonar_ring_too_short_for_the_supervisor(tmp_path, capsys):
    scenario = ROOT / "tests" / "analysis" / "scenarios" / "scripted_collision.toml"
    assert main(["check", "--json", str(scenario)]) == 0, "a warning, not a failure"
    captured = capsys.readouterr()
    warning = f"{scenario}:14:1: sensors.sonar_range_m (m): the sonar ring reaches 0.4 m, less"
    assert captured.err.startswith(warning)
    first = captured.err.splitlines()[0]
    assert first.endswith("the robot may touch someone it has not seen (warning)")
    (checked,) = json.loads(captured.out)["checked"]
    assert checked["ok"] and checked["warnings"][0]["line"] == 14
    assert main(["run", "-q", "--no-record", str(scenario)]) in (0, 1)
    assert capsys.readouterr().err.startswith(warning)
    served = ["serve", str(scenario), "-o", str(tmp_path / "live.mcap"), "--duration-s", "0.2"]
    assert main([*served, "--port", "0", "--http-port", "0"]) == 0
    assert capsys.readouterr().err.startswith(warning)
    assert main(["check", str(ROOT / "scenarios" / "library" / "greeting.toml")]) == 0
    assert capsys.readouterr().err == ""


def test_python_dash_m_oimi_compiles(tmp_path):
    out = tmp_path / "idle.json"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "oimi",
            "compile",
            str(ACTIVITIES / "idle_activity.txt"),
            "-o",
            str(out),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    expected = load_script_json((ACTIVITIES / "idle_activity.json").read_bytes(), source="i")
    assert load_script_json(out.read_bytes(), source=str(out)) == expected
