from __future__ import annotations

import base64
import io
import re
from pathlib import Path

import matplotlib.image
import polars as pl
from mcap.reader import make_reader
from oimi.analysis.dataset import build_dataset
from oimi.analysis.load import load_session
from oimi.analysis.metrics import session_metrics
from oimi.analysis.plots import PLOTS, label_levels
from oimi.analysis.report import (
    group_cells,
    html_table,
    human_duration,
    label,
    readable,
    write_session_report,
)

from oimi.cli import main


def test_report_is_one_offline_file_with_its_plots_inside(
    too_close_mcap: Path, tmp_path: Path
) -> None:
    data = load_session(too_close_mcap, stream=True)
    index = write_session_report(data, session_metrics(data), tmp_path)
    text = index.read_text()
    images = re.findall(r'<img src="data:image/png;base64,([^"]+)" alt="([a-z]+)"', text)
    assert [alt for _, alt in images] == list(PLOTS)
    for encoded, alt in images:
        image = matplotlib.image.imread(io.BytesIO(base64.b64decode(encoded)), format="png")
        assert image.shape[0] > 150 and image.shape[1] > 300
        assert image.std() > 0.01, f"{alt} is blank"
    assert 'src="http' not in text and "<link" not in text  # nothing fetched from elsewhere
    assert "Glossary" in text and "min surface distance" in text
    proximity = pl.read_parquet(tmp_path / "tables" / "proximity.parquet")
    assert proximity["human"].to_list() == ["child"]
    assert "duration_ms" in pl.read_csv(tmp_path / "tables" / "activities.csv").columns


def test_values_read_like_a_person_writes_them() -> None:
    assert human_duration(72) == "1 min 12 s"
    assert human_duration(0.02) == "0.02 s"
    assert human_duration(3600 * 8 + 5) == "8 h 0 min 5 s"
    assert human_duration(120) == "2 min"
    assert human_duration(17.8) == "17.8 s"  # beside a verdict's "at 17.80 s": not "18 s"
    assert human_duration(42.0) == "42 s"
    assert human_duration(59.96) == "1 min"
    assert readable(True) == "yes" and readable(False) == "no"
    assert readable(0.123456, "max_speed_mps") == "0.12 m/s"
    assert readable(None) == "–"


def test_a_group_cell_never_runs_a_dash_into_a_minus_sign() -> None:
    """'(-0.03--0.02)' read as a typo on the comparison page."""
    groups = pl.DataFrame(
        {
            "scenario": ["a", "b"],
            "param:robot.max_speed_mps": ["0.2", "0.3"],
            "runs": [3, 3],
            "seeds": ["1, 2, 3", "1, 2, 3"],
            "min_surface_distance_m mean": [-0.025, 0.2],
            "min_surface_distance_m spread": [0.005, 0.1],
            "min_surface_distance_m min": [-0.03, 0.1],
            "min_surface_distance_m max": [-0.02, 0.4],
        }
    )
    cells = group_cells(groups)["min_surface_distance_m"].to_list()
    assert cells == ["-0.03 m ± 0.01 (-0.03 to -0.02)", "0.2 m ± 0.1 (0.1–0.4)"]


def test_goal_labels_close_in_time_go_to_separate_levels() -> None:
    assert label_levels([0, 100, 200, 5000, 5050], gap=1000) == [0, 1, 2, 0, 1]


def test_a_folder_of_sessions_gives_one_comparison_table(recordings_dir: Path) -> None:
    dataset = build_dataset([recordings_dir])
    assert dataset.sessions == ["child_too_close-s3", "joystick_takeover-s0", "walk_at_robot-s0"]
    comparison = dataset.comparison
    joystick = comparison.filter(pl.col("run") == "joystick_takeover-s0")
    assert joystick["joystick_takeovers"].item() == 2
    proximity = dataset.scan("proximity").filter(pl.col("human") == "child").collect()
    assert sorted(proximity["session_id"]) == ["child_too_close-s3", "walk_at_robot-s0"]


def test_dataset_written_to_a_folder_is_scanned_lazily(
    recordings_dir: Path, tmp_path: Path
) -> None:
    dataset = build_dataset([recordings_dir], folder=tmp_path)
    samples = (
        dataset.scan("samples")
        .filter(pl.col("id") == "robot")
        .group_by("session_id")
        .agg(pl.len().alias("samples"))
        .sort("session_id")
        .collect()
    )
    # 1000, 1000 and 500 ticks: the world's state every second tick and at the last
    assert samples["samples"].to_list() == [501, 501, 251]
    commands = dataset.scan("/operator/commands").collect()
    assert set(commands["session_id"]) == {"child_too_close-s3", "joystick_takeover-s0"}


