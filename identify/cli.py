"""``identify-layers``: predict, fit, compare and diagnose laminated test plates.

Each command imports what it runs when it runs (the fit, the diagnosis, the plots), so
that ``--version``, ``--help`` and ``predict`` start without loading them."""

from __future__ import annotations

import argparse
import sys

from fem.effect_kinds import BUILT_IN
from fem.errors import MeasurementError
from fem.io import check_report_folder, report_folder, to_json, write_text

from .command_line import add_common_arguments, add_version, run_cli
from .examples import COATED_PLATE_MEASURED, spec_or_example

DESCRIPTION = """identify-layers: the stiffness of every layer of a laminated plate from its resonances.

  predict   elastic frequencies of every configuration in a spec
  peaks     modal peaks of one configuration from tap recordings (a peak-list CSV)
  fit       identify the layer properties from measured frequencies
  compare   where the model fails: residual patterns and plots
  diagnose  which physical effect is the model missing?

Exit status: 0 done (fit: converged, and its loss factors too when asked for), 1 fit (or its damping
identification) did not converge, is a poor fit or is not identifiable, 2 bad input."""


def _say(text: str) -> None:
    print(text, file=sys.stderr)


def _model(args):
    from fem.spec import load_spec

    model = load_spec(spec_or_example(args.spec))
    for note in model.notes:
        _say(f"note: {note}")
    return model


def _model_and_measurements(args):
    from .measurements import load_measurements

    if args.spec is not None and args.measurements is None:
        raise MeasurementError("give both SPEC and MEASUREMENTS (or neither, for the bundled example)")
    model = _model(args)
    if args.measurements is None:
        _say(f"(no MEASUREMENTS given: using the bundled example {COATED_PLATE_MEASURED.name})")
    measurements = load_measurements(args.measurements or COATED_PLATE_MEASURED, model)
    if args.shapes:
        from .measured_shapes import load_shapes

        measurements = load_shapes(args.shapes, model, measurements)
        _say(
            f"{len(measurements.shapes.shapes)} measured mode shapes: peaks are paired by their shapes (MAC)"
        )
    return model, measurements


def _progress(item) -> None:
    """An accepted iteration, or a line of text."""
    if isinstance(item, str):
        _say(f"  {item}")
    else:
        _say(
            f"  iteration {item.number:2d}: RMS error {100 * item.rms_rel_error:.5f} %, "
            f"largest relative change {item.step:.2e}"
        )


def run_predict(args) -> int:
    """First N elastic frequencies of every configuration."""
    from .predict import predict

    prediction = predict(_model(args), args.modes)
    print(to_json(prediction.to_dict()) if args.json else prediction.report())
    return 0


def run_shapes(args, guide) -> int:
    """A multi-point test: the modes found over the points, their shapes (SHAPES.csv); from
    a folder of hits per point (roving hammer) or from UFF files of FRFs per node."""
    from pathlib import Path

    from .recordings.readers import UFF_SUFFIXES, read_uff_points
    from .recordings.shapes import estimate_shapes, recordings_in_folders
    from .reporting.shape_plots import plot_measured_shapes

    if args.recordings and all(Path(r).suffix.lower() in UFF_SUFFIXES for r in args.recordings):
        measured = read_uff_points(args.recordings, args.points)
        for note in measured.notes:
            _say(f"note: {note}")
        recordings, points = measured.recordings_by_point, measured.points
    elif len(args.recordings) > 1:
        raise MeasurementError(
            "with --points give at most one folder: the one holding a sub-folder of hits per point "
            "(default: the points table's folder), or UFF files of FRFs per node"
        )
    else:
        recordings, points = recordings_in_folders(
            args.points, args.recordings[0] if args.recordings else None
        )
    band = None if args.band is None else tuple(args.band)
    result = estimate_shapes(recordings, points, args.configuration, args.sample_rate, band, guide)
    if args.out:
        result.write_peaks_csv(args.out)
        _say(f"peak list written to {args.out}")
    if args.shapes_out:
        result.write_csv(args.shapes_out)
        _say(f"mode shapes written to {args.shapes_out}")
    if args.report:
        with report_folder(args.report) as folder:
            write_text(folder / "shapes.txt", result.report())
            result.write_csv(folder / "shapes.csv")
            result.write_peaks_csv(folder / "peaks.csv")
            plot_measured_shapes(result, folder / "shapes.png")
        _say(f"report written to {args.report}/")
    print(to_json(result.to_dict()) if args.json else result.report())
    return 0 if len(result.modes) else 1


