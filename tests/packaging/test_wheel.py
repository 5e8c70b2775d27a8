"""The distribution as a user installs it: one import name, everything it needs inside.

The wheel is built from this checkout and installed (without its dependencies, which come
from this environment through a path file) into a fresh virtual environment; ``oimi demo``
then runs from another directory, where the repository's folders cannot be imported.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    # from a copy of the tracked files: setuptools builds in the source's build/, which
    # would leave files behind in the checkout (and reuse stale ones in the next wheel)
    source = tmp_path_factory.mktemp("source")
    tracked = (
        subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
        .stdout.decode()
        .split("\0")
    )
    for name in filter(None, tracked):
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, source / name, follow_symlinks=False)  # links stay links
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(out), str(source)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert build.returncode == 0, build.stderr
    (path,) = out.glob("oimi-*.whl")
    return path


def test_the_wheel_claims_only_the_oimi_import_name(wheel: Path) -> None:
    names = zipfile.ZipFile(wheel).namelist()
    tops = {name.split("/")[0] for name in names}
    assert {t for t in tops if not t.endswith(".dist-info")} == {"oimi"}
    for inside in (
        "oimi/pipeline/loop.py",
        "oimi/pipeline/script/dsl.lark",
        "oimi/scenarios/library/greeting.toml",
        "oimi/scenarios/library/activities/test_act.txt",
        "oimi/live/web/console.js",
        "oimi/recorder/foxglove_schemas/SceneUpdate.json",
        "oimi/ros2/msg/MapUpdate.msg",
    ):
        assert inside in names, inside
    metadata = next(n for n in names if n.endswith(".dist-info/METADATA"))
    text = zipfile.ZipFile(wheel).read(metadata).decode()
    assert "License-Expression: MIT" in text


def test_the_installed_wheel_runs_the_demo_from_another_directory(
    wheel: Path, tmp_path: Path
) -> None:
    env_dir = tmp_path / "env"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    install = subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", site, str(wheel)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert install.returncode == 0, install.stderr
    # the dependencies: this environment's packages, after the wheel's own
    Path(site, "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    work = tmp_path / "elsewhere"
    work.mkdir()
    done = subprocess.run(
        [str(python), "-m", "oimi", "demo", "--out", "out"],
        cwd=work,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert sorted(p.suffix for p in (work / "out").iterdir()) == [".mcap", ".rrd"]
    where = subprocess.run(
        [str(python), "-c", "import oimi.pipeline.loop as m; print(m.__file__)"],
        cwd=work,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert where.startswith(site), where  # the wheel's code, not the checkout's
    leaked = subprocess.run(
        [str(python), "-c", "import pipeline"], cwd=work, capture_output=True, text=True
    )
    assert leaked.returncode != 0 and "No module named 'pipeline'" in leaked.stderr
