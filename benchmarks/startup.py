"""Start-up time of the command lines: each command run as a whole process, paired run
by run with ``python -c "import numpy"`` (the floor any numpy program pays), so the
ratio holds on a busy machine whose speed drifts between runs.

Goals (the command line's own work is small; almost all of a start is import):
``identify-layers --version`` and ``plan-tests --help`` <= 0.3 s, ``identify-layers
predict`` on the bundled example <= 0.6 s, on an idle machine, where a start is one
thread's CPU time and numpy's import takes 0.11 s of it (median of 7 paired runs, 2-core
reference machine): ratios to numpy's import of <= 2.7 and <= 5.5.  The verdict is on
the median ratio of CPU times (user + sys of the process), which other load on the
machine changes far less than wall time; the table gives both.
"""

import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

BIN = Path(sys.executable).parent
REFERENCE = [sys.executable, "-c", "import numpy"]
#: (name, command, goal [s] on an idle machine, goal as a ratio to the reference)
COMMANDS = (
    ("identify-layers --version", [str(BIN / "identify-layers"), "--version"], 0.3, 2.7),
    ("plan-tests --help", [str(BIN / "plan-tests"), "--help"], 0.3, 2.7),
    ("identify-layers predict", [str(BIN / "identify-layers"), "predict"], 0.6, 5.5),
)
#: Pairs timed per command, after one warm-up pair (file caches).
PAIRS = 7


def run(command: list[str]) -> tuple[float, float]:
    """(wall, CPU) time [s] of one run of ``command`` as a whole process; it must succeed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def paired(command: list[str], pairs: int = PAIRS) -> dict:
    """Medians over ``pairs`` runs of the reference and ``command`` in turn: their wall and
    CPU times and the ratios pair by pair."""
    run(REFERENCE), run(command)
    times = [(run(REFERENCE), run(command)) for _ in range(pairs)]
    return {
        "command_wall_s": statistics.median(c[0] for _, c in times),
        "command_cpu_s": statistics.median(c[1] for _, c in times),
        "reference_cpu_s": statistics.median(r[1] for r, _ in times),
        "wall_ratio": statistics.median(c[0] / r[0] for r, c in times),
        "cpu_ratio": statistics.median(c[1] / r[1] for r, c in times),
    }


def main() -> None:
    print(
        f"== start-up of the command lines: medians of {PAIRS} runs paired with python -c 'import numpy' =="
    )
    print(
        f"{'command':26s} {'wall [s]':>8s} {'cpu [s]':>8s} {'numpy cpu':>9s} {'wall x':>7s} {'cpu x':>6s} "
        f"{'goal cpu x':>16s}  verdict"
    )
    for name, command, goal_s, goal_ratio in COMMANDS:
        row = paired(command)
        verdict = "met" if row["cpu_ratio"] <= goal_ratio else "MISSED"
        print(
            f"{name:26s} {row['command_wall_s']:8.3f} {row['command_cpu_s']:8.3f} "
            f"{row['reference_cpu_s']:9.3f} "
            f"{row['wall_ratio']:7.2f} {row['cpu_ratio']:6.2f} {f'<= {goal_ratio:g} ({goal_s:g} s)':>16s}  "
            f"{verdict}"
        )


if __name__ == "__main__":
    main()
