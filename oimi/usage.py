"""What ``oimi --help`` and ``oimi COMMAND --help`` tell a user: a line, a paragraph, examples."""

from __future__ import annotations

import textwrap
from typing import Final, NamedTuple

DESCRIPTION: Final = (
    "oimi: scripted play sessions for social assistive robots. Run scenarios in simulation,\n"
    "serve live sessions to an operator, and replay, view and analyse their recordings."
)
EPILOG: Final = (
    "examples:\n"
    "  oimi demo                                   # a session end to end, then how to watch it\n"
    "  oimi run scenarios/library/greeting.toml    # run and record one scenario\n"
    "  oimi info out/greeting.mcap                 # what a recording holds\n"
    "  oimi COMMAND --help                         # one command's options\n"
    "\nexit status: 0 ok; 1 an expectation or comparison failed (view: the viewer did);\n"
    "2 bad input, or what this machine cannot do as given (no display, a port in use)."
)


class Usage(NamedTuple):
    summary: str
    """One line, shown in ``oimi --help``."""
    details: str
    """A short paragraph under the line in ``oimi COMMAND --help`` (may be empty)."""
    examples: tuple[str, ...]


COMMANDS: Final[dict[str, Usage]] = {
    "compile": Usage(
        "compile a script written in the DSL to Script JSON",
        "Prints the JSON, or writes it to -o OUT.json. Nothing is written when the script has"
        " an error; the error names FILE:LINE:COL.",
        ("oimi compile scenarios/library/activities/example_act.txt -o out/example_act.json",),
    ),
    "check": Usage(
        "check scripts, scenarios and rule conditions without running them",
        "Prints 'FILE: ok' for each good file and each problem as FILE:LINE:COL: message."
        " Exits 2 when any file has a problem.",
        (
            "oimi check scenarios/library/*.toml",
            "oimi check --condition '! {TRUE}'",
        ),
    ),
    "run": Usage(
        "run a scenario in simulation and record it",
        "Runs faster than real time with a progress bar, records MCAP (and Rerun with --rrd),"
        " then prints a summary and each expectation's verdict. Exits 1 when one fails.",
        (
            "oimi run scenarios/library/greeting.toml -o out/greeting.mcap",
            "oimi run scenarios/library/greeting.toml --json > summary.json",
        ),
    ),
    "demo": Usage(
        "run a library scenario end to end and say how to watch it",
        "Records MCAP and Rerun under out/ and prints the commands that open them.",
        ("oimi demo", "oimi demo --scenario busy_playroom"),
    ),
    "replay": Usage(
        "replay a recording and check that it behaves the same",
        "redrive feeds the recorded inputs to the robot's mind and compares its outputs;"
        " rerun runs the recorded scenario again. Exits 1 at the first difference.",
        (
            "oimi replay out/greeting.mcap",
            "oimi replay out/greeting.mcap --mode rerun --json",
        ),
    ),
    "view": Usage(
        "open a recording in the Rerun viewer",
        "An MCAP recording is converted first. --save writes a Rerun file without opening a"
        " viewer; --web serves the viewer to a browser (without a display, use either).",
        ("oimi view out/greeting.rrd", "oimi view out/greeting.mcap --save out/greeting.rrd"),
    ),
    "analyse": Usage(
        "tables and plots of recorded sessions",
        "One recording: its tables. Several: one comparison table. --out DIR also writes the"
        " tables, plots and an HTML report.",
        ("oimi analyse out/greeting.mcap", "oimi analyse out/batch --out out/report"),
    ),
    "serve": Usage(
        "serve a live session driven by an operator",
        "The scenario's room and people, paced to the clock; the operator uses the web console"
        " or the App Interface. Runs until Ctrl-C. Everything is recorded for replay.",
        (
            "oimi serve scenarios/library/greeting.toml --child C07 --therapist 'A. Rossi'",
            "oimi serve scenarios/library/greeting.toml --foxglove",
        ),
    ),
    "batch": Usage(
        "run many scenarios, parameters and seeds, and tabulate the results",
        "Writes one recording per run, a results table, JUnit XML and a summary under --out.",
        ("oimi batch scenarios/library/*.toml --seeds 20 --out out/batch",),
    ),
    "bench": Usage(
        "measure performance",
        "Each case beside a floor that does the same work minus the part measured.",
        ("oimi bench --quick",),
    ),
    "bridge": Usage(
        "drive a ROS 2 robot: the session as a ROS 2 participant",
        "See docs/ros2.md for the topics and the network settings.",
        ("oimi bridge scenarios/library/greeting.toml",),
    ),
    "sim": Usage(
        "simulate the scenario's robot as a ROS 2 robot",
        "See docs/ros2.md.",
        ("oimi sim --ros2 scenarios/library/greeting.toml",),
    ),
    "export": Usage(
        "export a recording for other tools (a rosbag2 folder)",
        "",
        ("oimi export --ros2 out/greeting.mcap out/greeting-bag",),
    ),
    "info": Usage(
        "what a recording holds",
        "Scenario, seed, duration, session fields, topics with message counts, attachments"
        " and whether the file is complete or damaged.",
        ("oimi info out/greeting.mcap", "oimi info out/greeting.mcap --json"),
    ),
    "completion": Usage(
        "print a shell completion script",
        "Load it in your shell to complete commands and options with Tab.",
        (
            'eval "$(oimi completion bash)"            # in ~/.bashrc',
            'eval "$(oimi completion zsh)"             # in ~/.zshrc',
            "oimi completion fish > ~/.config/fish/completions/oimi.fish",
        ),
    ),
}


def description(name: str) -> str:
    """The line, capitalised, and the paragraph wrapped for a terminal."""
    text = COMMANDS[name]
    line = f"{text.summary[:1].upper()}{text.summary[1:]}."
    return "\n\n".join([line, textwrap.fill(text.details, width=88)] if text.details else [line])


def epilog(name: str) -> str:
    """The examples shown under ``oimi NAME --help``."""
    usage = COMMANDS.get(name)
    if usage is None or not usage.examples:
        return ""
    title = "example:" if len(usage.examples) == 1 else "examples:"
    return "\n".join([title, *(f"  {line}" for line in usage.examples)])


def version() -> str:
    """The installed distribution's version (``0+unknown`` when run from a bare checkout)."""
    from importlib import metadata

    try:
        return metadata.version("oimi")
    except metadata.PackageNotFoundError:
        return "0+unknown"
