"""Each layer's loss factor from the modal damping of the paper's three configurations,
and the Oberst beam (ASTM E756) as an independent check.

1. The paper's plate (section 2.2, Table 1 stiffness) with damping coatings: 3
   configurations, 10 modes, 0.05 % frequency scatter and 3 % damping scatter, the
   truth's damping ratios from the complex eigenproblem.  Stiffness and the nine loss
   factors of the three layers are identified; each must lie within 3 reported std of
   the truth.  Over many noisy repeats of the damping step the reported std is compared
   with the observed scatter.
2. The Oberst beam: a steel strip with one isotropic coating (free layer).  Its modal
   loss factors (complex eigenproblem of the plate model) give the coating's loss factor
   by ASTM E756's closed form (Euler-Bernoulli beams, base undamped) and by this tool;
   both are compared with the truth.

    python -m studies.damping [--out DIR] [--repeats N]
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from fem.laminates.laminate import Layer
from fem.laminates.material import Material
from fem.model import ModelOptions, SpecimenModel
from fem.solver.complex_modes import complex_loss_factors
from fem.solver.damping import ratio_from_loss
from fem.specimen import Configuration, Specimen
from identify.fitting.damping import identify_damping
from identify.fitting.driver import fit
from identify.measurements import Measurements
from identify.recordings.synthetic import AlsoMeasured, synthetic_measurements

from .common import report_folder, start_model, true_model, write_text

MODES = 10
FREQUENCY_STD_REL = 5e-4
DAMPING_STD_REL = 0.03
#: The coatings' and the steel's true loss factors (eta_E1, eta_E2, eta_G12): a polymer-
#: filled damping coating each side (three loss factors each), the steel nearly elastic
#: and, a metal, with one loss factor for all its moduli (identified as ``eta``).
TRUE_LOSS = {
    "bottom_coating": (0.03, 0.04, 0.05),
    "steel": (0.002, 0.002, 0.002),
    "top_coating": (0.02, 0.025, 0.04),
}
IDENTIFIED = {
    "bottom_coating": ("eta_E1", "eta_E2", "eta_G12"),
    "steel": ("eta",),
    "top_coating": ("eta_E1", "eta_E2", "eta_G12"),
}
#: The known materials' loss factors (handbook: brass ~1e-3, a structural epoxy ~0.05-0.1).
KNOWN_LOSS = {"brass": 0.001, "adhesive": 0.1}


def _with_losses(model: SpecimenModel, identify: bool) -> SpecimenModel:
    materials = model.specimen.materials
    changed = [
        replace(
            materials[n],
            eta_E1=None if identify else a,
            eta_E2=None if identify else b,
            eta_G12=None if identify else c,
            identify_damping=IDENTIFIED[n] if identify else (),
        )
        for n, (a, b, c) in TRUE_LOSS.items()
    ]
    changed += [replace(materials[n], eta_E1=eta, eta_E2=eta, eta_G12=eta) for n, eta in KNOWN_LOSS.items()]
    return model.with_specimen(model.specimen.with_materials(changed)).with_options(modes=MODES)


def truth() -> SpecimenModel:
    """The paper's plate with Table 1's stiffness and ``TRUE_LOSS``."""
    return _with_losses(true_model(), identify=False)


def start() -> SpecimenModel:
    """The bundled example (Table 6 start values) asking for the three layers' loss factors."""
    return _with_losses(start_model(), identify=True)


def simulate(seed: int) -> Measurements:
    """10 modes of each configuration with 0.05 % frequency and 3 % damping scatter."""
    return synthetic_measurements(
        truth(),
        modes=MODES,
        noise_rel=FREQUENCY_STD_REL,
        seed=seed,
        also=AlsoMeasured(damping_std_rel=DAMPING_STD_REL),
    )


def true_values(targets) -> np.ndarray:
    return np.array(
        [TRUE_LOSS[m][("eta_E1", "eta_E2", "eta_G12").index(k) if k != "eta" else 0] for m, k in targets]
    )


@dataclass(frozen=True)
class Repeats:
    """The damping step repeated on fresh damping noise at one stiffness fit."""

    targets: tuple
    observed_std: np.ndarray
    reported_std: np.ndarray
    mean_error: np.ndarray  # mean (value - truth) / reported std
    statuses: dict
    draws: int

    @property
    def ratio(self) -> np.ndarray:
        return self.reported_std / self.observed_std


