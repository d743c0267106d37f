"""Write outputs completely or not at all.

* One file: :func:`atomic_write` (temporary file in the same folder + ``os.replace``).
* A command's set of files: :class:`OutputSet` stages every file in a temporary folder beside
  the output folder; :meth:`OutputSet.commit` removes the command's own stale files from an
  earlier run (the names it owns, not the user's other files) and moves the new set in. A run
  that fails before ``commit`` leaves the previous outputs as they were; Ctrl-C or SIGTERM during
  ``commit`` waits for its end (:func:`gc_ocp.signals.deferred`). A folder holding
  another command's outputs is refused (:data:`OWNER`): two commands' files are never mixed.

Files get the permissions the user's umask gives a new file (``0666 & ~umask``), not the 0600 of
:func:`tempfile.mkstemp`.
"""

from __future__ import annotations

import os
import shutil
import socket
import tempfile
from collections.abc import Callable
from pathlib import Path

from gc_ocp import signals
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


OWNER = ".gc_ocp_outputs"
"""The file in an output folder naming the command whose outputs it holds
(:meth:`OutputSet.commit` writes it): another command refuses the folder rather than mix its
files with them (both write a ``report.html``; a diagnosis beside a fit's ``fit.json`` of
another trial read as one study)."""


def check_writable(
    folder: str | os.PathLike, what: str = "--out", command: str | None = None
) -> Path:
    """Fail early (before any computation) when ``folder`` cannot be an output folder: it is a
    file, a file cannot be made where it and its outputs' staging folder (beside it) would be,
    or it holds another command's outputs (:data:`OWNER`; ``command``: this one's name)."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{what} {folder} exists and is not a folder; give a folder path.")
    for place in dict.fromkeys([folder.parent, folder]):  # the staging folder's, then its own
        existing = next((p for p in (place, *place.parents) if p.exists()), Path("."))
        _probe(existing, folder, what)
    if command is not None and (other := owner_of(folder)) not in ("", command):
        raise InputError(
            f"{what} {folder} holds the outputs of `{other}`; `{command}` would mix its own "
            f"files with them. Give another {what} folder, or empty that one."
        )
    return folder


def owner_of(folder: str | os.PathLike) -> str:
    """The command whose outputs ``folder`` holds (:data:`OWNER`; "" for none)."""
    owner = Path(folder) / OWNER
    return owner.read_text(encoding="utf-8").strip() if owner.is_file() else ""


def claim(folder: str | os.PathLike, command: str) -> None:
    """Record ``command`` as the owner of ``folder``'s outputs (:data:`OWNER`), for the
    commands that write their files one by one (each atomically) rather than as an
    :class:`OutputSet`."""
    atomic_write_text(Path(folder) / OWNER, command + "\n")


def _probe(place: Path, folder: Path, what: str) -> None:
    """Create and remove a file in ``place``: permissions, a read-only or special file system
    (``/proc``, ``/sys``) and a full disk all show here, before any computation, and as the
    user's folder (an access check passes for root where the file system still refuses)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".gc_ocp_probe.", dir=place)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise InputError(
            f"{what} {folder}: cannot write in {place} ({e.strerror or e}); choose a folder you "
            "can write to."
        ) from None


STAGE_OWNER = ".owner"
"""In a staging folder: the host and process id of the run that stages there
(:func:`remove_dead_stages`)."""


def remove_dead_stages(folder: Path) -> None:
    """Remove the staging folders beside ``folder`` (``.NAME.*``) of runs of this host whose
    process is gone: a run killed outright (SIGKILL, a power cut) cannot remove its own, and
    they stayed beside ``--out`` for good (an interruption review). A live process's, another
    host's (a shared file system) or one without an owner record is left alone."""
    host = socket.gethostname()
    for stage in folder.parent.glob(f".{folder.name}.*"):
        try:
            who, pid = (stage / STAGE_OWNER).read_text().split()
        except (OSError, ValueError):
            continue
        if who != host or not pid.isdigit():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(stage, ignore_errors=True)
        except OSError:
            pass  # alive (another user's, say)


class OutputSet:
    """The files of one command run, staged in a temporary folder and moved in together.

    ``owned``: every file name the command may write (its stale copies from an earlier run are
    removed on :meth:`commit`, also when this run does not write them)."""

    def __init__(self, folder: str | os.PathLike, owned: tuple[str, ...], command: str) -> None:
        self.folder = check_writable(folder, command=command)
        self.owned = tuple(owned)
        self.command = command
        try:
            self.folder.parent.mkdir(parents=True, exist_ok=True)
            remove_dead_stages(self.folder)
            self.stage = Path(
                tempfile.mkdtemp(prefix=f".{self.folder.name}.", dir=self.folder.parent)
            )
            (self.stage / STAGE_OWNER).write_text(f"{socket.gethostname()} {os.getpid()}\n")
        except OSError as e:
            raise InputError(
                f"--out {self.folder}: cannot write beside it ({e.strerror or e}); choose a "
                "folder you can write to."
            ) from None
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
        out = []
        with signals.deferred():  # an interrupt waits for the whole set
            for name in self.owned:
                if name not in self.written and (self.folder / name).exists():
                    (self.folder / name).unlink()
            for name in self.written:
                os.replace(self.stage / name, self.folder / name)
                out.append(self.folder / name)
            claim(self.folder, self.command)
        self.discard()
        return out

    def discard(self) -> None:

        shutil.rmtree(self.stage, ignore_errors=True)
