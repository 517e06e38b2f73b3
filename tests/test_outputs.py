"""`geocode.outputs`: every output reserved by a real write beside it, all put in place
together or none. Unwritable places are ones that stay unwritable as root: under /proc or
/sys, or below a regular file (chmod does not stop root)."""

from __future__ import annotations

from pathlib import Path

import pytest

from geocode.errors import Interrupted, UserError
from geocode.outputs import Outputs, check_writable

UNWRITABLE = ["/proc/geocode-test.png", "/sys/geocode-test.png", "{tmp}/file.txt/x.png",
              "{tmp}/file.txt/deeper/x.png"]


@pytest.fixture
def tmp(tmp_path: Path) -> Path:
    (tmp_path / "file.txt").write_text("a file, not a folder\n")
    return tmp_path


def files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_every_output_appears_only_when_the_block_ends_well(tmp):
    with Outputs() as out:
        a, b = out.reserve(tmp / "a.obj"), out.reserve(tmp / "new" / "b.yaml")
        a.write_text("a")
        b.write_text("b")
        assert not (tmp / "a.obj").exists() and not (tmp / "new" / "b.yaml").exists()
    assert (tmp / "a.obj").read_text() == "a" and (tmp / "new" / "b.yaml").read_text() == "b"
    assert files(tmp) == ["a.obj", "file.txt", "new", "new/b.yaml"]


@pytest.mark.parametrize("failure", [RuntimeError("bug"), UserError("x", "bad", "fix"), Interrupted()])
def test_a_failure_after_some_outputs_are_written_leaves_none(tmp, failure):
    before = files(tmp)
    with pytest.raises(type(failure)), Outputs() as out:
        out.reserve(tmp / "a.obj").write_text("a")
        out.reserve(tmp / "made" / "deep" / "b.png").write_text("b")
        raise failure
    assert files(tmp) == before                      # no output, no temporary, no new folder


@pytest.mark.parametrize("target", UNWRITABLE)
def test_an_unwritable_output_is_refused_before_any_is_written(tmp, target):
    path = target.format(tmp=tmp)
    before = files(tmp)
    with pytest.raises(UserError, match=f"^{path}: .*; ") as caught, Outputs() as out:
        out.reserve(tmp / "first.obj")
        out.reserve(path)
        pytest.fail("reserved an unwritable path")
    assert len(str(caught.value).splitlines()) == 1
    assert files(tmp) == before


def test_a_folder_and_a_path_given_twice_are_refused(tmp):
    with pytest.raises(UserError, match="is a folder"), Outputs() as out:
        out.reserve(tmp)
    with pytest.raises(UserError, match="two outputs"), Outputs() as out:
        out.reserve(tmp / "a.obj")
        out.reserve(tmp / "." / "a.obj")
    assert files(tmp) == ["file.txt"]


def test_a_stop_while_a_temporary_file_is_made_leaves_none(tmp, monkeypatch):
    """Ctrl-C right after the temporary file exists, before `reserve` returns: the stop waits
    until the file is recorded, so that the block's end removes it."""
    import signal
    import tempfile

    from geocode.errors import stop_signals_raise

    made = tempfile.mkstemp

    def made_then_stopped(*args, **kwargs):
        result = made(*args, **kwargs)
        signal.raise_signal(signal.SIGINT)
        return result

    monkeypatch.setattr(tempfile, "mkstemp", made_then_stopped)
    before = files(tmp)
    with pytest.raises(Interrupted), stop_signals_raise(), Outputs() as out:
        out.reserve(tmp / "a.obj")
        raise AssertionError("the stop did not come")
    assert files(tmp) == before


def test_an_existing_output_is_replaced_only_on_success(tmp):
    old = tmp / "a.obj"
    old.write_text("old")
    with pytest.raises(RuntimeError), Outputs() as out:
        out.reserve(old).write_text("new")
        raise RuntimeError
    assert old.read_text() == "old"
    with Outputs() as out:
        out.reserve(old).write_text("new")
    assert old.read_text() == "new"


@pytest.mark.parametrize("target", UNWRITABLE)
def test_check_writable_tries_for_real_and_leaves_nothing(tmp, target):
    path = target.format(tmp=tmp)
    with pytest.raises(UserError, match=f"^{path}: "):
        check_writable(path)
    assert check_writable(tmp / "new" / "x.png") == tmp / "new" / "x.png"
    assert check_writable(tmp / "new", folder=True) == tmp / "new"
    assert files(tmp) == ["file.txt"]


def test_check_writable_knows_files_from_folders(tmp):
    with pytest.raises(UserError, match="is a folder"):
        check_writable(tmp)
    with pytest.raises(UserError, match="is a file"):
        check_writable(tmp / "file.txt", folder=True)
