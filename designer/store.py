"""A content-addressed store of solved configurations on disk, so that an interrupted
``sweep`` or ``recommend`` resumes where it stopped and a repeated one is near-instant.

A solve's key is what its result depends on (the laminate's layers with their materials,
the mesh, the model options, the attachments, the parameters its sensitivities are
taken to); its SHA-256 names a small ``.npz`` (frequencies, labels, relative
sensitivities: a few kB), written atomically, so a killed run leaves whole entries or
none.  Leftover temporary files of a killed run are cleared when the store is opened.
The default folder is ``$XDG_CACHE_HOME/layer-id/solves`` (``~/.cache/...``).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from fem.errors import OutputError
from fem.io import tool_version

#: Entries written by another version of the tool may differ: the version is part of the key.
FORMAT = "1"


def default_folder() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "layer-id" / "solves"


class SolveStore:
    """Solved configurations on disk: ``get(key)`` -> (frequencies, labels or None,
    sensitivities) or None; ``put(key, result)``.  ``hits`` and ``written`` count;
    ``failed`` says why entries could not be written ('' when they could)."""

    def __init__(self, folder: str | Path | None = None):
        self.folder = Path(folder) if folder is not None else default_folder()
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(
                f"solve cache folder {str(self.folder)!r} cannot be made ({exc.strerror}); give "
                "--cache DIR elsewhere or --no-cache"
            ) from None
        for stale in self.folder.glob(".*.tmp"):
            try:
                stale.unlink(missing_ok=True)
            except OSError:
                pass  # a read-only store: its leftovers stay, it is still read
        self.hits = self.written = 0
        self.failed = ""  # why entries could not be written, if they could not

    @staticmethod
    def digest(key) -> str:
        return hashlib.sha256(f"{FORMAT} {tool_version()} {key!r}".encode()).hexdigest()

    def _path(self, key) -> Path:
        return self.folder / f"{self.digest(key)}.npz"

    def get(self, key):
        path = self._path(key)
        try:
            with np.load(path, allow_pickle=False) as data:
                labels = tuple(str(x) for x in data["labels"]) if bool(data["labelled"]) else None
                out = (data["frequencies"].copy(), labels, data["sensitivities"].copy())
        except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):
            return None  # absent, or unreadable (truncated, empty, foreign: then it is simply solved again)
        self.hits += 1
        return out

    def put(self, key, result) -> None:
        """Keep a solve; a store that cannot be written (read-only, disk full) is only a
        lost speed-up: the run goes on and ``failed`` says why."""
        frequencies, labels, sensitivities = result
        try:
            fd, tmp = tempfile.mkstemp(dir=self.folder, prefix=".", suffix=".tmp")
        except OSError as exc:
            self.failed = (
                self.failed or f"solve cache {str(self.folder)!r} cannot be written ({exc.strerror})"
            )
            return
        os.close(fd)
        try:
            with open(tmp, "wb") as handle:
                np.savez(
                    handle,
                    frequencies=frequencies,
                    sensitivities=sensitivities,
                    labels=np.array(labels if labels is not None else (), dtype=str),
                    labelled=np.array(labels is not None),
                )
            os.replace(tmp, self._path(key))
            self.written += 1
        except OSError as exc:
            self.failed = (
                self.failed or f"solve cache {str(self.folder)!r} cannot be written ({exc.strerror})"
            )
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)


__all__ = ["SolveStore", "default_folder"]
