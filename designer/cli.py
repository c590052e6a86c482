"""``plan-tests``: plan the bonded test configurations of a laminated plate.

Each command imports the planner parts it runs when it runs, so that ``--version`` and
``--help`` start without loading them."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from fem.design_space import CRITERIA
from fem.errors import DesignError
from fem.io import check_report_folder, report_folder, to_json
from identify.command_line import add_common_arguments, add_version, run_cli
from identify.examples import spec_or_example

from .search.methods import METHODS

DESCRIPTION = """plan-tests: plan the bonded test configurations of a laminated plate.

  recommend  the best sets of added plates from the spec's [design] space
  check      is the spec's own set of configurations identifiable, and how to test it (exit 1 if not)
  sweep      how the scores change with each design variable (a report folder)

Exit status: 0 done (check: feasible), 1 check found the design infeasible, 2 bad input."""


def _problem(args):
    from fem.model import MAX_MODES
    from fem.spec import load_spec
    from fem.validation import whole

    from .problem import Problem
    from .store import SolveStore

    store = SolveStore(args.cache) if hasattr(args, "no_cache") and not args.no_cache else None
    if store is not None and not os.access(store.folder, os.W_OK | os.X_OK):
        print(
            f"note: the solve cache {str(store.folder)!r} is read-only: it is read, new solves are not kept "
            "(--cache DIR elsewhere to keep them)",
            file=sys.stderr,
        )
    model = load_spec(spec_or_example(args.spec))
    for note in model.notes:
        print(f"note: {note}", file=sys.stderr)
    modes = None if args.modes is None else whole(args.modes, "--modes", 1, MAX_MODES, "", DesignError)
    return Problem.of(
        model, modes, getattr(args, "criterion", None), getattr(args, "prior_range", None), store
    )


def _progress(args):
    from .progress import Progress

    show = sys.stderr.isatty() if args.progress is None else args.progress
    return Progress(sys.stderr if show else None)


def _not_the_input(spec, written) -> None:
    """Refuse ``--write-spec`` onto the spec it reads: the user's file (and its comments)
    would be replaced by the design."""
    if written is None or spec is None:
        return
    same = Path(written).resolve() == Path(spec).resolve()
    if not same and Path(written).exists() and Path(spec).exists():
        same = os.path.samefile(written, spec)
    if same:
        raise DesignError(
            f"--write-spec {written}: that is the input spec; it would be overwritten (its comments "
            "lost): write the design to a new file, e.g. --write-spec plan.toml"
        )


def run_recommend(args) -> int:
    """Ranked designs with scores, predicted std and the frequencies to expect."""
    _not_the_input(args.spec, args.write_spec)
    from .candidates import candidates
    from .parallel import executor
    from .scores.damping import damping_scores
    from .search.ranking import recommend
    from .search.refine import refine
    from .spec_file import write_spec

    problem = _problem(args)
    tasks = len(candidates(problem.space, problem.specimen)) + 1
    with executor(args.workers, args.scheduler, tasks) as pool:
        result = recommend(problem, args.top, args.method, pool, _progress(args))
    refined = refine(problem, result.best) if args.refine else None
    best = refined.design if refined is not None and refined.improved else result.best
    written = write_spec(problem, best, args.write_spec) if args.write_spec else None
    scores = [
        damping_scores(problem.model, [s.configuration for s in d.solved], problem.space.damping_std_rel)
        for d in result.designs
    ]
    if args.json:
        out = result.to_dict()
        for design, score in zip(out["designs"], scores):
            design["damping"] = score.to_dict() if score is not None else None
        if refined is not None:
            out["refined"] = refined.to_dict()
        if written is not None:
            out["written_spec"] = str(written)
        print(to_json(out))
        return 0
    print(result.report())
    for k, score in enumerate(scores):
        if score is not None:
            print(f"\ndesign {k + 1} " + score.report())
    if refined is not None:
        print("\n" + refined.report())
    if written is not None:
        print(
            f"\nwritten: {written} ({'the refined' if best is not result.best else 'the best'} design as a "
            "spec; "
            "check it with plan-tests check, fit it with identify-layers fit)"
        )
    return 0


def run_check(args) -> int:
    """Feasibility of the spec's configurations; exit status 1 when infeasible."""
    from .check import check

    if args.out:
        check_report_folder(args.out)
    problem = _problem(args)
    configurations = None
    if args.configurations:
        configurations = [problem.specimen.configuration(n.strip()) for n in args.configurations.split(",")]
    result = check(problem, configurations, progress=_progress(args))
    figures = []
    if args.out:
        with report_folder(args.out) as folder:
            figures = [Path(args.out) / Path(f).name for f in result.test_sheet.write(folder)]
    if args.json:
        out = result.to_dict()
        if args.out:
            out["figures"] = [str(f) for f in figures]
        print(to_json(out))
    else:
        print(result.report())
        if figures:
            print(f"\nwritten: {', '.join(str(f) for f in figures)}")
    return 0 if result.feasible else 1


