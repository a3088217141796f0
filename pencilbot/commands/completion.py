"""``pencilbot completion bash|zsh|fish``: a shell completion script, made from the parser itself.

The script completes commands, each command's own options, the choices of options that have
them, and profile and style names (asked of ``pencilbot completion --names`` when you press
Tab, so your own profiles and styles are there as soon as their files are); anything else
completes file names. zsh runs the bash script through its ``bashcompinit``.
"""

from __future__ import annotations

import argparse
import shlex
from typing import Any

from pencilbot.commands.options import add_verbosity
from pencilbot.errors import PencilbotError

SHELLS = ("bash", "zsh", "fish")
#: Options whose values are names of configs, completed from the folders as they are.
NAMED = {"--profile": "profiles", "--style": "styles"}


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "completion",
        help="print a shell completion script",
        description=(
            'Print the completion script for a shell. bash: add `eval "$(pencilbot completion bash)"` '
            "to ~/.bashrc (or save it as ~/.local/share/bash-completion/completions/pencilbot); zsh: "
            '`eval "$(pencilbot completion zsh)"` in ~/.zshrc; fish: `pencilbot completion fish > '
            "~/.config/fish/completions/pencilbot.fish`."
        ),
    )
    parser.add_argument("shell", nargs="?", choices=SHELLS, help="the shell to complete in")
    parser.add_argument(
        "--names", choices=sorted(NAMED.values()), help=argparse.SUPPRESS
    )  # what the scripts ask
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.names:
        from pencilbot.configs_io import config_names

        print("\n".join(config_names({"profiles": "plotters", "styles": "styles"}[args.names])))
        return 0
    if args.shell is None:
        raise PencilbotError("name the shell: pencilbot completion bash, zsh or fish")
    from pencilbot.commands import build_parser

    commands = describe(build_parser())
    print(fish_script(commands) if args.shell == "fish" else bash_script(commands, zsh=args.shell == "zsh"))
    return 0


def describe(parser: argparse.ArgumentParser) -> dict[str, dict]:
    """Per command: its help line, the choices of its positional arguments (``words``), and each
    option's strings, help and what its value is (``None``: a flag; a list: its choices;
    ``"profiles"``/``"styles"``: a config name; ``""``: anything)."""
    found = {}
    subparsers: Any = parser._subparsers  # argparse's private tree: untyped
    for action in subparsers._group_actions:  # argparse keeps its tree here
        helps = {choice.dest: choice.help for choice in action._choices_actions}
        for name, sub in action.choices.items():
            options, words = [], []
            for option in sub._actions:
                if not option.option_strings and option.choices:
                    words += list(option.choices)  # a positional's choices
                if not option.option_strings or option.help == argparse.SUPPRESS:
                    continue
                takes = None if option.nargs == 0 else list(option.choices) if option.choices else ""
                named = next((NAMED[s] for s in option.option_strings if s in NAMED), None)
                text = (
                    sub._get_formatter()._expand_help(option) if option.help else ""
                )  # %(default)s filled in
                options.append({"strings": option.option_strings, "help": text, "value": named or takes})
            found[name] = {"help": helps.get(name, ""), "options": options, "words": words}
    return found


def bash_script(commands: dict[str, dict], *, zsh: bool = False) -> str:
    """The bash completion function (for zsh, with bashcompinit loaded first)."""
    lines = []
    if zsh:
        lines += ["#compdef pencilbot", "autoload -U +X bashcompinit && bashcompinit"]
    lines += [
        "# pencilbot shell completion (pencilbot completion --help says how to install it)",
        "_pencilbot() {",
        '    local cur="${COMP_WORDS[COMP_CWORD]}" prev="${COMP_WORDS[COMP_CWORD-1]}" command="" i',
        "    for ((i = 1; i < COMP_CWORD; i++)); do",
        '        case "${COMP_WORDS[i]}" in -*) ;; *) command="${COMP_WORDS[i]}"; break ;; esac',
        "    done",
        '    if [[ -z "$command" ]]; then',
        f'        COMPREPLY=($(compgen -W {shlex.quote(" ".join([*commands, "--help", "--version"]))} -- "$cur"))',
        "        return",
        "    fi",
        '    case "$command $prev" in',
    ]
    values: dict[str, list[str]] = {}
    for name, command in commands.items():
        for option in command["options"]:
            if option["value"]:
                key = option["value"] if isinstance(option["value"], str) else " ".join(option["value"])
                values.setdefault(key, []).extend(f"{name} {s}" for s in option["strings"])
    for key, cases in values.items():
        pattern = "|".join(shlex.quote(case) for case in cases)
        if key in NAMED.values():
            words = f'"$(pencilbot completion --names {key} 2>/dev/null)"'
            lines.append(f'        {pattern}) COMPREPLY=($(compgen -W {words} -- "$cur")); return ;;')
        else:
            lines.append(
                f'        {pattern}) COMPREPLY=($(compgen -W {shlex.quote(key)} -- "$cur")); return ;;'
            )
    # Other options that take a value: a file or a number, left to the shell's default.
    anything = [
        f"{name} {s}"
        for name, command in commands.items()
        for option in command["options"]
        if option["value"] == ""
        for s in option["strings"]
    ]
    if anything:
        lines.append(f"        {'|'.join(shlex.quote(case) for case in anything)}) return ;;")
    lines += ["    esac", '    case "$command" in']
    for name, command in commands.items():
        options = " ".join(s for option in command["options"] for s in option["strings"])
        words = " ".join(command["words"])
        lines.append(
            f"        {shlex.quote(name)}) local options={shlex.quote(options)} words={shlex.quote(words)} ;;"
        )
    lines += [
        "        *) return ;;",
        "    esac",
        '    if [[ "$cur" == -* ]]; then COMPREPLY=($(compgen -W "$options" -- "$cur"))',
        '    elif [[ -n "$words" ]]; then COMPREPLY=($(compgen -W "$words" -- "$cur")); fi',
        "}",
        "complete -o default -o bashdefault -F _pencilbot pencilbot",
    ]
    return "\n".join(lines)


def fish_script(commands: dict[str, dict]) -> str:
    """The fish completions: one ``complete`` line per command and option."""
    quote = lambda text: "'" + text.replace("\\", "\\\\").replace("'", "\\'") + "'"  # noqa: E731
    lines = [
        "# pencilbot shell completion (pencilbot completion --help says how to install it)",
        "complete -c pencilbot -f",
    ]
    for name, command in commands.items():
        lines.append(f"complete -c pencilbot -n __fish_use_subcommand -a {name} -d {quote(command['help'])}")
    for name, command in commands.items():
        when = f"-n {quote(f'__fish_seen_subcommand_from {name}')}"
        if command["words"]:
            lines.append(f"complete -c pencilbot {when} -a {quote(' '.join(command['words']))}")
        else:
            lines.append(f"complete -c pencilbot {when} -F")  # its arguments: files
        for option in command["options"]:
            flags = " ".join(
                f"-l {s[2:]}" if s.startswith("--") else f"-s {s[1:]}" for s in option["strings"]
            )
            value = option["value"]
            if value in NAMED.values():
                what = f"-x -a {quote(f'(pencilbot completion --names {value})')}"
            elif isinstance(value, list):
                what = f"-x -a {quote(' '.join(value))}"
            elif value == "":
                what = "-r -F"
            else:
                what = ""
            lines.append(
                f"complete -c pencilbot {when} {flags} {what} -d {quote(option['help'][:80])}".replace(
                    "  ", " "
                )
            )
    return "\n".join(lines)