def repeats(result, draws: int, seed: int = 11) -> Repeats:
    """``draws`` fresh 3 % damping draws on the truth's damping ratios, each identified at
    the fitted stiffness and pairing of ``result``."""
    base = result.measurements.table
    exact = {c: ratio_from_loss(complex_loss_factors(truth(), c)) for c in base["configuration"].unique()}
    zeta = np.array([exact[c][m - 1] for c, m in zip(base["configuration"], base["mode"])])
    rng = np.random.default_rng(seed)
    values, stds, statuses = [], [], {}
    for _ in range(draws):
        table = base.assign(
            damping_ratio=zeta * (1 + DAMPING_STD_REL * rng.standard_normal(len(zeta))),
            damping_std=DAMPING_STD_REL * zeta,
        )
        d = identify_damping(result.model, Measurements(table, "<repeat>"), result.pairings)
        values.append(d.values), stds.append(d.std)
        statuses[d.status] = statuses.get(d.status, 0) + 1
    values, stds = np.array(values), np.array(stds)
    truth_values = true_values(d.targets)
    return Repeats(
        d.targets,
        values.std(axis=0, ddof=1),
        stds.mean(axis=0),
        ((values - truth_values) / stds).mean(axis=0),
        statuses,
        draws,
    )


# ---------------------------------------------------------------------------- tap chain
@dataclass(frozen=True)
class TapChain:
    peaks: pd.DataFrame  # the peak lists the recordings gave (with damping_ratio, damping_std)
    result: object  # the fit (its ``damping`` the loss factors)
    z: np.ndarray  # (identified - true) / std per loss factor


def tap_chain(folder, seed: int = 1, hits: int = 5) -> TapChain:
    """Simulated recordings of the truth (its modal damping from the complex eigenproblem,
    a 3 g accelerometer, hit-to-hit scatter and noise as ``studies.tap_test``) -> peaks ->
    fit of the peak lists (no mode numbers) -> the layers' loss factors."""
    from fem.solver.attachments import PointMass
    from fem.solver.mode_shapes import deflection_operator
    from identify.recordings.peaks import extract_peaks
    from identify.recordings.tap_simulation import Modes, Session

    from .tap_test import EXCITATION, SENSOR, SENSOR_MASS

    sensor = [PointMass(SENSOR_MASS, *SENSOR, "accelerometer")]
    model = truth().with_attachments(sensor)
    lists = []
    for k, c in enumerate(model.specimen.configurations):
        solution = model.solve(c.name)
        points = deflection_operator(solution.units, [EXCITATION[0], SENSOR[0]], [EXCITATION[1], SENSOR[1]])
        w = points @ solution.modes.shapes
        zeta = ratio_from_loss(complex_loss_factors(model, c.name))
        session = Session(Modes(solution.frequencies_hz, zeta, w[0] * w[1]), n_hits=hits, seed=seed + k)
        peaks = extract_peaks(session.hits(), c.name)
        lists.append(
            peaks.to_frame()[["configuration", "frequency_hz", "std_hz", "damping_ratio", "damping_std"]]
        )
    peak_list = pd.concat(lists, ignore_index=True)
    write_text(folder / "tap_chain_peaks.csv", peak_list.to_csv(index=False))
    begin = start().with_attachments(sensor)
    from identify.measurements import parse_measurements

    result = fit(begin, parse_measurements(peak_list, begin, "tap_chain_peaks.csv"))
    d = result.damping
    return TapChain(peak_list, result, (d.values - true_values(d.targets)) / d.std)


# ---------------------------------------------------------------------------- Oberst beam
#: Strip and coating of the Oberst comparison: a 1 mm steel strip 180 x 15 mm with a
#: 0.5 mm stiff polymer coating on one face (the E756 free-layer case).
STRIP = {"length": 0.18, "width": 0.015, "base": 1.0e-3, "coating": 0.5e-3}
BASE = Material("steel", 200e9, 200e9, 200e9 / 2.6, 0.3, 7850.0, eta_E1=0.0, eta_E2=0.0, eta_G12=0.0)
COATING = Material(
    "coating",
    10e9,
    10e9,
    10e9 / 2.6,
    0.3,
    1500.0,
    eta_E1=0.3,
    eta_E2=0.3,
    eta_G12=0.3,
    identify_damping=("eta",),
)


def oberst_closed_form(composite_loss: np.ndarray) -> np.ndarray:
    """ASTM E756-05 eq. (the free-layer, one-side coated beam): the coating's loss factor
    from the composite beam's modal loss factor, base undamped, Euler-Bernoulli beams:
    eta2 = eta_c (1 + MT)(1 + 4MT + 6MT^2 + 4MT^3 + M^2T^4) / (MT (3 + 6T + 4T^2 + 2MT^3 + M^2T^4)),
    M = E2 / E1, T = H2 / H1."""
    m, t = COATING.E1 / BASE.E1, STRIP["coating"] / STRIP["base"]
    return (
        composite_loss
        * (1 + m * t)
        * (1 + 4 * m * t + 6 * m * t**2 + 4 * m * t**3 + m**2 * t**4)
        / (m * t * (3 + 6 * t + 4 * t**2 + 2 * m * t**3 + m**2 * t**4))
    )