def run_sweep(args) -> int:
    """A report folder: CSV, plots, summary."""
    from .parallel import executor
    from .sweep import parse_variable, sweep

    check_report_folder(args.out)  # refuse a bad --out before the solves, not after
    problem = _problem(args)
    variables = [parse_variable(v, problem) for v in (args.vary or ["thickness", "material"])]
    tasks = len(problem.specimen.configurations) * (1 + sum(len(v.values) for v in variables))
    with executor(args.workers, args.scheduler, tasks) as pool:
        result = sweep(problem, variables, pool, _progress(args))
    files = result.write(args.out)
    if args.json:
        print(to_json({"folder": str(args.out), "files": [str(f) for f in files], **result.to_dict()}))
        return 0
    print(result.report())
    print(f"\nwritten: {', '.join(str(f) for f in files)}")
    return 0


def _common(p: argparse.ArgumentParser, parallel: bool = True, prior: bool = True) -> None:
    add_common_arguments(p)
    p.add_argument("--modes", type=int, help="modes measured per plate (default: [model] modes)")
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )
    if prior:
        p.add_argument(
            "--prior-range",
            type=float,
            metavar="REL",
            help="score over +-REL of the identified properties (default: [design] prior_range_rel; 0: "
            "the nominal values only)",
        )
    if parallel:
        p.add_argument(
            "--workers",
            type=int,
            default=0,
            help="processes (default 0: all cores when there are enough solves to pay for them)",
        )
        p.add_argument("--scheduler", help="run on the Dask cluster at this address (needs the dask extra)")
        p.add_argument(
            "--cache",
            metavar="DIR",
            help="keep solved configurations here, so an interrupted or repeated run resumes (default: "
            "$XDG_CACHE_HOME/layer-id/solves)",
        )
        p.add_argument("--no-cache", action="store_true", help="solve everything anew; keep nothing on disk")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="plan-tests", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_version(parser)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("recommend", help="best sets of added plates from the [design] space")
    _common(p)
    p.add_argument("--top", type=int, default=5, help="designs to list (default 5)")
    p.add_argument(
        "--method",
        choices=METHODS,
        default="auto",
        help="exhaustive, relaxation (cvxpy) or auto (exhaustive up to 50 000 sets)",
    )
    p.add_argument("--criterion", choices=list(CRITERIA), help="rank by (default: [design] criterion)")
    p.add_argument(
        "--refine",
        action="store_true",
        help="also try the stock thicknesses next to the best set's continuous optimum (nlopt)",
    )
    p.add_argument(
        "--write-spec",
        metavar="OUT.toml",
        help="write the best (or refined) design as a complete spec, for check and fit",
    )
    p.set_defaults(run=run_recommend)
    p = sub.add_parser("check", help="feasibility of the spec's configurations (exit 1 if infeasible)")
    _common(p, parallel=False)
    p.add_argument("--configurations", help="comma-separated names to check (default: all in the spec)")
    p.add_argument(
        "--out", metavar="DIR", help="write the test sheet's figures (one per configuration) to DIR"
    )
    p.set_defaults(run=run_check)
    p = sub.add_parser("sweep", help="scores against each design variable: CSV, plots, summary")
    _common(p, prior=False)  # a sweep scores at the nominal values
    p.add_argument(
        "--vary",
        action="append",
        metavar="VAR[=VALUES]",
        help="thickness, adhesive_thickness, material, placement or modes, optionally CONFIG.VAR; "
        "values 0.5,1,2 or START:STOP:COUNT (repeatable; default: thickness and material)",
    )
    p.add_argument("--out", default="reports/sweep", help="report folder (default reports/sweep)")
    p.set_defaults(run=run_sweep)
    return parser


def main(argv=None) -> int:
    """Run a command; bad input becomes one line on stderr and exit status 2."""
    return run_cli(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
