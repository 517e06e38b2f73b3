"""The parameter counts the docs state are the programs' own: the README's programs table and
each program's docstring ("61 parameters: 12 discrete, 49 continuous")."""

import re
from pathlib import Path

import pytest

from geocode.paths import programs_dir
from geocode.program import Program, registry

pytestmark = pytest.mark.blender

README = Path(__file__).parents[1] / "README.md"


def _readme_counts() -> dict[str, int]:
    rows = re.findall(r"^\| `(\w+)` \| (\d+)\b.*\| \[docs/\1-gallery\.png\]", README.read_text(),
                      re.MULTILINE)
    return {domain: int(count) for domain, count in rows}


def test_the_readme_lists_every_program():
    assert sorted(_readme_counts()) == sorted(registry())


@pytest.mark.parametrize("domain", registry())
def test_stated_counts_are_exact(domain):
    kinds = [p.kind for p in Program.load(domain).parameters]
    discrete, continuous = len(kinds) - kinds.count("float"), kinds.count("float")
    assert _readme_counts()[domain] == len(kinds)
    docstring = (programs_dir() / f"{domain}.py").read_text().split('"""')[1]
    stated = re.search(r"(\d+) parameters:\s+(\d+) discrete,\s+(\d+) continuous", docstring)
    assert stated, f"{domain}.py states no parameter counts"
    assert tuple(map(int, stated.groups())) == (len(kinds), discrete, continuous)
