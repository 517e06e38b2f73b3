"""The README and docs/ as a newcomer reads them: a README of at most 250 lines, prose in the
present tense with no dated or historical words, and links that lead somewhere (a file of the
repository and, for a Markdown page, one of its headings)."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
DATED = re.compile(r"\b(today|yesterday|this week|session|issue \d+|before issue|no longer|used to)\b", re.I)
LINK = re.compile(r"\]\(([^)\s]+)\)")


def name(page: Path) -> str:
    return str(page.relative_to(ROOT))


def anchors(page: Path) -> set[str]:
    """The fragments a Markdown renderer gives the page's headings (GitHub's rule: lower case,
    punctuation dropped, spaces to hyphens)."""
    headings = re.findall(r"^#+\s+(.+?)\s*$", page.read_text(), re.M)
    return {re.sub(r"[^\w\- ]", "", h.lower()).replace(" ", "-") for h in headings}


def test_the_readme_is_short():
    lines = len((ROOT / "README.md").read_text().splitlines())
    assert lines <= 250, f"README.md has {lines} lines; keep it to 250 and move detail into docs/"


@pytest.mark.parametrize("page", PAGES, ids=name)
def test_no_dated_or_historical_words(page):
    found = [f"{name(page)}:{n}: {m[0]!r}" for n, line in enumerate(page.read_text().splitlines(), 1)
             for m in DATED.finditer(line)]
    assert not found, "say what the product does now:\n" + "\n".join(found)


@pytest.mark.parametrize("page", PAGES, ids=name)
def test_links_lead_somewhere(page):
    broken = []
    for target in LINK.findall(page.read_text()):
        if re.match(r"[a-z]+:", target):
            continue                                    # a web address
        path, _, fragment = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        if not file.exists():
            broken.append(f"{target}: no such file")
        elif fragment and file.suffix == ".md" and fragment not in anchors(file):
            broken.append(f"{target}: no such heading in {name(file)}")
    assert not broken, f"{name(page)}: " + "; ".join(broken)


def test_the_checks_catch_what_they_look_for(tmp_path):
    assert DATED.search("as measured today") and DATED.search("see Issue 24") and not DATED.search("todays")
    page = tmp_path / "p.md"
    page.write_text("# Why each default\n## The mini profile's sizes\n")
    assert anchors(page) == {"why-each-default", "the-mini-profiles-sizes"}


def test_the_code_cites_pages_and_headings_that_exist():
    """Comments, docstrings and YAML comments point at docs/<page>.md#<heading> for the reason
    behind a number: the page and the heading must be there."""
    cited = re.compile(r"\bdocs/[\w/.-]+?\.md(?:#[\w-]+)?")
    broken = []
    for folder in ("src", "conf", "workflow", "programs", "profiles", "scripts", "tests", "docs/examples"):
        for file in sorted((ROOT / folder).rglob("*")):
            if (file.suffix not in {".py", ".yaml", ".smk", ".sh", ""} or not file.is_file()
                    or any(part.endswith(".egg-info") for part in file.parts)):   # pip's copy of the README
                continue
            for citation in cited.findall(file.read_text(errors="ignore")):
                path, _, fragment = citation.partition("#")
                if not (ROOT / path).exists() or (fragment and fragment not in anchors(ROOT / path)):
                    broken.append(f"{file.relative_to(ROOT)}: {citation}")
    assert not broken, "citations of missing pages or headings: " + "; ".join(broken)
