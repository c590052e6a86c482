"""Run every benchmark: ``python -m benchmarks [OUT.md]``.

Each benchmark prints its figures as it goes; the same text is written, with the date,
the machine and its load, to ``docs/generated/benchmarks.md`` (or ``OUT.md``), the
accuracy and speed page of the documentation, so the published figures are the ones
``make bench`` measured and never copied by hand.  (Guarded: the designer's and the
diagnosis's worker processes are spawned and import the main module.)
"""
import contextlib
import io
import os
import platform
import sys
from datetime import datetime, timezone
from pathlib import Path

from fem.io import tool_version, write_text

from . import core, damping, designer, diagnosis, identification, layerwise, peaks, startup

#: The benchmarks in the order they run, each with the heading of its section.
SECTIONS = (("Start-up of the command lines", startup),
            ("Physics core: accuracy against time, solve and sensitivity cost", core),
            ("Test planner", designer),
            ("Identification", identification),
            ("Diagnosis against one baseline fit", diagnosis),
            ("Layerwise plate model", layerwise),
            ("Measurement front end: recordings to peak lists", peaks),
            ("Damping of the layers", damping))
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
    return (f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
            f"{platform.python_version()}, layer-id {tool_version()}; load average (1/5/15 min) {load}")


def run(page: Path = PAGE) -> None:
    """Every benchmark, printed and written to ``page`` (Markdown, atomically)."""
    start = f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC on {_machine()}"
    parts = []
    for heading, module in SECTIONS:
        tee = _Tee(sys.stdout)
        with contextlib.redirect_stdout(tee):
            module.main()
        parts.append(f"## {heading}\n\n```\n{tee.copy.getvalue().rstrip()}\n```\n")
    text = ("# Accuracy and speed\n\n"
            "Written by `make bench` (`python -m benchmarks`); do not edit by hand. Each section is the\n"
            "output of one benchmark module, with its targets. Timings are wall times on the machine\n"
            "below; a busy machine (load average above its cores) makes them longer.\n\n"
            f"- started: {start}\n"
            f"- finished: {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC on {_machine()}\n\n" + "\n".join(parts))
    page.parent.mkdir(parents=True, exist_ok=True)
    write_text(page, text)
    print(f"written to {page}")


if __name__ == "__main__":
    run(Path(sys.argv[1]) if len(sys.argv) > 1 else PAGE)
