"""Output helpers shared by the command-line tools: files and report folders written
whole or not at all, JSON, the tool's version."""

from __future__ import annotations

import html
import json
import os
import shutil
import signal
import tempfile
import threading
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

import numpy as np

from .errors import OutputError

#: The file that marks a folder as a report this tool wrote (so it may replace it whole).
REPORT_MARK = ".layer-id-report"


@lru_cache(maxsize=1)
def tool_version() -> str:
    """The installed version of the tool (pyproject's), or 'unknown' when not installed."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("layer-id")
    except PackageNotFoundError:
        return "unknown"


def _permissions() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def _writable_parent(path: Path, what: str) -> None:
    """Make the parent folder, or a one-line error saying why it cannot be written."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(
            f"{what} {str(path)!r}: its folder cannot be made ({exc.strerror}); choose another place"
        ) from None
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise OutputError(
            f"{what} {str(path)!r}: the folder {str(path.parent)!r} is not writable; choose another place"
        )


@contextmanager
def atomic_path(path: str | Path):
    """Yield a temporary path beside ``path``; move it into place only on success,
    so an interrupted run never leaves a half-written file."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"output file {str(path)!r} is a folder; give a file name")
    _writable_parent(path, "output file")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        # mkstemp makes 0600; reports are for everyone who reads the folder
        os.chmod(tmp, 0o666 & ~_permissions())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _manifest(folder: Path) -> set[str] | None:
    """The files a report folder's mark lists as written by this tool (relative paths),
    or None when the folder has no mark (not a report of this tool)."""
    mark = folder / REPORT_MARK
    if not mark.is_file():
        return None
    lines = mark.read_text(errors="replace").splitlines()
    return {line[2:] for line in lines if line.startswith("- ")}


def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*") if not p.is_dir() and p.name != REPORT_MARK}


def check_report_folder(path: str | Path) -> Path:
    """``path`` as a report folder to write, or a one-line error before any work: an
    existing file, the current folder or one above it, a folder that is not this tool's
    report or holds files the tool did not write (its mark lists those it wrote), a place
    that cannot be written."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"report folder {str(path)!r} is an existing file; give a folder name")
    if path.exists() and Path.cwd().resolve().is_relative_to(path.resolve()):
        raise OutputError(
            f"report folder {str(path)!r} is the current folder or holds it; a report replaces its "
            "folder whole: give a new subfolder, e.g. --report report"
        )
    if path.is_dir() and any(path.iterdir()):
        written = _manifest(path)
        if written is None:
            raise OutputError(
                f"report folder {str(path)!r} exists and is not a report of this tool; choose a new or "
                "empty folder (its files are left alone)"
            )
        foreign = sorted(_files(path) - written)
        if foreign:
            listed = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
            raise OutputError(
                f"report folder {str(path)!r} holds files this tool did not write ({listed}); a new "
                "report replaces the folder whole: move them out or choose another folder"
            )
    _writable_parent(path, "report folder")
    return path


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _clear_leftovers(path: Path) -> None:
    """Remove what killed runs left beside ``path`` (``.NAME.tmp-PID-*``, ``.NAME.old-PID-*``);
    a running one's (its process still alive) is left alone."""
    for stale in list(path.parent.glob(f".{path.name}.tmp-*")) + list(
        path.parent.glob(f".{path.name}.old-*")
    ):
        pid = stale.name.rsplit(".", 1)[-1].split("-")[1]
        if not (pid.isdigit() and _alive(int(pid))):
            shutil.rmtree(stale, ignore_errors=True)


@contextmanager
def _swap_lock(path: Path):
    """One run at a time swaps its report into ``path`` (a lock on the folder that holds
    it: nothing is left behind), so two runs into one folder end with one whole report,
    the later one's."""
    import fcntl

    fd = os.open(path.parent, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


@contextmanager
def report_folder(path: str | Path):
    """Yield a temporary folder beside ``path`` to write a report into; on success it
    replaces ``path`` whole (a previous report of this tool included: no stale files
    mix in), on any error or interruption it is removed.  ``path`` must be new, empty, or
    a report this tool wrote holding only files it wrote (the mark ``REPORT_MARK`` lists
    them): anything else is refused before work starts, and again just before the swap.
    Leftovers of a run that was killed (``.NAME.tmp-PID-*``, ``.NAME.old-PID-*`` beside
    it) are cleared first; a concurrent run's are not.  A kill between the two renames
    that swap an old report for the new one leaves the old one as ``.NAME.old-*``; Ctrl-C
    and SIGTERM wait until both are done."""
    path = check_report_folder(path)
    _clear_leftovers(path)
    tmp = None
    try:
        # Made with interrupts held: a Ctrl-C between the folder's creation and its name
        # being known here would leave it behind (the interrupt now comes after, inside
        # the try, and the folder is removed).
        with _interrupts_held():
            tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.tmp-{os.getpid()}-"))
        yield tmp
        written = sorted(_files(tmp))
        (tmp / REPORT_MARK).write_text(
            f"written by layer-id {tool_version()}; its files:\n" + "".join(f"- {name}\n" for name in written)
        )
        os.chmod(tmp, 0o777 & ~_permissions())
        with _swap_lock(path), _interrupts_held():
            check_report_folder(path)  # still ours to replace (nothing foreign put in meanwhile)
            old = None
            if path.exists():
                old = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.old-{os.getpid()}-"))
                os.replace(path, old / "report")
            os.replace(tmp, path)
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
    finally:
        if tmp is not None and tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


@contextmanager
def _interrupts_held():
    """Ctrl-C (SIGINT) and SIGTERM wait until the swap's two renames are done: an
    interruption between them would leave the old report moved aside and no new one."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def write_text(path: str | Path, text: str) -> None:
    """Write a text file atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def html_pre(text: str) -> str:
    """A text report as HTML (the notebook view of a result)."""
    return f"<pre>{html.escape(text)}</pre>"


def _plain(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def to_json(data) -> str:
    """JSON text with numpy values converted."""
    return json.dumps(data, indent=2, default=_plain, allow_nan=False)
