from __future__ import annotations

from pathlib import Path

import matplotlib.image
import polars as pl

from analysis.dataset import build_dataset
from analysis.load import load_session
from analysis.metrics import session_metrics
from analysis.plots import PLOTS
from analysis.report import write_session_report
from oimi.cli import main


def test_report_writes_readable_plots_tables_and_html(too_close_mcap: Path, tmp_path: Path) -> None:
    data = load_session(too_close_mcap)
    index = write_session_report(data, session_metrics(data), tmp_path)
    for name in PLOTS:
        image = matplotlib.image.imread(tmp_path / "plots" / f"{name}.png")
        assert image.shape[0] > 200 and image.shape[1] > 200
        assert image.std() > 0.01, f"{name}.png is blank"
        assert f'src="plots/{name}.png"' in index.read_text()
    proximity = pl.read_parquet(tmp_path / "tables" / "proximity.parquet")
    assert proximity["human"].to_list() == ["child"]
    assert "duration_ms" in pl.read_csv(tmp_path / "tables" / "activities.csv").columns


def test_a_folder_of_sessions_gives_one_comparison_table(recordings_dir: Path) -> None:
    dataset = build_dataset([recordings_dir])
    assert dataset.sessions == [
        "child too close-seed3",
        "joystick takeover-seed0",
        "walk at robot-seed0",
    ]
    comparison = dataset.comparison
    assert (
        comparison.filter(pl.col("session_id") == "joystick takeover-seed0")["interventions"].item()
        == 2
    )
    proximity = dataset.scan("proximity").filter(pl.col("human") == "child").collect()
    assert sorted(proximity["session_id"]) == ["child too close-seed3", "walk at robot-seed0"]


def test_dataset_written_to_a_folder_is_scanned_lazily(
    recordings_dir: Path, tmp_path: Path
) -> None:
    dataset = build_dataset([recordings_dir], folder=tmp_path)
    ticks = (
        dataset.scan("/world/state")
        .group_by("session_id")
        .agg(pl.len().alias("ticks"))
        .sort("session_id")
        .collect()
    )
    assert ticks["ticks"].to_list() == [1000, 1000, 500]


def test_cli_prints_one_session_and_writes_its_report(
    walk_mcap: Path, tmp_path: Path, capsys
) -> None:
    assert main(["analyse", str(walk_mcap), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "| min_distance_m" in out
    assert "proximity" in out
    assert (tmp_path / "index.html").exists()
    assert (tmp_path / "plots" / "distance.png").exists()


def test_cli_compares_a_folder_of_sessions(recordings_dir: Path, tmp_path: Path, capsys) -> None:
    assert main(["analyse", str(recordings_dir), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "joystick takeover-seed0" in out and "walk at robot-seed0" in out
    assert pl.read_csv(tmp_path / "comparison.csv").height == 3
    assert (tmp_path / "sessions" / "walk_at_robot-seed0" / "index.html").exists()
    assert 'href="sessions/walk_at_robot-seed0/index.html"' in (tmp_path / "index.html").read_text()


def test_cli_warns_about_a_truncated_file(too_close_mcap: Path, tmp_path: Path, capsys) -> None:
    cut = tmp_path / "cut.mcap"
    whole = too_close_mcap.read_bytes()
    cut.write_bytes(whole[: len(whole) * 6 // 10])  # past the first chunk: something to analyse
    assert main(["analyse", str(cut)]) == 0
    assert f"warning: {cut}: damaged at byte " in capsys.readouterr().err


def test_cli_names_a_missing_path(tmp_path: Path, capsys) -> None:
    assert main(["analyse", str(tmp_path / "nothing.mcap")]) == 2
    assert "nothing.mcap: no such file or folder" in capsys.readouterr().err
