"""The reference pages: `docs/reference/commands.md` (every command's --help) and
`docs/reference/config.md` (every config group and key, as `geocode config --keys` lists
them), written by `geocode reference -o docs/reference`; `tests/test_reference.py` fails when
the committed pages differ from what that command writes.

The command line's parser is handed in, not imported: this module sits in the tools layer,
below `geocode.cli` (tests/test_layering.py), and the `reference` command passes its own
parser. Help is formatted at a fixed width, so the pages never depend on the terminal.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

WIDTH = 100   # characters a line of --help
GENERATED = "Written by `geocode reference -o docs/reference`; do not edit by hand: rerun it."


def commands(parser: argparse.ArgumentParser) -> list[tuple[argparse.ArgumentParser, str]]:
    """Every command and subcommand below `parser`, depth first in the parser's order, each with
    the one line its parent's help gives it."""
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            lines = {choice.dest: choice.help for choice in action._choices_actions}
            for name, sub in action.choices.items():
                found += [(sub, lines[name]), *commands(sub)]
    return found


def help_text(parser: argparse.ArgumentParser) -> str:
    """`parser`'s --help at WIDTH characters a line (the parser keeps that width after)."""
    parser.formatter_class = functools.partial(parser.formatter_class, width=WIDTH)
    return parser.format_help().rstrip()


def anchor(title: str) -> str:
    """The fragment a Markdown renderer gives a heading of words: `geocode bench fit` ->
    `geocode-bench-fit`."""
    return title.lower().replace(" ", "-")


def cell(text: str, code: bool = False) -> str:
    """`text` as a Markdown table cell: bars escaped, and angle brackets outside its code spans."""
    text = text.replace("|", "\\|")
    if code:
        return f"`{text}`"
    spans = text.split("`")
    spans[::2] = [span.replace("<", "&lt;").replace(">", "&gt;") for span in spans[::2]]
    return "`".join(spans)


def commands_page(parser: argparse.ArgumentParser) -> str:
    found = commands(parser)
    lines = ["# Commands", "", GENERATED, "",
             "Each command's `--help`. A pipeline step also takes the config's `key=value` settings "
             "([config.md](config.md)).", "",
             "| command | what it does |", "|---|---|"]
    lines += [f"| [`{sub.prog}`](#{anchor(sub.prog)}) | {cell(line)} |" for sub, line in found]
    lines += ["", f"## {parser.prog}", "", "```text", help_text(parser), "```"]
    for sub, _ in found:
        lines += ["", f"## {sub.prog}", "", "```text", help_text(sub), "```"]
    return "\n".join(lines) + "\n"


def config_page() -> str:
    from geocode.config import compose, config_groups, key_rows

    lines = ["# Configuration", "", GENERATED, "",
             "Choose a group's option with `group=choice` and set a key with `key=value`, on a step's "
             "command line (`geocode train domain=chair train.max_epochs=50`) or through the workflow "
             "(`snakemake --config ...`: [../guide/scale.md](../guide/scale.md)). `geocode config --keys` "
             "prints the same list with any overrides applied. Defaults are the default profile's (`mini`).",
             "", "## Groups", "", "| group | choices |", "|---|---|"]
    lines += [f"| `{group}` | {', '.join(f'`{c}`' for c in choices)} |" for group, choices in config_groups().items()]
    section = None
    for key, value, meaning, valid in key_rows(compose()):
        top = key.partition(".")[0] if "." in key else "top level"
        if top != section:
            section = top
            lines += ["", f"## {section}", "", "| key | default | meaning | valid values |", "|---|---|---|---|"]
        lines.append(f"| `{key}` | {cell(value, code=True)} | {cell(meaning)} | {cell(valid)} |")
    return "\n".join(lines) + "\n"


def write_reference(parser: argparse.ArgumentParser, folder: Path) -> list[Path]:
    """Write commands.md and config.md into `folder` (each file whole or not at all)."""
    from geocode.meshio import write_text

    pages = {folder / "commands.md": commands_page(parser), folder / "config.md": config_page()}
    folder.mkdir(parents=True, exist_ok=True)
    for path, text in pages.items():
        write_text(path, text)
    return list(pages)
