"""``oimi completion bash|zsh|fish``: a completion script generated from the CLI's own parser.

Completes the commands, each command's options, the values of options with fixed
choices, and file names elsewhere; it is generated from ``oimi.cli.build_parser`` so a
new command or option is completed without editing a script.
"""

from __future__ import annotations

import argparse
import re
from typing import NamedTuple

SHELLS = ("bash", "zsh", "fish")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("shell", choices=SHELLS, help="the shell to complete in")


def run(args: argparse.Namespace) -> int:
    from oimi.cli import build_parser

    print(script(build_parser(), args.shell), end="")
    return 0


class Option(NamedTuple):
    flags: tuple[str, ...]
    help: str
    takes_value: bool
    choices: tuple[str, ...]


class Command(NamedTuple):
    name: str
    help: str
    options: tuple[Option, ...]
    words: tuple[str, ...]
    """Fixed choices of its positional arguments (empty: complete file names)."""


def commands(parser: argparse.ArgumentParser) -> list[Command]:
    """The sub-commands of ``parser`` with their options, in the order of ``oimi --help``."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    helps = {choice.dest: choice.help or "" for choice in sub._choices_actions}
    found = []
    for name, command in sub.choices.items():
        options, words = [], []
        for action in command._actions:
            if action.option_strings:
                options.append(
                    Option(
                        tuple(action.option_strings),
                        _plain(action.help or ""),
                        action.nargs != 0,
                        tuple(str(c) for c in action.choices or ()),
                    )
                )
            elif action.choices:
                words.extend(str(c) for c in action.choices)
        found.append(Command(name, _plain(helps.get(name, "")), tuple(options), tuple(words)))
    return found


def _plain(text: str) -> str:
    """Help text on one line, without argparse's ``%(default)s`` forms."""
    return re.sub(r"\s+", " ", text.replace("%(default)s", "")).strip()


def script(parser: argparse.ArgumentParser, shell: str) -> str:
    """The completion script for ``shell``."""
    return {"bash": _bash, "zsh": _zsh, "fish": _fish}[shell](commands(parser))


def _bash(found: list[Command]) -> str:
    names = " ".join(c.name for c in found)
    lines = [
        '# oimi completion for bash; load with: eval "$(oimi completion bash)"',
        "_oimi() {",
        '    local cur="${COMP_WORDS[COMP_CWORD]}" prev="${COMP_WORDS[COMP_CWORD-1]}"',
        '    local cmd="" opts="" words="" i',
        "    for ((i = 1; i < COMP_CWORD; i++)); do",
        '        case "${COMP_WORDS[i]}" in -*) ;; *) cmd="${COMP_WORDS[i]}"; break ;; esac',
        "    done",
        '    if [[ -z "$cmd" ]]; then',
        f'        COMPREPLY=($(compgen -W "{names} --help --version" -- "$cur"))',
        "        return",
        "    fi",
        '    case "$cmd" in',
    ]
    for command in found:
        lines.append(f"        {command.name})")
        choices = [o for o in command.options if o.choices]
        if choices:
            lines.append('            case "$prev" in')
            for option in choices:
                flags = "|".join(option.flags)
                values = " ".join(option.choices)
                lines.append(
                    f'                {flags}) COMPREPLY=($(compgen -W "{values}" -- "$cur"));'
                    " return ;;"
                )
            lines.append("            esac")
        opts = " ".join(flag for option in command.options for flag in option.flags)
        lines.append(f'            opts="{opts}"; words="{" ".join(command.words)}" ;;')
    lines += [
        "    esac",
        '    if [[ "$cur" == -* ]]; then',
        '        COMPREPLY=($(compgen -W "$opts" -- "$cur"))',
        '    elif [[ -n "$words" ]]; then',
        '        COMPREPLY=($(compgen -W "$words" -- "$cur"))',
        "    else",
        '        COMPREPLY=($(compgen -f -- "$cur"))',
        "    fi",
        "}",
        "complete -o filenames -F _oimi oimi",
        "",
    ]
    return "\n".join(lines)


def _zsh_text(text: str) -> str:
    return text.replace("'", "'\\''").replace("[", "(").replace("]", ")").replace(":", "\\:")


def _zsh(found: list[Command]) -> str:
    lines = [
        "#compdef oimi",
        '# oimi completion for zsh; load with: eval "$(oimi completion zsh)" (after compinit)',
        "_oimi() {",
        "    local -a commands",
        "    commands=(",
        *(f"        '{c.name}:{_zsh_text(c.help)}'" for c in found),
        "    )",
        "    if (( CURRENT == 2 )); then",
        "        _describe 'command' commands",
        "        _arguments '--version[print the version]' '(-h --help)'{-h,--help}'[show help]'",
        "        return",
        "    fi",
        "    local cmd=$words[2]",
        "    shift words; (( CURRENT-- ))",
        "    case $cmd in",
    ]
    for command in found:
        specs = []
        for option in command.options:
            help = _zsh_text(option.help)
            value = ""
            if option.choices:
                value = f":value:({' '.join(option.choices)})"
            elif option.takes_value:
                value = ":value:_files"
            for flag in option.flags:
                specs.append(f"'{flag}[{help}]{value}'")
        rest = f"'*:value:({' '.join(command.words)})'" if command.words else "'*:file:_files'"
        specs.append(rest)
        lines.append(f"        {command.name}) _arguments {' '.join(specs)} ;;")
    lines += ["    esac", "}", "compdef _oimi oimi", ""]
    return "\n".join(lines)


def _fish_text(text: str) -> str:
    return text.replace("\\", "\\\\").replace("'", "\\'")


def _fish(found: list[Command]) -> str:
    names = " ".join(c.name for c in found)
    lines = [
        "# oimi completion for fish; save as ~/.config/fish/completions/oimi.fish",
        "complete -c oimi -f",
        "complete -c oimi -n __fish_use_subcommand -l version -d 'print the version'",
    ]
    lines += [
        f"complete -c oimi -n __fish_use_subcommand -a {c.name} -d '{_fish_text(c.help)}'"
        for c in found
    ]
    for command in found:
        when = f"-n '__fish_seen_subcommand_from {command.name}'"
        if command.words:
            lines.append(f"complete -c oimi {when} -a '{' '.join(command.words)}'")
        else:
            lines.append(f"complete -c oimi {when} -F")
        for option in command.options:
            flags = " ".join(
                f"-l {flag[2:]}" if flag.startswith("--") else f"-s {flag[1:]}"
                for flag in option.flags
            )
            value = ""
            if option.choices:
                value = f" -x -a '{' '.join(option.choices)}'"
            elif option.takes_value:
                value = " -r"
            lines.append(f"complete -c oimi {when} {flags}{value} -d '{_fish_text(option.help)}'")
    lines.append(f"# commands: {names}")
    lines.append("")
    return "\n".join(lines)
