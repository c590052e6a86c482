"""``identify-layers``: predict, fit, compare and diagnose laminated test plates."""
from __future__ import annotations

import argparse
import sys

from fem.io import run_cli, to_json
from fem.model import SpecimenModel
from fem.spec import Spec, load_spec

from .examples import COATED_PLATE, COATED_PLATE_MEASURED
from .measurements import load_measurements
from .report import report_text, to_dict, write_report
from .updating import fit as fit_layers


def _load(path: str | None) -> Spec:
    if path is None:
        print(f"(no SPEC given: using the bundled example {COATED_PLATE.name})", file=sys.stderr)
        path = COATED_PLATE
    return load_spec(path)


def predict(args) -> int:
    """First N elastic frequencies of every configuration."""
    spec = _load(args.spec)
    options = spec.model if args.modes is None else type(spec.model)(args.modes, spec.model.divisions)
    model = SpecimenModel(spec.specimen, options)
    rows = []
    for c in spec.specimen.configurations:
        solution = model.solve(c.name)
        rows.append({"name": c.name, "frequencies_hz": solution.frequencies_hz.round(4), "labels": solution.modes.labels})
    if args.json:
        print(to_json({"configurations": rows}))
        return 0
    mesh = model.mesh
    print(f"{spec.specimen.name}: first {options.modes} elastic modes (Kirchhoff plate, {mesh.nx} x {mesh.ny} elements)")
    header = "mode  " + "".join(f"{r['name']:>24s}" for r in rows)
    print(header)
    for i in range(options.modes):
        cells = "".join(f"{r['frequencies_hz'][i]:>14.3f} Hz {r['labels'][i]:>6s}" for r in rows)
        print(f"{i + 1:>4d}  {cells}")
    return 0


def _load_pair(spec_path: str | None, measurements_path: str | None):
    if spec_path is None and measurements_path is None:
        print(f"(no SPEC and MEASUREMENTS given: using the bundled example {COATED_PLATE.name} with "
              f"{COATED_PLATE_MEASURED.name})", file=sys.stderr)
        spec_path, measurements_path = COATED_PLATE, COATED_PLATE_MEASURED
    elif measurements_path is None:
        raise SystemExit("identify-layers: give both SPEC and MEASUREMENTS (or neither, for the bundled example)")
    spec = load_spec(spec_path)
    return spec, load_measurements(measurements_path, spec.specimen)


def _progress(iteration) -> None:
    print(f"  iteration {iteration.number:2d}: RMS error {100 * iteration.rms_rel_error:.5f} %, "
          f"largest relative change {iteration.step:.2e}", file=sys.stderr)


def fit(args) -> int:
    """Identify the layer properties from measured frequencies of every configuration."""
    spec, measurements = _load_pair(args.spec, args.measurements)
    print(f"identifying {len(spec.specimen.material_parameters())} parameters from {len(measurements)} "
          "frequencies", file=sys.stderr)
    result = fit_layers(spec.specimen, measurements, model=spec.model, progress=_progress)
    if args.report:
        folder = write_report(result, args.report)
        print(f"report written to {folder}/", file=sys.stderr)
    print(to_json(to_dict(result)) if args.json else report_text(result))
    return 0 if result.converged else 1


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="identify-layers", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("predict", help="elastic frequencies of every configuration in a spec")
    p.add_argument("spec", nargs="?", help="specimen spec (TOML); default: the bundled example")
    p.add_argument("--modes", type=int, help="elastic modes per configuration (default: [model] modes)")
    p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
    p.set_defaults(run=predict)
    p = sub.add_parser("fit", help="identify the layer properties from measured frequencies")
    p.add_argument("spec", nargs="?", help="specimen spec (TOML); default: the bundled example")
    p.add_argument("measurements", nargs="?", help="measured frequencies (CSV); default: the bundled example's")
    p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
    p.add_argument("--report", metavar="DIR", help="write a report folder (text, JSON, CSV, plots)")
    p.set_defaults(run=fit)
    return parser


def _main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    return args.run(args)


def main(argv=None) -> int:
    return run_cli(_main, argv)


if __name__ == "__main__":
    sys.exit(main())