@dataclass(frozen=True)
class Oberst:
    composite_loss: np.ndarray  # the strip's bending modes' loss factors (complex eigenproblem)
    closed_form: np.ndarray  # the coating's eta by E756, per mode
    tool: float  # the coating's eta identified by this tool
    tool_std: float
    truth: float


def oberst(modes: int = 3) -> Oberst:
    """The strip's lowest ``modes`` (bending) modes: composite loss factors from the complex
    eigenproblem, then the coating's loss factor by E756 and by ``identify_damping`` (3 %
    damping std stated, no noise added)."""
    layers = (Layer(BASE, STRIP["base"], 0.0, "layer1"), Layer(COATING, STRIP["coating"], 0.0, "layer2"))
    specimen = Specimen("Oberst strip", STRIP["length"], STRIP["width"], layers, (Configuration("original"),))
    model = SpecimenModel(specimen, ModelOptions(modes=modes))
    composite = complex_loss_factors(model, "original")
    zeta = ratio_from_loss(composite)
    table = pd.DataFrame(
        {
            "configuration": "original",
            "mode": np.arange(1, modes + 1),
            "frequency_hz": model.solve("original").frequencies_hz,
            "std_hz": np.nan,
            "label": "",
            "damping_ratio": zeta,
            "damping_std": DAMPING_STD_REL * zeta,
        }
    )
    d = identify_damping(model, Measurements(table, "<Oberst strip>"))
    return Oberst(
        composite, oberst_closed_form(composite), float(d.values[0]), float(d.std[0]), COATING.eta_E1
    )


def run(out=None, draws: int = 50) -> dict:
    """The whole study: one identification, the repeats and the Oberst beam; a report."""
    measured = simulate(seed=3)
    result = fit(start(), measured)
    d = result.damping
    truth_values = true_values(d.targets)
    z = (d.values - truth_values) / d.std
    rep = repeats(result, draws)
    strip = oberst()
    folder = report_folder("damping", out)
    chain = tap_chain(folder)
    lines = [
        "Layer loss factors of the paper's plate (3 configurations x 10 modes, 0.05 % / 3 % scatter)",
        f"stiffness fit: {result.status.value}; damping: {d.status} ({d.method}), condition number "
        f"{d.condition_number:.3g} ({d.verdict}), chi^2 {d.chi2:.3g} for {d.dof}",
        "",
        f"{'loss factor':28s} {'truth':>8s} {'identified':>11s} {'std':>9s} {'(id-truth)/std':>15s} "
        f"{'std ratio':>10s}",
    ]
    for (m, k), t, v, s, zz, r in zip(d.targets, truth_values, d.values, d.std, z, rep.ratio):
        lines.append(f"{m + '.' + k:28s} {t:8.4f} {v:11.4f} {s:9.4f} {zz:15.2f} {r:10.2f}")
    lines += [
        "",
        f"std ratio: mean reported std / observed scatter over {draws} damping draws "
        f"(statuses {rep.statuses})",
        "",
        "Oberst beam (steel 1 mm + 0.5 mm coating, E2/E1 = 0.05, coating eta 0.3)",
        f"  composite loss factors of modes 1-3: {np.array2string(strip.composite_loss, precision=5)}",
        f"  ASTM E756 coating eta per mode:      {np.array2string(strip.closed_form, precision=4)}",
        f"  this tool:                           {strip.tool:.4f} +- {strip.tool_std:.4f}",
        f"  truth:                               {strip.truth:.4f}",
        "",
        "Tap chain: simulated recordings (5 hits per configuration, 3 g accelerometer) -> peaks -> fit",
        f"  peaks found: {len(chain.peaks)}; stiffness {chain.result.status.value}; damping "
        f"{chain.result.damping.status}; (identified - true) / std of the loss factors: "
        f"{np.array2string(chain.z, precision=2)}",
    ]
    text = "\n".join(lines) + "\n"
    write_text(folder / "summary.txt", text)
    print(text)
    return {"result": result, "z": z, "repeats": rep, "oberst": strip, "tap_chain": chain}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--out", help="report folder (default reports/damping)")
    parser.add_argument("--repeats", type=int, default=50, help="damping draws for the std check")
    args = parser.parse_args(argv)
    run(args.out, args.repeats)


if __name__ == "__main__":
    main()