def test_cli_prints_one_session_and_writes_its_report(
    walk_mcap: Path, tmp_path: Path, capsys
) -> None:
    assert main(["analyse", str(walk_mcap), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "| min surface distance" in out
    assert "proximity" in out
    assert "data:image/png;base64," in (tmp_path / "index.html").read_text()


def test_cli_compares_a_folder_of_sessions(recordings_dir: Path, tmp_path: Path, capsys) -> None:
    assert main(["analyse", str(recordings_dir), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "joystick_takeover-s0" in out and "walk_at_robot-s0" in out
    comparison = pl.read_csv(tmp_path / "comparison.csv")
    assert comparison.height == 3
    # verdicts checked from each recording's attached scenario, as oimi run checks them
    assert comparison.filter(pl.col("run") == "joystick_takeover-s0")["passed"].item() is True
    assert (tmp_path / "sessions" / "walk_at_robot-s0" / "index.html").exists()
    assert 'href="sessions/walk_at_robot-s0/index.html"' in (tmp_path / "index.html").read_text()


def test_cli_shows_its_progress_over_several_sessions(recordings_dir: Path, capsys) -> None:
    """A folder of a hundred one-hour sessions took minutes without a word."""
    assert main(["analyse", str(recordings_dir)]) == 0
    lines = [x for x in capsys.readouterr().err.splitlines() if x.startswith("analyse [")]
    assert len(lines) == 3, "a line per session where stderr is not a terminal"
    assert lines[-1].startswith(f"analyse [{'#' * 30}] 3/3 sessions  (")
    assert main(["analyse", str(recordings_dir), "-q"]) == 0
    assert "analyse [" not in capsys.readouterr().err


def test_cli_warns_about_a_truncated_file(too_close_mcap: Path, tmp_path: Path, capsys) -> None:
    cut = tmp_path / "cut.mcap"
    with too_close_mcap.open("rb") as stream:
        first = make_reader(stream).get_summary().chunk_indexes[0]
    end = first.chunk_start_offset + first.chunk_length  # past the first chunk: to analyse
    cut.write_bytes(too_close_mcap.read_bytes()[: end + 10])
    assert main(["analyse", str(cut)]) == 0
    assert f"warning: {cut}: damaged at byte " in capsys.readouterr().err


def test_cli_names_a_missing_path(tmp_path: Path, capsys) -> None:
    assert main(["analyse", str(tmp_path / "nothing.mcap")]) == 2
    assert "nothing.mcap: no such file or folder" in capsys.readouterr().err


def test_a_folder_with_an_unreadable_recording_is_analysed_without_it_and_exits_1(
    walk_mcap: Path, too_close_mcap: Path, tmp_path: Path, capsys
) -> None:
    """One bad file (nothing recoverable, an older format) must not stop a folder's analysis."""
    folder = tmp_path / "sessions"
    folder.mkdir()
    for source in (walk_mcap, too_close_mcap):
        (folder / source.name).write_bytes(source.read_bytes())
    (folder / "broken.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\0" * 64)
    assert main(["analyse", str(folder), "--out", str(tmp_path / "report")]) == 1
    captured = capsys.readouterr()
    assert f"error: left out {folder / 'broken.mcap'}: " in captured.err
    assert "walk_at_robot-s0" in captured.out and "child_too_close-s3" in captured.out
    assert pl.read_csv(tmp_path / "report" / "comparison.csv").height == 2
    assert main(["analyse", str(folder / "broken.mcap")]) == 2, "alone, it is an error"


def test_a_parameter_keeps_its_name_as_a_header() -> None:
    """It is what --param takes: 'param:humans.child.x' (unit cut, as for metrics) is no field."""
    assert label("param:humans.child.x_m") == "param:humans.child.x_m"
    assert label("param:robot.max_speed_mps") == "param:robot.max_speed_mps"
    assert label("min_surface_distance_m") == "min surface distance"


def test_a_time_shown_as_a_duration_is_not_shown_twice() -> None:
    """The goals table has time_ms and time: the page showed two columns headed 'time'."""
    goals = pl.DataFrame(
        {"time_ms": [17800], "time": [17800], "goal": ["hide_and_show"]},
        schema={"time_ms": pl.Int64, "time": pl.Duration("ms"), "goal": pl.String},
    )
    headers = re.findall(r"<th[^>]*>([^<]*)</th>", html_table(goals))
    assert headers == ["time", "goal"]
    durations = pl.DataFrame({"duration_ms": [5]})  # no duration column beside it: kept
    assert re.findall(r"<th[^>]*>([^<]*)</th>", html_table(durations)) == ["duration"]
