"""A command's output files: each checked by really writing beside it before any work is done,
and all of them put in place together, or none.

`Outputs` reserves each output path by creating a temporary file in its folder (making the
missing folders): that is the check, and the only one that cannot be fooled. It fails in a
read-only folder, under /proc or /sys, where a parent is a file or the path is a folder, and
it fails the same way as root (which `os.access` does not see). The command writes every
output to its temporary name; when the block ends well, all are renamed into place, one right
after another with nothing left to compute; when it fails, or is stopped, every temporary
file and every folder made for them is removed, so no output is left looking complete.

    with Outputs() as out:
        obj, png = out.reserve(args.output), out.reserve(args.png)
        ...                                   # the work: nothing is in place yet
        write_obj(obj, mesh)
        render(png)
    # here c.obj and c.png are both in place

`check_writable` is the same check at parse time, before Blender starts or a folder is made.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from geocode.errors import UserError, signals_deferred

_UMASK = os.umask(0o022)
os.umask(_UMASK)
FIX = "choose a folder you can write to"


class Outputs:
    """The output files of one command; a context manager (see the module's docstring)."""

    def __init__(self) -> None:
        self._temporary: dict[Path, Path] = {}   # output path -> its temporary file
        self._made: list[Path] = []              # folders made for the outputs, outermost first

    def reserve(self, path: str | os.PathLike) -> Path:
        """The temporary file to write `path`'s content to, created beside it now; UserError
        (naming `path`, the problem and the fix) where it cannot be."""
        path = Path(path)
        if path.is_dir():
            raise UserError(path, "is a folder", "give a file name to write")
        if any(path.resolve() == other.resolve() for other in self._temporary):
            raise UserError(path, "is given for two outputs", "give each output its own path")
        self._make_folder(path)
        # a stop between making the file and recording it would leave it behind: `discard`
        # removes only what is recorded
        with signals_deferred():
            try:
                fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            except OSError as exc:
                raise UserError(path, f"cannot be written ({exc.strerror})", FIX) from None
            self._temporary[path] = Path(name)
        os.close(fd)
        os.chmod(name, 0o666 & ~_UMASK)      # mkstemp makes 0600; outputs are ordinary files
        return Path(name)

    def _make_folder(self, path: Path) -> None:
        for folder in [p for p in reversed(path.parents) if not p.is_dir()]:
            if folder.exists():
                raise UserError(path, f"{folder} is a file, not a folder", "give another path")
            try:
                folder.mkdir()
            except FileExistsError:  # another process made it meanwhile: theirs, not ours
                continue
            except OSError as exc:
                raise UserError(path, f"its folder {folder} cannot be made ({exc.strerror})", FIX) from None
            self._made.append(folder)

    def commit(self) -> None:
        """Rename every temporary file onto its output (a stop signal waits for the last)."""
        with signals_deferred():
            for path, temporary in self._temporary.items():
                try:
                    os.replace(temporary, path)
                except OSError as exc:
                    self.discard()
                    raise UserError(path, f"cannot be written ({exc.strerror})",
                                    "free some space or choose another place") from None
        self._temporary.clear()
        self._made.clear()

    def discard(self) -> None:
        """Remove every temporary file, and the folders made for them."""
        for temporary in self._temporary.values():
            temporary.unlink(missing_ok=True)
        self._temporary.clear()
        for folder in reversed(self._made):
            try:
                folder.rmdir()
            except OSError:      # something else was put there meanwhile: leave it
                break
        self._made.clear()

    def __enter__(self) -> Outputs:
        return self

    def __exit__(self, kind, exc, traceback) -> None:
        if kind is None:
            self.commit()
        else:                    # any exception, a stop signal included
            self.discard()


def check_writable(path: str | os.PathLike, folder: bool = False) -> Path:
    """`path` (a file, or with `folder` a folder) if a file can be created where it would go,
    tried for real in its nearest existing folder and removed; UserError otherwise."""
    path = Path(path)
    if path.exists() and path.is_dir() != folder:
        kind, want = ("a file", "a folder") if folder else ("a folder", "a file name")
        raise UserError(path, f"is {kind}", f"give {want} to write")
    existing = next(p for p in ((path,) if folder else ()) + tuple(path.parents) if p.exists())
    if not existing.is_dir():
        raise UserError(path, f"{existing} is a file, not a folder", "give another path")
    try:
        fd, name = tempfile.mkstemp(prefix=".geocode-check.", suffix=".tmp", dir=existing)
    except OSError as exc:
        raise UserError(path, f"cannot be written in {existing} ({exc.strerror})", FIX) from None
    os.close(fd)
    os.unlink(name)
    return path
