"""Where Foxglove's published JSON schemas are: ``shared/`` beside the repository (as in CI),
else the copy shipped in ``recorder/foxglove_schemas`` (identical, see the test below)."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "foxglove-schemas"
PACKAGED = ROOT / "recorder" / "foxglove_schemas"
FOXGLOVE_SCHEMAS = SHARED if SHARED.is_dir() else PACKAGED
