"""What both command lines (``identify-layers``, ``plan-tests``) share: the runner that
turns a user's error into one line and an exit status, ``--version`` and the arguments
every command has."""

from __future__ import annotations

import os
import sys

from fem.errors import LayerIdError
from fem.io import tool_version


def run_cli(build_parser, argv=None) -> int:
    """Parse the command line and run the chosen command (``args.run``): user errors
    become one line on stderr and exit status 2."""
    try:
        args = build_parser().parse_args(argv)
        code = args.run(args) or 0
        sys.stdout.flush()  # here, where a closed pipe is caught, not at the interpreter's exit
        return code
    except LayerIdError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader went away (``| head``): the rest of the output has nowhere to go.
        # Point stdout at /dev/null so the interpreter's final flush cannot fail again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1


def add_version(parser) -> None:
    """``--version`` on a tool's top-level parser."""
    parser.add_argument("--version", action="version", version=f"%(prog)s {tool_version()}")


def add_common_arguments(
    parser, spec_help: str = "specimen spec (TOML); default: the bundled example"
) -> None:
    """The options every command of both tools has: the spec file and ``--json``."""
    parser.add_argument("spec", nargs="?", help=spec_help)
    parser.add_argument("--json", action="store_true", help="machine-readable output on stdout")


__all__ = ["run_cli", "add_version", "add_common_arguments"]
