"""Output helpers shared by the command-line tools: atomic writes and clean errors."""
from __future__ import annotations

import html
import json
import os
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .errors import LayerIdError


@contextmanager
def atomic_path(path: str | Path):
    """Yield a temporary path beside ``path``; move it into place only on success,
    so an interrupted run never leaves a half-written file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; reports are for everyone who may read the folder
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


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


def run_cli(build_parser, argv=None) -> int:
    """Parse the command line and run the chosen command (``args.run``): user errors
    become one line on stderr and exit status 2."""
    try:
        args = build_parser().parse_args(argv)
        return args.run(args) or 0
    except LayerIdError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


def add_common_arguments(parser, spec_help: str = "specimen spec (TOML); default: the bundled example") -> None:
    """The options every command of both tools has: the spec file and ``--json``."""
    parser.add_argument("spec", nargs="?", help=spec_help)
    parser.add_argument("--json", action="store_true", help="machine-readable output on stdout")