def run_peaks(args) -> int:
    """Modal peaks of one configuration from impact-test recordings: a peak-list CSV."""
    from .recordings.peaks import extract_peaks
    from .recordings.readers import is_multi_point_uff

    guide = None
    if args.spec is not None:
        from fem.spec import load_spec

        from .predict import predict

        model = load_spec(args.spec)
        if args.configuration not in [c.name for c in model.specimen.configurations]:
            model.specimen.configuration(args.configuration)  # the one-line error naming the known ones
        guide = predict(model).frequencies_hz[args.configuration]
        _say(
            f"guided by the predicted modes of '{args.configuration}': "
            f"{', '.join(f'{f:.1f}' for f in guide)} Hz"
        )
    if args.points or is_multi_point_uff(args.recordings):
        return run_shapes(args, guide)
    if args.shapes_out:
        raise MeasurementError(
            "--shapes-out needs a multi-point test: --points POINTS.csv with a folder of hits per "
            "point, or UFF files holding the FRFs of several nodes (these hold one point's)"
        )
    if not args.recordings:
        raise MeasurementError(
            "give the recordings (one file a hit), or --points POINTS.csv for a roving-hammer test"
        )
    band = None if args.band is None else tuple(args.band)
    result = extract_peaks(args.recordings, args.configuration, args.sample_rate, band, guide)
    if args.out:
        result.write_csv(args.out)
        _say(f"peak list written to {args.out}")
    if args.report:
        with report_folder(args.report) as folder:
            write_text(folder / "peaks.txt", result.report() + "\n")
            result.write_csv(folder / "peaks.csv")
            result.plot(folder)
        _say(f"report written to {args.report}/")
    print(to_json(result.to_dict()) if args.json else result.report())
    return 0 if len(result) else 1


def run_fit(args) -> int:
    """Identify the layer properties from measured frequencies of every configuration."""
    from .engine.ambiguity import MAX_REFITS, NEAR_MODES, ambiguous_pair_count
    from .fitting.driver import fit
    from .reporting.report import write_report

    if args.report:
        check_report_folder(args.report)  # refuse a bad --report before the fit, not after
    model, measurements = _model_and_measurements(args)
    if args.effect:
        _say(f"baseline fit, then with {', '.join(args.effect)} (parameters free):")
    else:
        _say(
            f"identifying {len(model.specimen.material_parameters())} parameters from {len(measurements)} "
            "frequencies"
        )
    pairs = ambiguous_pair_count(measurements.table, measurements.pinned)
    if pairs > MAX_REFITS:
        _say(
            f"{pairs} pairs of unlabelled modes lie within {100 * NEAR_MODES:g} % of each other: after the "
            "fit "
            f"converges, checking their pairing refits up to {MAX_REFITS} of them a round (minutes on a long "
            "mode "
            "list); a 'label' column for close modes makes it unnecessary"
        )
    options = None
    if args.use_shapes:
        if measurements.shapes is None:
            raise MeasurementError("--use-shapes needs the measured shapes: give --shapes SHAPES.csv")
        from .engine.updating import FitOptions

        options = FitOptions(use_shapes=True)
    result = fit(model, measurements, args.effect or (), options=options, progress=_progress, workers=None)
    if args.report:
        _say(f"report written to {write_report(result, args.report)}/")
    print(to_json(result.to_dict()) if args.json else result.report())
    damping_ok = result.damping is None or result.damping.converged
    return 0 if result.converged and damping_ok else 1


def run_compare(args) -> int:
    """Where the model fails: residuals per mode and the patterns that point at causes."""
    from .diagnosis.compare import compare
    from .reporting.plots import plot_comparison, plot_point_map
    from .reporting.report import AnalysisReport, write_analysis_report

    if args.report:
        check_report_folder(args.report)
    model, measurements = _model_and_measurements(args)
    comparison = compare(model, measurements, refit=not args.no_fit)
    text = comparison.report()
    if args.report:
        shown = comparison.fitted.model if comparison.fitted else model
        modes = int(comparison.table["mode"].max()) + 3
        report = AnalysisReport(
            title=f"Model against measurement: {model.name}",
            analysis="compare (identify-layers compare)",
            model=model,
            measurements=measurements,
            text=text,
            files={
                "comparison.txt": text,
                "comparison.csv": comparison.table.to_csv(index=False),
            },
            figures=[
                (
                    lambda path: plot_comparison(comparison, shown.with_options(modes=modes), path),
                    "residuals_with_shapes.png",
                    "error per measured mode with the paired mode shape above it",
                ),
                (
                    lambda path: plot_point_map(comparison, model, path),
                    "point_mass_map.png",
                    "share of the misfit a point mass would explain at each point",
                ),
            ],
            comparison=comparison,
        )
        write_analysis_report(args.report, report)
        _say(f"report written to {args.report}/")
    print(to_json(comparison.to_dict()) if args.json else text)
    return 0


