"""The command line: one clear line and exit code 2 for a user's mistake, never a traceback."""

from __future__ import annotations

import argparse
import json
import re
import shlex
import subprocess
import sys

import pytest

from geocode.cli import main, parse, parse_values, parser
from geocode.errors import UserError
from geocode.paths import PROGRAMS_ENV, repo_root


def geocode(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "geocode.cli", *args], capture_output=True, text=True)


def test_importing_the_package_and_cli_pulls_in_neither_blender_nor_torch():
    code = ("import sys, geocode, geocode.cli, geocode.config; "
            "print(sorted(m for m in ('bpy', 'torch') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_parse_values_reads_numbers_and_booleans():
    assert parse_values(["a=1.5", "b=true", "c=false", "d=-2"]) == {"a": 1.5, "b": 1.0, "c": 0.0, "d": -2.0}
    with pytest.raises(ValueError, match="name=number"):
        parse_values(["a=tall"])
    with pytest.raises(ValueError, match="name=number"):
        parse_values(["a"])


def test_config_prints_the_composed_profile(capsys):
    assert main(["config", "profile=smoke", "train.max_epochs=3"]) == 0
    out = capsys.readouterr().out
    assert "profile_name: smoke" in out and "max_epochs: 3" in out


@pytest.mark.parametrize("override, words", [
    ("data.shards=0", "data.shards=0: out of range; give a whole number >= 1"),
    ("profile=huge", "profile"),
    ("data.nonsense=1", "nonsense"),
    ("domain=tabel", "domain=tabel: no such domain; use one of "),
])
def test_bad_overrides_give_one_line(override, words):
    result = geocode("config", override)
    if override.startswith("domain="):
        from geocode.config import registry

        words += ", ".join(registry())
    assert result.returncode == 2
    assert words in result.stderr
    assert "Traceback" not in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_domain_group_comes_from_the_registry(tmp_path, monkeypatch):
    """A program and its recipe make a domain; nothing in conf/ is needed."""
    for name in ("vase", "stool"):
        (tmp_path / f"{name}.py").write_text("")
        (tmp_path / f"{name}.yaml").write_text("parameters: {}\n")
    monkeypatch.setenv("GEOCODE_PROGRAMS", str(tmp_path))
    result = geocode("config", "domain=stool")
    assert result.returncode == 0, result.stderr
    assert "domain:\n  name: stool\n" in result.stdout


def test_shape_rejects_unknown_names_and_out_of_range_values(tmp_path):
    out = tmp_path / "v.obj"
    result = geocode("shape", "vase", "no_such_parameter=1", "-o", str(out))
    assert result.returncode == 2 and "no_such_parameter" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    show = json.loads(geocode("program", "show", "vase", "--json").stdout)
    first = next(p for p in show["parameters"] if p["kind"] == "float")
    result = geocode("shape", "vase", f"{first['name']}={first['max'] + 10}", "-o", str(out))
    assert result.returncode == 2 and first["name"] in result.stderr and not out.exists()
    result = geocode("shape", "vase", f"{first['name']}={first['max']}", "-o", str(out))
    assert result.returncode == 0, result.stderr
    # the OBJ is the program's shape at that value, to the byte, and not its default shape
    from geocode.meshio import obj_text
    from geocode.program import Program

    program = Program.load("vase")
    mesh = program.evaluate({first["name"]: first["max"]})
    assert out.read_text() == obj_text(mesh.vertices, mesh.faces)
    assert out.read_text() != obj_text(program.evaluate({}).vertices, program.evaluate({}).faces)
    assert f"wrote {out} ({len(mesh.faces)} faces)" in result.stdout + result.stderr


def test_program_show_json_lists_every_parameter():
    show = json.loads(geocode("program", "show", "vase", "--json").stdout)
    assert show["domain"] == "vase" and len(show["parameters"]) >= 39
    keys = {"name", "kind", "min", "max", "default", "classes", "visible_if"}
    assert all(keys <= set(p) for p in show["parameters"])
    assert sum(p["visible_if"] is not None for p in show["parameters"]) >= 5


def test_bench_epoch_refuses_an_unknown_device_in_one_line():
    result = geocode("bench", "epoch", "--device", "gpu")
    assert result.returncode == 2 and "--device gpu" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("args", [
    ["gallery", "chair", "-o", "{tmp}/g.png", "-n", "100000000"],
    ["shape", "chair", "-o", "{tmp}/c.obj", "--png", "/proc/x.png"],
    ["reconstruct", "vase", "{tmp}/x.obj", "-o", "{tmp}/out", "--budget", "1000000"],
])
def test_an_out_of_bound_size_or_unwritable_output_is_refused_before_blender_starts(args, tmp_path, monkeypatch,
                                                                                   capsys):
    def started():
        raise AssertionError("Blender started for a refused command")
    monkeypatch.setattr("geocode.cli.import_blender", started)
    assert main([a.replace("{tmp}", str(tmp_path)) for a in args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("geocode: ") and args[-2] in err
    assert not list(tmp_path.iterdir())


@pytest.mark.blender
def test_a_shape_whose_picture_fails_leaves_no_obj(tmp_path, monkeypatch, capsys):
    from geocode.errors import UserError

    def broken_render(mesh, png):
        raise UserError(png, "cannot be rendered", "a test")
    monkeypatch.setattr("geocode.blender.gallery.render_mesh_png", broken_render)
    assert main(["shape", "vase", "-o", str(tmp_path / "c.obj"), "--png", str(tmp_path / "c.png")]) == 2
    assert "cannot be rendered" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


# -- one dialect ------------------------------------------------------------------------------

def subcommands(p: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    """(words, parser) of every command below `p` that runs something, however deep."""
    subs = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield path, p
    for action in subs:
        for name, child in action.choices.items():
            yield from subcommands(child, (*path, name))


def test_every_command_shows_examples_that_parse(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)       # the output options try their folder for real
    commands = list(subcommands(parser()))
    assert len(commands) >= 30 and ("bench", "fit") in dict(commands)
    for words, command in commands:
        examples = command.epilog.partition("examples:\n")[2].splitlines()
        assert examples, words
        for example in examples:
            tokens = shlex.split(example, comments=True)
            assert tokens[:len(words) + 1] == ["geocode", *words], example
            parse(tokens[1:])
    assert "is now" not in capsys.readouterr().err


@pytest.mark.parametrize("old, new", [
    (["reconstruct", "vase", "x.obj", "-o", "out", "--refine", "7"],
     ["reconstruct", "vase", "x.obj", "-o", "out", "--budget", "7"]),
    (["train", "--out", "runs/x", "domain=vase"], ["train", "-o", "runs/x", "domain=vase"]),
    (["gallery", "vase", "-o", "g.png", "--n", "5"], ["gallery", "vase", "-o", "g.png", "--shapes", "5"]),
    (["bench", "program", "vase", "--n", "5"], ["bench", "program", "vase", "-n", "5"]),
    (["bench", "fit", "vase", "--n", "5", "profile=smoke"], ["bench", "fit", "vase", "-n", "5", "profile=smoke"]),
    (["bench", "turns", "vase", "--n", "5"], ["bench", "turns", "vase", "-n", "5"]),
])
def test_an_old_spelling_still_works_with_a_one_line_notice(old, new, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert vars(parse(new)) == vars(parse(old))
    renamed = next(a for a in old if a in ("--refine", "--out", "--n"))
    current = {"--refine": "--budget", "--out": "-o/--output", "--n": "-n/--shapes"}[renamed]
    assert capsys.readouterr().err == (f"geocode: {renamed} is now {current}; "
                                       "the old name goes in the next release\n")
    shown = command_help(old[:2] if old[0] == "bench" else old[:1])
    assert not re.search(rf"(?<![\w-]){renamed}(?![\w-])", shown)    # hidden from --help


def command_help(words: list[str]) -> str:
    return dict(subcommands(parser()))[tuple(words)].format_help()


@pytest.mark.parametrize("args", [
    ["bench", "program", "vase", "--modality", "sketch"],     # fit's option
    ["bench", "fit", "vase", "--clouds", "3"],                 # epoch's
    ["bench", "epoch", "vase"],                                # epoch measures no domain
    ["bench", "eval", "vase", "-o", "pages"],                  # real's and span's
    ["bench", "program", "vase", "profile=smoke"],             # program reads no run
    ["bench", "turns", "vase", "--camera", "novel"],
    ["bench", "span", "vase"],                                 # span needs its folder
])
def test_a_benchmark_refuses_the_options_of_another(args, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"geocode: {' '.join(args[:2])}: ")
    assert f"see geocode {' '.join(args[:2])} --help" in err


def test_the_benchmarks_that_read_a_run_measure_the_validation_split_unless_told(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for words in (["fit", "chair"], ["turns", "chair"]):
        assert parse(["bench", *words]).split == "val"
        assert parse(["bench", *words, "--split", "test"]).split == "test"
        assert "the tables report" in " ".join(command_help(["bench", words[0]]).split())
    assert main(["bench", "fit", "chair", "--split", "train"]) == 2


# -- every command line of the docs parses ----------------------------------------------------

DOCS = [repo_root() / "README.md", *sorted((repo_root() / "docs").rglob("*.md"))]
SHOWN = re.compile(r"^(?:\.venv/bin/)?geocode\s")
# What the docs write for a user's own names: <domain> a domain, any other <...> a name of a
# file or folder; an optional [--option value] is given; "..." ends what is checked, and a line
# that asks for --help only names its command.
PLACEHOLDERS = {"<domain>": "chair", "<benchmark>": "fit", "--workers N": "--workers 2"}
SKIPPED = {"geocode reconstruct chair <the 11 chairs>"}   # a sentence's words, its -o left out
PROGRAMS = re.compile(r"^export GEOCODE_PROGRAMS=(\S+)$", re.M)   # a page about a user's own programs


def shown_commands(text: str) -> list[str]:
    """The `geocode ...` command lines of a Markdown text: lines of its ``` blocks and its
    inline code."""
    shown, block = [], False
    for line in text.splitlines():
        if line.strip().startswith("```"):
            block = not block
        elif block:
            shown += [line.strip()] if SHOWN.match(line.strip()) else []
        else:
            shown += [code.strip() for code in re.findall(r"`([^`]+)`", line) if SHOWN.match(code.strip())]
    return shown


def words_of(shown: str) -> list[str]:
    for placeholder, given in PLACEHOLDERS.items():
        shown = shown.replace(placeholder, given)
    shown = re.sub(r"<[^>]+>", "x", shown)
    shown = re.sub(r"\[(-[^\]]*)\]", r"\1", shown)
    words = [w for w in shlex.split(shown, comments=True)[1:] if w != "--help"]
    return words[:words.index("...")] if "..." in words else words


def names_a_command(words: list[str]) -> bool:
    """Whether the words only name a command (`geocode reconstruct` in a sentence)."""
    p = parser()
    for word in words:
        subs = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs or word not in subs[0].choices:
            return False
        p = subs[0].choices[word]
    return True


def test_shown_commands_are_read_from_blocks_and_inline_code():
    text = "Run `geocode gallery vase -o g.png` or\n```bash\ngeocode programs   # all\nls\n```\n`geocodes`"
    assert shown_commands(text) == ["geocode gallery vase -o g.png", "geocode programs   # all"]
    assert words_of("geocode bench fit <domain> [-n 10] --json") == ["bench", "fit", "chair", "-n", "10", "--json"]
    assert words_of("geocode bench ...") == ["bench"] and names_a_command(["bench"])
    assert not names_a_command(["bench", "vase"])


def test_every_command_line_in_the_readme_and_docs_parses(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    failed, checked = [], 0
    for doc in DOCS:
        text = doc.read_text()
        programs = PROGRAMS.search(text)
        if programs:
            monkeypatch.setenv(PROGRAMS_ENV, str(repo_root() / programs[1]))
        else:
            monkeypatch.delenv(PROGRAMS_ENV, raising=False)
        for shown in shown_commands(text):
            words = words_of(shown)
            if names_a_command(words) or shown in SKIPPED:
                continue
            checked += 1
            try:
                parse(words)
            except UserError as exc:
                failed.append(f"{doc.relative_to(repo_root())}: {shown}: {exc}")
            if "is now" in (notice := capsys.readouterr().err):     # an old spelling
                failed.append(f"{doc.relative_to(repo_root())}: {shown}: {notice.strip()}")
    assert {doc.parent.name for doc in DOCS} >= {"guide", "reference"}   # the subfolders are read
    assert checked >= 20 and not failed, "\n".join(failed)
