"""`oimi replay LIVE.mcap --mode rerun` is refused up front: a live session's operator
commands and joystick came from outside the scenario, which a rerun plays again; the
refusal says to use --mode redrive, which replays it."""

from __future__ import annotations

from pathlib import Path

from cli_process import ROOT, oimi

GREETING = ROOT / "scenarios" / "library" / "greeting.toml"


def test_rerun_of_a_live_recording_is_refused_with_a_hint(tmp_path: Path) -> None:
    live = tmp_path / "live.mcap"
    done = oimi(
        "serve", GREETING, "--no-tcp", "--no-console", "--duration-s", "0.3", "-o", live
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rerun = oimi("replay", live, "--mode", "rerun")
    assert rerun.returncode == 2, rerun.stdout + rerun.stderr
    assert "DIVERGENCE" not in rerun.stdout
    assert rerun.stderr.startswith(f"{live}: a live session's recording")
    assert "--mode redrive" in rerun.stderr
    assert oimi("replay", live).returncode == 0  # redrive, the default, replays it