def run_diagnose(args) -> int:
    """Find the effects the model misses (forward selection); exit 0 only when the data
    are then explained (at the noise level, or the refit with the selection converged)."""
    from .diagnosis.diagnose import diagnose
    from .reporting.plots import plot_before_after, plot_point_map
    from .reporting.report import AnalysisReport, write_analysis_report

    if args.report:
        check_report_folder(args.report)
    model, measurements = _model_and_measurements(args)
    kinds = args.effects.split(",") if args.effects else None
    result = diagnose(model, measurements, kinds, progress=_progress, workers=None)
    text = result.report()
    if args.report:
        figures = [
            (
                lambda path: plot_point_map(result.comparison, model, path),
                "point_mass_map.png",
                "share of the misfit a point mass would explain at each point",
            )
        ]
        if result.final is not None:
            chain = " + ".join(c.kind for c in result.selected)
            figures.insert(
                0,
                (
                    lambda path: plot_before_after(result.baseline, result.final, chain, path),
                    "before_after.png",
                    f"error per mode without and with {chain}",
                ),
            )
        report = AnalysisReport(
            title=f"Diagnosis: {model.name}",
            analysis="diagnose (identify-layers diagnose)",
            model=model,
            measurements=measurements,
            text=text,
            files={"diagnosis.txt": text, "diagnosis.json": to_json(result.to_dict())}
            | ({"refit.txt": result.final.report()} if result.final is not None else {}),
            figures=figures,
            comparison=result.comparison,
        )
        write_analysis_report(args.report, report)
        _say(f"report written to {args.report}/")
    print(to_json(result.to_dict()) if args.json else text)
    return 0 if result.explained else 1


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="identify-layers", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_version(parser)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("predict", help="elastic frequencies of every configuration in a spec")
    add_common_arguments(p)
    p.add_argument("--modes", type=int, help="elastic modes per configuration (default: [model] modes)")
    p.set_defaults(run=run_predict)
    p = sub.add_parser("peaks", help="modal peaks of one configuration from tap recordings")
    p.add_argument(
        "recordings",
        nargs="*",
        metavar="REC",
        help="impact-test recordings of one configuration: CSV (time_s, force, a response column), WAV, "
        "UFF58, MATLAB .mat or NI TDMS; several files are several hits (with --points: the folder "
        "holding one sub-folder of hits per point); UFF files with FRFs of several nodes (and their "
        "coordinates, data set 15 or 2411) are a multi-point test: the modes and their shapes",
    )
    p.add_argument(
        "--configuration", default="original", help="the configuration recorded (default: original)"
    )
    p.add_argument(
        "--sample-rate",
        type=float,
        metavar="HZ",
        help="for CSV or MAT files without a time_s column (e.g. integer ADC counts)",
    )
    p.add_argument(
        "--band", type=float, nargs=2, metavar=("LOW", "HIGH"), help="frequency band searched [Hz]"
    )
    p.add_argument("--spec", help="a spec: its predicted frequencies of the configuration guide the search")
    p.add_argument(
        "--out", metavar="CSV", help="write the peak list (configuration,frequency_hz,std_hz,damping_ratio)"
    )
    p.add_argument(
        "--points",
        metavar="CSV",
        help="a roving-hammer test: the hammer points (point, x_mm, y_mm), each point's hits in a sub-folder "
        "named after it; the modes found over the points and their shapes.  With multi-point UFF "
        "files: the nodes' coordinates (point = node number), replacing the files' geometry",
    )
    p.add_argument(
        "--shapes-out",
        metavar="CSV",
        help="with --points or multi-point UFF files: write the mode shapes "
        "(the SHAPES.csv of fit --shapes); --out writes the peak list "
        "they name",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output on stdout")
    p.add_argument(
        "--report", metavar="DIR", help="write a report folder (text, CSV, FRF and stabilisation plots)"
    )
    p.set_defaults(run=run_peaks)
    for name, run, text in (
        ("fit", run_fit, "identify the layer properties from measured frequencies"),
        ("compare", run_compare, "where the model fails: residual patterns and plots"),
        ("diagnose", run_diagnose, "which physical effect is the model missing?"),
    ):
        p = sub.add_parser(name, help=text)
        add_common_arguments(p)
        p.add_argument(
            "measurements", nargs="?", help="measured frequencies (CSV); default: the bundled example's"
        )
        p.add_argument("--report", metavar="DIR", help="write a report folder (text, JSON, CSV, plots)")
        p.add_argument(
            "--shapes",
            metavar="CSV",
            help="measured mode shapes "
            "(configuration, frequency_hz, x_mm, y_mm, amplitude[, amplitude_imag]): "
            "peaks are paired with model modes by MAC, and the report maps where the shapes disagree",
        )
        p.set_defaults(run=run)
        if name == "fit":
            p.add_argument(
                "--use-shapes",
                action="store_true",
                help="fit the measured shapes (--shapes) beside the frequencies: each point's amplitude a "
                "residual (separated modes; scatter 1 %% of the largest amplitude)",
            )
            p.add_argument(
                "--effect",
                action="append",
                metavar="KIND",
                help="switch an effect on with its parameters free (repeatable): " + ", ".join(BUILT_IN),
            )
        if name == "compare":
            p.add_argument(
                "--no-fit", action="store_true", help="compare at the spec's values, without fitting"
            )
        if name == "diagnose":
            p.add_argument(
                "--effects",
                metavar="K1,K2",
                help=f"only these candidate effects (default: all registered: {', '.join(BUILT_IN)})",
            )
    return parser


def main(argv=None) -> int:
    """Run a command; bad input becomes one line on stderr and exit status 2."""
    return run_cli(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
