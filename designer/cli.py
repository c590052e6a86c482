"""``plan-tests``: plan bonded test configurations (brought by the test-planner issue)."""
from __future__ import annotations

import sys

from fem.io import run_cli


def _main(argv=None) -> int:
    print("plan-tests is not available yet: it arrives with the test-planner issue "
          "(recommend, check, sweep).", file=sys.stderr)
    return 2


def main(argv=None) -> int:
    return run_cli(_main, argv)


if __name__ == "__main__":
    sys.exit(main())
