"""Recordings are sacred: `oimi view --save` and `oimi compile -o` through `python -m oimi`
never write over the file they read (even with --overwrite), refuse an existing file unless
--overwrite, and (view) want an .rrd name and leave nothing at the target when a save fails.
Each refusal exits 2 naming the file, and every file in the folder keeps its bytes."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest
from cli_process import ROOT, oimi
from oimi.pipeline.events import Topic
from oimi.recorder.mcap_sink import McapSink
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.runner import Session
from rerun.chunk import RrdReader

SCENARIO = ROOT / "scenarios" / "library" / "caress_reward.toml"
SCRIPT = ROOT / "scenarios" / "library" / "activities" / "test_act.txt"
OLD = b"an earlier save, kept"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with a run's ``x.mcap`` and ``x.rrd`` (never changed: tests copy them)."""
    folder = tmp_path_factory.mktemp("recorded")
    done = oimi("run", "-q", SCENARIO, "-o", folder / "x.mcap", "--rrd", folder / "x.rrd")
    assert done.returncode == 0, done.stdout + done.stderr
    return folder


@pytest.fixture
def folder(recorded: Path, tmp_path: Path) -> Path:
    """A copy of the recorded folder: ``greeting.mcap``, ``run.rrd``."""
    shutil.copyfile(recorded / "x.mcap", tmp_path / "greeting.mcap")
    shutil.copyfile(recorded / "x.rrd", tmp_path / "run.rrd")
    return tmp_path


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file of ``folder`` (partial files included) and its bytes; a link as its target."""
    return {
        p.name: os.readlink(p).encode() if p.is_symlink() else p.read_bytes()
        for p in folder.rglob("*")
    }


def refused(done: subprocess.CompletedProcess[str], path: Path, *words: str) -> None:
    """Exit 2, stderr opening with ``path`` and holding ``words``, no traceback."""
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stderr.startswith(f"{path}: "), done.stderr
    assert all(word in done.stderr for word in words), done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize("overwrite", [[], ["--overwrite"]], ids=["plain", "overwrite"])
def test_saving_over_the_mcap_being_viewed_is_refused_and_it_is_untouched(
    folder: Path, overwrite: list[str]
) -> None:
    mcap = folder / "greeting.mcap"
    before = snapshot(folder)
    refused(oimi("view", mcap, "--save", mcap, *overwrite), mcap, "is the input file")
    assert snapshot(folder) == before
    assert oimi("view", mcap, "--save", folder / "ok.rrd").returncode == 0  # still readable


def test_saving_over_the_rrd_being_viewed_is_refused_by_any_name_even_with_overwrite(
    folder: Path,
) -> None:
    rrd = folder / "run.rrd"
    (folder / "link.rrd").symlink_to("run.rrd")
    os.link(rrd, folder / "hard.rrd")
    before = snapshot(folder)
    for name in (rrd, folder / "sub" / ".." / "run.rrd", folder / "link.rrd", folder / "hard.rrd"):
        done = oimi("view", rrd, "--save", name, "--overwrite")
        refused(done, name, "is the input file", "even with --overwrite")
    assert snapshot(folder) == before


@pytest.mark.parametrize("overwrite", [[], ["--overwrite"]], ids=["plain", "overwrite"])
def test_saving_over_another_mcap_is_refused_for_its_suffix(
    folder: Path, overwrite: list[str]
) -> None:
    victim = folder / "victim.mcap"
    shutil.copyfile(folder / "greeting.mcap", victim)
    before = snapshot(folder)
    done = oimi("view", folder / "greeting.mcap", "--save", victim, *overwrite)
    refused(done, victim, ".rrd suffix", "victim.rrd")
    assert snapshot(folder) == before


def test_a_new_save_needs_the_rrd_suffix(folder: Path) -> None:
    before = snapshot(folder)
    for name in ("new.mcap", "new"):
        refused(oimi("view", folder / "run.rrd", "--save", folder / name), folder / name, ".rrd")
    assert snapshot(folder) == before


def test_an_existing_rrd_is_refused_and_replaced_only_with_overwrite(folder: Path) -> None:
    out = folder / "out.rrd"
    out.write_bytes(OLD)
    before = snapshot(folder)
    done = oimi("view", folder / "greeting.mcap", "--save", out)
    refused(done, out, "exists", "--overwrite")
    assert snapshot(folder) == before
    done = oimi("view", folder / "greeting.mcap", "--save", out, "--overwrite")
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"rerun: {out}\n"
    ids = [r.recording_id for r in RrdReader(folder / "run.rrd").recordings()]
    assert [r.recording_id for r in RrdReader(out).recordings()] == ids
    assert sorted(p.name for p in folder.iterdir()) == ["greeting.mcap", "out.rrd", "run.rrd"]


def test_a_leftover_partial_file_is_refused_unless_overwrite_and_never_when_it_is_the_input(
    folder: Path,
) -> None:
    partial = folder / "out.partial.rrd"
    partial.write_bytes(OLD)
    before = snapshot(folder)
    out = folder / "out.rrd"
    refused(oimi("view", folder / "greeting.mcap", "--save", out), out, str(partial))
    assert snapshot(folder) == before
    shutil.copyfile(folder / "run.rrd", partial)  # viewing the partial file itself
    before = snapshot(folder)
    refused(oimi("view", partial, "--save", out, "--overwrite"), out, "the input file")
    assert snapshot(folder) == before
    partial.write_bytes(OLD)
    assert oimi("view", folder / "greeting.mcap", "--save", out, "--overwrite").returncode == 0
    assert not partial.exists() and out.read_bytes().startswith(b"RRF")


def undecodable_mcap(path: Path) -> Path:
    """An MCAP whose one message has a tick but is not its topic's event: a conversion
    fails after the Rerun file is opened."""
    session = Session(load_scenario(SCENARIO))
    sink = McapSink(path, metadata=session.metadata().records(), attachments=session.attachments())
    sink.add_encoded(Topic.LOG.value, 1_000_000, b'{"tick": 1, "time_ms": 1}')
    sink.close()
    return path


def test_a_failed_save_leaves_the_target_as_it_was_and_no_partial_file(folder: Path) -> None:
    bad = undecodable_mcap(folder / "bad.mcap")
    before = snapshot(folder)
    done = oimi("view", bad, "--save", folder / "new.rrd")
    assert done.returncode == 2, done.stderr
    assert "/log message 0" in done.stderr and "Traceback" not in done.stderr
    assert snapshot(folder) == before  # no cut-short new.rrd, no new.partial.rrd
    done = oimi("view", bad, "--save", folder / "run.rrd", "--overwrite")
    assert done.returncode == 2, done.stderr
    assert snapshot(folder) == before  # the run's rrd is whole


def test_compile_never_writes_over_its_script_and_refuses_an_existing_output(
    tmp_path: Path,
) -> None:
    script = tmp_path / "act.txt"
    shutil.copyfile(SCRIPT, script)
    other = tmp_path / "other.txt"
    other.write_bytes(OLD)
    (tmp_path / "link.json").symlink_to("act.txt")
    before = snapshot(tmp_path)
    for out in (script, tmp_path / "." / "act.txt", tmp_path / "link.json"):
        for overwrite in ([], ["--overwrite"]):
            refused(oimi("compile", script, "-o", out, *overwrite), out, "is the input file")
    refused(oimi("compile", script, "-o", other), other, "exists", "--overwrite")
    assert snapshot(tmp_path) == before
    bad = tmp_path / "bad.txt"
    bad.write_text('[a]\n[goal:g]\n[action]\n[b##blk_inst: LD("1, 2, 0, 1, 0, 0")]\n')
    assert oimi("compile", bad, "-o", other, "--overwrite").returncode == 2
    assert other.read_bytes() == OLD  # a failed compile replaces nothing, even when told
    done = oimi("compile", script, "-o", other, "--overwrite")
    assert done.returncode == 0, done.stderr
    assert other.read_text().startswith("{")
    assert script.read_bytes() == SCRIPT.read_bytes()


def test_help_offers_overwrite() -> None:
    for command in ("view", "compile"):
        done = oimi(command, "--help")
        assert done.returncode == 0 and "--overwrite" in done.stdout, done.stdout
