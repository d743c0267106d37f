"""Write outputs completely or not at all.

* One file: :func:`atomic_write` (temporary file in the same folder + ``os.replace``).
* A command's set of files: :class:`OutputSet` stages every file in a temporary folder beside
  the output folder; :meth:`OutputSet.commit` removes the command's own stale files from an
  earlier run (the names it owns, not the user's other files) and moves the new set in. A run
  that fails before ``commit`` leaves the previous outputs as they were.

Files get the permissions the user's umask gives a new file (``0666 & ~umask``), not the 0600 of
:func:`tempfile.mkstemp`.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

from gc_ocp.errors import InputError


def atomic_write(path: str | os.PathLike, writer: Callable[[Path], None]) -> Path:
    """Call ``writer(tmp_path)`` then move the finished file onto ``path`` atomically.

    A failure (exception, interrupt) leaves no partial ``path`` and removes the temporary file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(
        prefix=f".{path.name}.", suffix=".tmp" + path.suffix, dir=path.parent
    )
    os.close(fd)
    try:
        writer(Path(tmp))
        os.chmod(tmp, _file_mode())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""

    def w(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())

    return atomic_write(path, w)


def atomic_savefig(fig, path: str | os.PathLike, **kwargs) -> Path:
    """Save a matplotlib figure atomically (format from ``path``'s suffix)."""
    fmt = Path(path).suffix.lstrip(".") or "png"
    return atomic_write(path, lambda tmp: fig.savefig(tmp, format=fmt, **kwargs))


def _file_mode() -> int:
    """``0666 & ~umask``: what ``open()`` gives a new file."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def check_writable(folder: str | os.PathLike, what: str = "--out") -> Path:
    """Fail early (before any computation) when ``folder`` cannot be an output folder."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{what} {folder} exists and is not a folder; give a folder path.")
    parent = (
        folder if folder.exists() else next((p for p in folder.parents if p.exists()), Path("."))
    )
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(
            f"{what} {folder}: {parent} is not writable; choose a folder you can write to."
        )
    return folder


class OutputSet:
    """The files of one command run, staged in a temporary folder and moved in together.

    ``owned``: every file name the command may write (its stale copies from an earlier run are
    removed on :meth:`commit`, also when this run does not write them)."""

    def __init__(self, folder: str | os.PathLike, owned: tuple[str, ...]) -> None:
        self.folder = check_writable(folder)
        self.owned = tuple(owned)
        self.folder.parent.mkdir(parents=True, exist_ok=True)
        self.stage = Path(tempfile.mkdtemp(prefix=f".{self.folder.name}.", dir=self.folder.parent))
        self.written: list[str] = []

    def path(self, name: str) -> Path:
        if name not in self.owned:
            raise ValueError(f"{name} is not one of this command's outputs {self.owned}")
        self.written.append(name)
        return self.stage / name

    def text(self, name: str, text: str) -> None:
        atomic_write_text(self.path(name), text)

    def figure(self, name: str, fig, **kwargs) -> None:
        atomic_savefig(fig, self.path(name), **kwargs)

    def commit(self) -> list[Path]:
        """Remove the command's stale files and move the staged set into the folder."""
        self.folder.mkdir(parents=True, exist_ok=True)
        for name in self.owned:
            if name not in self.written and (self.folder / name).exists():
                (self.folder / name).unlink()
        out = []
        for name in self.written:
            os.replace(self.stage / name, self.folder / name)
            out.append(self.folder / name)
        self.discard()
        return out

    def discard(self) -> None:

        shutil.rmtree(self.stage, ignore_errors=True)
