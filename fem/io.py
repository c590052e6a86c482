"""Output helpers shared by the command-line tools: files and report folders written
whole or not at all, JSON, the tool's version."""
from __future__ import annotations

import html
import json
import os
import shutil
import tempfile
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
        raise OutputError(f"{what} {str(path)!r}: its folder cannot be made ({exc.strerror}); choose another "
                          "place") from None
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise OutputError(f"{what} {str(path)!r}: the folder {str(path.parent)!r} is not writable; choose another "
                          "place")


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
        os.chmod(tmp, 0o666 & ~_permissions())  # mkstemp makes 0600; reports are for everyone who reads the folder
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def check_report_folder(path: str | Path) -> Path:
    """``path`` as a report folder to write, or a one-line error before any work: an
    existing file, a folder that is not this tool's report, a place that cannot be written."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"report folder {str(path)!r} is an existing file; give a folder name")
    if path.is_dir() and any(path.iterdir()) and not (path / REPORT_MARK).exists():
        raise OutputError(f"report folder {str(path)!r} exists and is not a report of this tool; choose a new or "
                          "empty folder (its files are left alone)")
    _writable_parent(path, "report folder")
    return path


@contextmanager
def report_folder(path: str | Path):
    """Yield a temporary folder beside ``path`` to write a report into; on success it
    replaces ``path`` whole (a previous report of this tool included: no stale files
    mix in), on any error or interruption it is removed.  ``path`` must be new, empty, or
    a report this tool wrote (marked by ``REPORT_MARK``): anything else is refused
    before work starts.  Leftovers of a run that was killed (``.NAME.tmp-*``,
    ``.NAME.old-*`` beside it) are cleared first.  A kill between the two renames that
    swap an old report for the new one leaves the old one as ``.NAME.old-*``."""
    path = check_report_folder(path)
    for stale in list(path.parent.glob(f".{path.name}.tmp-*")) + list(path.parent.glob(f".{path.name}.old-*")):
        shutil.rmtree(stale, ignore_errors=True)
    tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.tmp-"))
    try:
        yield tmp
        (tmp / REPORT_MARK).write_text(f"written by layer-id {tool_version()}\n")
        os.chmod(tmp, 0o777 & ~_permissions())
        old = None
        if path.exists():
            old = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.old-"))
            os.replace(path, old / "report")
        os.replace(tmp, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


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
