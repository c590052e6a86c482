"""Run every benchmark: ``python -m benchmarks [OUT.md] [--only NAME ...]``.

Each benchmark prints its figures as it goes; the same text is written, with the date,
the machine and its load, to ``docs/generated/benchmarks.md`` (or ``OUT.md``), the
accuracy and speed page of the documentation, so the published figures are the ones
``make bench`` measured and never copied by hand.  ``--only startup peaks`` re-measures the
named benchmark modules and replaces their sections of the page, keeping the others; every
section says when, and under what load, it was measured.  (Guarded: the designer's and the
diagnosis's worker processes are spawned and import the main module.)
"""

import contextlib
import io
import os
import platform
import resource
import sys
from datetime import UTC, datetime
from pathlib import Path

from fem.io import tool_version, write_text

from . import core, damping, designer, diagnosis, identification, layerwise, peaks, startup

#: The benchmarks in the order they run, each with the heading of its section.
SECTIONS = (
    ("Start-up of the command lines", startup),
    ("Physics core: accuracy against time, solve and sensitivity cost", core),
    ("Test planner", designer),
    ("Identification", identification),
    ("Diagnosis against one baseline fit", diagnosis),
    ("Layerwise plate model", layerwise),
    ("Measurement front end: recordings to peak lists", peaks),
    ("Damping of the layers", damping),
)
PAGE = Path(__file__).parent.parent / "docs" / "generated" / "benchmarks.md"


class _Tee(io.TextIOBase):
    """Writes to the terminal and keeps a copy."""

    def __init__(self, terminal):
        self.terminal, self.copy = terminal, io.StringIO()

    def write(self, text: str) -> int:
        self.terminal.write(text)
        self.terminal.flush()
        return self.copy.write(text)


def _machine() -> str:
    load = " / ".join(f"{x:.1f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "n/a"
    return (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}, layer-id {tool_version()}; load average (1/5/15 min) {load}"
    )


def _measured(module) -> str:
    """One benchmark module run, printed as it goes; its page section's code block."""
    tee = _Tee(sys.stdout)
    with contextlib.redirect_stdout(tee):
        module.main()
        print(_peak_memory())
    return tee.copy.getvalue().rstrip()


def _peak_memory() -> str:
    """Peak resident memory so far of this process and of its largest worker (target:
    2 GB for any command)."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB on Linux
    workers = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return (
        f"peak memory so far (target 2048 MB a process): {own:.0f} MB this process, "
        f"{workers:.0f} MB its largest worker"
    )


def _sections(text: str) -> dict[str, str]:
    """The ``## heading`` sections of a page: heading -> the whole section."""
    return {part.split("\n", 1)[0]: "## " + part.rstrip() + "\n" for part in text.split("\n## ")[1:]}


def run(page: Path = PAGE, only: set[str] | None = None) -> None:
    """The benchmarks (every one, or the modules named in ``only``), printed and written to
    ``page`` (Markdown, atomically); with ``only`` the other sections are kept as they were."""
    names = {module.__name__.split(".")[-1] for _, module in SECTIONS}
    if only is not None and not only <= names:
        raise SystemExit(
            f"--only {' '.join(sorted(only - names))}: no such benchmark; allowed: {', '.join(sorted(names))}"
        )
    start = f"{datetime.now(UTC):%Y-%m-%d %H:%M} UTC on {_machine()}"
    previous = page.read_text() if only is not None and page.exists() else ""
    kept = _sections(previous)
    parts = []
    for heading, module in SECTIONS:
        if only is not None and module.__name__.split(".")[-1] not in only and heading in kept:
            parts.append(kept[heading])
            continue
        block = _measured(module)
        parts.append(
            f"## {heading}\n\n```\n{block}\n```\n\nMeasured {datetime.now(UTC):%Y-%m-%d %H:%M} UTC "
            f"on {_machine()}.\n"
        )
    if only is None:
        runs = f"- started: {start}\n- finished: {datetime.now(UTC):%Y-%m-%d %H:%M} UTC on {_machine()}\n"
    else:  # the last full run's times stay, for the sections kept from it
        runs = "".join(
            line + "\n" for line in previous.splitlines() if line.startswith(("- started:", "- finished:"))
        )
        runs += f"- re-measured with --only {' '.join(sorted(only))}: {start}\n"
    text = (
        "# Accuracy and speed\n\n"
        "Written by `make bench` (`python -m benchmarks`); do not edit by hand. Each section is the\n"
        "output of one benchmark module, with its targets. Timings are wall times on the machine\n"
        "below; a busy machine (load average above its cores) makes them longer.\n\n"
        + runs
        + "\n"
        + "\n".join(parts)
    )
    page.parent.mkdir(parents=True, exist_ok=True)
    write_text(page, text)
    print(f"written to {page}")


if __name__ == "__main__":
    arguments = sys.argv[1:]
    chosen = None
    if "--only" in arguments:
        at = arguments.index("--only")
        chosen, arguments = set(arguments[at + 1 :]), arguments[:at]
    run(Path(arguments[0]) if arguments else PAGE, chosen)
