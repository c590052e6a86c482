"""``identify-layers``: predict, fit, compare and diagnose laminated test plates."""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from fem.effects import apply_fixed, effect
from fem.errors import MeasurementError
from fem.io import run_cli, to_json, write_text
from fem.model import SpecimenModel
from fem.spec import Spec, load_spec

from .examples import COATED_PLATE, COATED_PLATE_MEASURED
from .measurements import load_measurements
from .compare import compare as compare_layers
from .diagnose import diagnose as diagnose_layers
from .diagnose import fit_with_effects
from .plots import plot_comparison, plot_point_map
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
        raise MeasurementError("give both SPEC and MEASUREMENTS (or neither, for the bundled example)")
    spec = load_spec(spec_path)
    return spec, load_measurements(measurements_path, spec.specimen)


def _progress(iteration) -> None:
    print(f"  iteration {iteration.number:2d}: RMS error {100 * iteration.rms_rel_error:.5f} %, "
          f"largest relative change {iteration.step:.2e}", file=sys.stderr)


def _with_spec_effects(spec: Spec):
    """The specimen and model options with the spec's [[effects]] (fixed parameters)."""
    specimen, options, notes = apply_fixed(spec.specimen, spec.model, spec.effects)
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    return specimen, options


def fit(args) -> int:
    """Identify the layer properties from measured frequencies of every configuration."""
    spec, measurements = _load_pair(args.spec, args.measurements)
    specimen, options = _with_spec_effects(spec)
    for kind in args.effect or []:
        effect(kind)  # unknown kinds fail before any work
    before = None
    if args.effect:
        print(f"baseline fit, then with {', '.join(args.effect)} (parameters free):", file=sys.stderr)
        before, result = fit_with_effects(specimen, measurements, options, args.effect,
                                          progress=lambda text: print(f"  {text}", file=sys.stderr))
    else:
        print(f"identifying {len(specimen.material_parameters())} parameters from {len(measurements)} "
              "frequencies", file=sys.stderr)
        result = fit_layers(specimen, measurements, model=options, progress=_progress)
    if args.report:
        folder = write_report(result, args.report, before)
        print(f"report written to {folder}/", file=sys.stderr)
    print(to_json(to_dict(result)) if args.json else report_text(result, before))
    return 0 if result.converged else 1


def compare(args) -> int:
    """Where the model fails: residuals per mode and the patterns that point at causes."""
    spec, measurements = _load_pair(args.spec, args.measurements)
    specimen, options = _with_spec_effects(spec)
    comparison = compare_layers(specimen, measurements, options, refit=not args.no_fit)
    if args.report:
        folder = Path(args.report)
        folder.mkdir(parents=True, exist_ok=True)
        write_text(folder / "comparison.txt", comparison.report())
        write_text(folder / "comparison.csv", comparison.table.to_csv(index=False))
        shown = comparison.fitted.specimen if comparison.fitted else specimen
        plot_comparison(comparison, shown, replace(options, modes=int(measurements.table["mode"].max()) + 3),
                        folder / "residuals_with_shapes.png")
        plot_point_map(comparison, specimen, folder / "point_mass_map.png")
        print(f"report written to {folder}/", file=sys.stderr)
    if args.json:
        print(to_json({"rms_rel_error": comparison.rms_rel_error,
                       "reduced_chi2": comparison.reduced_chi2 if comparison.reduced_chi2 == comparison.reduced_chi2 else None,
                       "at_noise_level": comparison.at_noise_level,
                       "patterns": [{"pattern": p.name, "share": p.share, "detail": p.detail, "suggests": list(p.suggests)}
                                    for p in comparison.patterns],
                       "residuals": comparison.table.to_dict(orient="records")}))
    else:
        print(comparison.report())
    return 0


def diagnose(args) -> int:
    """Rank the candidate physical effects by how much of the misfit each explains."""
    spec, measurements = _load_pair(args.spec, args.measurements)
    specimen, options = _with_spec_effects(spec)
    kinds = args.effects.split(",") if args.effects else None
    for kind in kinds or []:
        effect(kind)  # unknown kinds fail before any work
    result = diagnose_layers(specimen, measurements, options, kinds,
                             progress=lambda text: print(f"  {text}", file=sys.stderr))
    if args.report:
        folder = Path(args.report)
        folder.mkdir(parents=True, exist_ok=True)
        write_text(folder / "diagnosis.txt", result.report())
        write_text(folder / "diagnosis.json", to_json(result.to_dict()))
        if result.candidates and result.candidates[0].fit is not None:
            from .plots import plot_before_after

            best = result.candidates[0]
            plot_before_after(result.baseline, best.fit, best.kind, folder / "before_after.png")
        plot_point_map(result.comparison, specimen, folder / "point_mass_map.png")
        print(f"report written to {folder}/", file=sys.stderr)
    print(to_json(result.to_dict()) if args.json else result.report())
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="identify-layers", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("predict", help="elastic frequencies of every configuration in a spec")
    p.add_argument("spec", nargs="?", help="specimen spec (TOML); default: the bundled example")
    p.add_argument("--modes", type=int, help="elastic modes per configuration (default: [model] modes)")
    p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
    p.set_defaults(run=predict)
    for name, run, text in (("fit", fit, "identify the layer properties from measured frequencies"),
                            ("compare", compare, "where the model fails: residual patterns and plots"),
                            ("diagnose", diagnose, "which physical effect is the model missing?")):
        p = sub.add_parser(name, help=text)
        p.add_argument("spec", nargs="?", help="specimen spec (TOML); default: the bundled example")
        p.add_argument("measurements", nargs="?", help="measured frequencies (CSV); default: the bundled example's")
        p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
        p.add_argument("--report", metavar="DIR", help="write a report folder (text, JSON, CSV, plots)")
        p.set_defaults(run=run)
        if name == "fit":
            p.add_argument("--effect", action="append", metavar="KIND",
                           help="switch an effect on with its parameters free (repeatable): "
                                "transverse_shear, rotary_inertia, point_mass, suspension, orientation, adhesive, "
                                "thickness, or a registered kind")
        if name == "compare":
            p.add_argument("--no-fit", action="store_true", help="compare at the spec's values, without fitting")
        if name == "diagnose":
            p.add_argument("--effects", metavar="K1,K2", help="only these candidate effects (default: all registered)")
    return parser


def main(argv=None) -> int:
    return run_cli(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
