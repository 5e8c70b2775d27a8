"""The CLI furniture: --version, user-facing --help, `oimi info`, --json summaries, completion."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from mcap.reader import make_reader
from test_cli_run import oimi

from oimi.cli import COMMANDS, build_parser
from oimi.cmd_info import extension_text
from oimi.usage import COMMANDS as USAGE

ROOT = Path(__file__).parents[2]
SCENARIO = ROOT / "scenarios" / "library" / "blink.toml"


def one_json(stdout: str) -> dict:
    """stdout holds exactly one line, a JSON object."""
    lines = stdout.splitlines()
    assert len(lines) == 1, stdout
    return json.loads(lines[0])


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """One `oimi run --json` of blink, a minute long (more than one chunk): the recording
    and the JSON summary."""
    path = tmp_path_factory.mktemp("run") / "blink.mcap"
    done = oimi("run", SCENARIO, "-o", path, "--json", "--param", "duration_s=60")
    assert done.returncode == 0, done.stderr
    return path, one_json(done.stdout)


def test_version_prints_the_distribution_version() -> None:
    done = oimi("--version")
    assert done.returncode == 0
    assert done.stdout.startswith("oimi ") and done.stdout.split()[1][0].isdigit()


def test_every_command_has_a_user_help_line_and_an_example() -> None:
    assert set(USAGE) == set(COMMANDS)
    top = " ".join(build_parser().format_help().split())
    for name in COMMANDS:
        assert USAGE[name].summary in top
        assert USAGE[name].examples, name
        text = build_parser([name])._subparsers._group_actions[0].choices[name].format_help()
        heading = re.search(r"^examples?:$", text, re.MULTILINE)
        assert heading is not None and f"oimi {name}" in text[heading.end() :], name
        assert "``" not in text and ":func:" not in text and ":class:" not in text, name


def test_run_json_is_one_summary_on_stdout_and_the_human_text_on_stderr(recorded) -> None:
    path, summary = recorded
    assert summary["command"] == "run" and summary["ok"] is True
    assert summary["summary"]["scenario"] == "blink"
    assert summary["recording"] == str(path)
    assert summary["passed"] == len(summary["verdicts"]) and summary["failed"] == 0


def test_info_shows_scenario_seed_duration_topics_and_attachments(recorded) -> None:
    path, run = recorded
    done = oimi("info", path)
    assert done.returncode == 0, done.stderr
    assert "state       complete" in done.stdout
    assert "scenario    blink (blink.toml), seed 0" in done.stdout
    assert f"{run['summary']['ticks']:,} ticks" in done.stdout
    assert "/world/state" in done.stdout and "scenario/blink.toml" in done.stdout
    assert "world state every 2 ticks, at every contact and at the last tick" in done.stdout
    info = one_json(oimi("info", path, "--json").stdout)
    assert info["world_every_n_ticks"] == 2
    assert info["complete"] is True and info["recovery"] is None
    assert info["ticks"] == run["summary"]["ticks"]
    # every second tick and the last, 2999
    assert info["topics"]["/world/state"] == run["summary"]["ticks"] // 2 + 1
    assert info["live"] is False and info["session"] is None
    assert "rules/library.py" in info["attachments"]


def test_info_shows_an_extension_as_words_not_its_json_record() -> None:
    """It printed 'peek {"module":"peek","version":"0.1","digest":"c22d..."}'."""
    record = json.dumps({"module": "peek", "version": "0.1", "digest": "c22d7481291a0390"})
    assert extension_text("peek", record) == "peek 0.1 (module peek, digest c22d7481291a0390)"
    assert extension_text("odd", "not json") == "odd not json", "an unreadable one as found"


def test_info_on_a_cut_file_says_it_is_damaged_and_how_far_it_reads(recorded, tmp_path) -> None:
    path, run = recorded
    with path.open("rb") as stream:
        chunks = make_reader(stream).get_summary().chunk_indexes  # type: ignore[union-attr]
    assert len(chunks) >= 2
    middle_of_last = chunks[-1].chunk_start_offset + chunks[-1].chunk_length // 2
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[:middle_of_last])
    done = oimi("info", cut)
    assert done.returncode == 0, done.stderr
    assert "DAMAGED or partial" in done.stdout and "(up to the damage)" in done.stdout
    info = one_json(oimi("info", cut, "--json").stdout)
    assert info["complete"] is False
    assert info["recovery"]["stopped_at_byte"] < cut.stat().st_size
    assert 0 < info["ticks"] < run["summary"]["ticks"]


def test_info_json_on_a_file_that_is_not_a_recording_exits_2_with_an_error(tmp_path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_text("hello")
    done = oimi("info", bad, "--json")
    assert done.returncode == 2
    summary = one_json(done.stdout)
    assert summary["ok"] is False and "bad.mcap" in summary["error"]
    assert "Traceback" not in done.stderr


def test_check_json_lists_each_file_and_condition(tmp_path) -> None:
    done = oimi("check", SCENARIO, "--condition", "{TRUE} ==", "--json")
    assert done.returncode == 2
    summary = one_json(done.stdout)
    assert summary["ok"] is False
    first, second = summary["checked"]
    assert first == {"file": str(SCENARIO), "ok": True, "errors": [], "warnings": []}
    assert second["ok"] is False and second["errors"][0].startswith("<condition 1>:")


def test_replay_json_reports_the_comparison(recorded) -> None:
    path, run = recorded
    done = oimi("replay", path, "--json")
    assert done.returncode == 0, done.stderr
    summary = one_json(done.stdout)
    assert summary["ok"] is True and summary["mode"] == "redrive"
    assert summary["divergence"] is None and summary["compared"]["/sensors/updates"] > 0
    assert summary["ticks"] == run["summary"]["ticks"]


def bash_complete(script: str, *words: str) -> list[str]:
    code = (
        f"{script}\nCOMP_WORDS=({' '.join(repr(w) for w in words)}); "
        f"COMP_CWORD={len(words) - 1}; _oimi; printf '%s\\n' \"${{COMPREPLY[@]}}\""
    )
    done = subprocess.run(["bash", "-c", code], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


def test_bash_completion_completes_commands_options_and_choices() -> None:
    script = oimi("completion", "bash").stdout
    assert bash_complete(script, "oimi", "re") == ["replay"]
    assert "--mode" in bash_complete(script, "oimi", "replay", "--m")
    assert bash_complete(script, "oimi", "replay", "--mode", "") == ["redrive", "rerun"]
    assert bash_complete(script, "oimi", "completion", "") == ["bash", "zsh", "fish"]
    assert "--json" in bash_complete(script, "oimi", "info", "--")


@pytest.mark.parametrize("shell", ["zsh", "fish"])
def test_zsh_and_fish_scripts_name_every_command_and_parse(shell: str, tmp_path: Path) -> None:
    script = oimi("completion", shell).stdout
    for name in COMMANDS:
        assert f"{name}" in script
    assert "redrive rerun" in script
    if shutil.which(shell) is None:
        return  # the shell is not installed: its syntax check is skipped
    path = tmp_path / f"oimi.{shell}"
    path.write_text(script)
    done = subprocess.run([shell, "-n", str(path)], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stderr
    if shell == "fish":  # fish completes a command line on request
        asked = f"source {path}; complete -C 'oimi replay --mode '; complete -C 'oimi inf'"
        done = subprocess.run(["fish", "-c", asked], capture_output=True, text=True, timeout=30)
        words = [line.split("\t")[0] for line in done.stdout.splitlines()]
        assert words == ["redrive", "rerun", "info"], done.stdout + done.stderr
