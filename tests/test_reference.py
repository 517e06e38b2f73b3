"""The reference pages docs/reference/*.md are what `geocode reference` writes now: a changed
option, help line or config key fails here until the pages are written again."""

from pathlib import Path

import pytest

from geocode.cli import main, parser
from geocode.paths import PROGRAMS_ENV
from geocode.settings import documented_keys
from geocode.tools.reference import anchor, cell, commands, commands_page, config_page

REFERENCE = Path(__file__).resolve().parents[1] / "docs" / "reference"
COMMAND = "geocode reference -o docs/reference"


@pytest.fixture
def registry_programs(monkeypatch):
    """The repository's programs, whatever the environment names, and a narrow terminal that
    must not change the pages."""
    monkeypatch.delenv(PROGRAMS_ENV, raising=False)
    monkeypatch.setenv("COLUMNS", "37")


def test_the_committed_reference_pages_are_current(registry_programs, tmp_path, capsys):
    assert main(["reference", "-o", str(tmp_path)]) == 0
    assert "commands.md" in capsys.readouterr().out
    for name in ("commands.md", "config.md"):
        committed = REFERENCE / name
        assert committed.exists(), f"docs/reference/{name} is missing; run: {COMMAND}"
        assert (tmp_path / name).read_text() == committed.read_text(), \
            f"docs/reference/{name} is stale; run: {COMMAND}"


def test_every_command_has_its_section(registry_programs):
    page = commands_page(parser())
    found = [sub.prog for sub, _ in commands(parser())]
    assert {"geocode reconstruct", "geocode bench fit", "geocode program show", "geocode reference"} <= set(found)
    for prog in found:
        assert f"\n## {prog}\n" in page and f"(#{anchor(prog)})" in page, prog
    assert "examples:\n  geocode reconstruct chair scan.ply -o out/" in page


def test_every_config_key_has_its_row(registry_programs):
    page = config_page()
    for key in documented_keys():
        assert f"| `{key}` |" in page, key
    assert "| `train.max_epochs` | `16` |" in page       # the default profile's value


def test_cells_escape_what_markdown_would_read():
    assert cell("a|b <x> `c <d>`") == "a\\|b &lt;x&gt; `c <d>`"
    assert cell("{a: 1}|2", code=True) == "`{a: 1}\\|2`"
