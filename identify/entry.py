"""The console entry points (``identify-layers``, ``plan-tests``).  They load their
command line's modules inside the interrupt handling, so that a Ctrl-C while they load
ends in one line, as it does once the command runs."""
from __future__ import annotations

import sys
from importlib import import_module


def _run(module: str) -> int:
    try:
        main = import_module(module).main
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return main()


def identify_layers() -> int:
    return _run("identify.cli")


def plan_tests() -> int:
    return _run("designer.cli")
