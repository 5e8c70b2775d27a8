"""Argument types the commands share (argparse says the error with the option's name)."""

from __future__ import annotations

import argparse

from oimi.recorder.world_sampling import DEFAULT_WORLD_EVERY_N_TICKS


def positive_int(text: str) -> int:
    """An integer of at least 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def add_world_every_argument(parser: argparse.ArgumentParser, *, spec_files: bool = False) -> None:
    """``--world-every N``: how often a recording keeps ``/world/state`` (``args.world_every``;
    with ``spec_files``, None when not given: a batch spec's groups then say)."""
    default = f"default {DEFAULT_WORLD_EVERY_N_TICKS}; 1: every tick"
    if spec_files:
        default = f"a spec file's world_every_n_ticks, else {default}"
    parser.add_argument(
        "--world-every",
        type=positive_int,
        default=None if spec_files else DEFAULT_WORLD_EVERY_N_TICKS,
        metavar="N",
        help=f"record /world/state every N ticks, and at every contact ({default})",
    )
