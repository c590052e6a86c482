#!/usr/bin/env python3
"""Does the theory's error, taken as independent per mode, cover what it does to the
properties?  ``theory_accuracy.json`` holds the layerwise theory's error against 3-D
elasticity per mode; on each development case without a sensor this script propagates
that very error vector delta through the linear fit at the true values, with the
parameters a diagnosis frees there (the layer properties, the plies' G13 and G23, their
angles where the case misaligns them): the property shift -G delta (G = J^+, weighted by
the case's scatter) in units of the theory's std (``SHEAR_THEORY_STD_REL``, independent
per mode: the budget's ``theory vs 3-D`` column) and of the measurements' std.  Where the
independent std is honest the first ratio scatters like N(0, 1) or tighter.  Writes
``theory_independence.json``.

    python tests/data/solid3d/theory_independence.py [--out theory_independence.json]

About 5 minutes on one core.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[2]))

from fem.model import SHEAR_THEORY_STD_REL  # noqa: E402
from fem.specimen import Parameter  # noqa: E402
from identify.engine.objective import Objective  # noqa: E402
from studies import blind_diagnosis as bd  # noqa: E402


def freed(case: dict, model) -> list[Parameter]:
    """The parameters a diagnosis frees on the case's true layerwise model."""
    base = list(model.specimen.material_parameters())
    plies = sorted({layer.material.name for layer in model.specimen.layers} - bd._without_axes(case))
    shear = [Parameter(k, m) for m in plies for k in ("G13", "G23") if Parameter(k, m) not in base]
    misaligned = case["choices"]["misalignment_max_deg"] > 0
    angles = [
        Parameter("angle", layer.label)
        for layer in model.specimen.layers
        if misaligned and layer.material.name in plies
    ]
    return base + shear + angles


def case_shifts(name: str, errors_pct: list[float]) -> dict:
    """Per scored property: (shift / theory std, shift / measurement std)."""
    case, _, data = bd.case_start(name)
    model = bd.truth_model(case, "layerwise")
    wanted = bd._wanted(case, bd.truth_model(case))
    parameters = freed(case, model)
    objective = Objective(model, data, parameters)
    e = objective.evaluate(np.array([model.value(p) for p in parameters]), None)
    sigma = objective.sigma
    f3d = np.array([m["frequency_hz"] for c in case["configurations"] for m in c["modes"]])
    delta = np.asarray(errors_pct) / 100 * f3d
    gain = np.linalg.pinv(e.derivatives / sigma[:, None])
    shift = -gain @ (delta / sigma)
    measurement = np.sqrt(np.einsum("ij,ij->i", gain, gain))
    theory = np.sqrt(np.einsum("ij,ij->i", gain * ((SHEAR_THEORY_STD_REL * f3d / sigma) ** 2)[None, :], gain))
    return {
        p.name: [round(float(shift[i] / theory[i]), 3), round(float(shift[i] / measurement[i]), 3)]
        for i, p in enumerate(parameters)
        if p in wanted
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE / "theory_independence.json")
    args = parser.parse_args(argv)
    record = json.loads((HERE / "theory_accuracy.json").read_text())
    cases = {}
    for name, c in record["cases"].items():
        if not c["sensor"]:
            cases[name] = case_shifts(name, c["layerwise"]["errors_pct"])
            print(name, cases[name], flush=True)
    z = np.array([v[0] for c in cases.values() for v in c.values()])
    summary = {
        "properties": int(z.size),
        "rms_in_theory_std": round(float(np.sqrt(np.mean(z**2))), 3),
        "share_beyond_2": round(float(np.mean(np.abs(z) > 2)), 4),
        "max_abs": round(float(np.abs(z).max()), 3),
    }
    out = {
        "what": "per development case without a sensor and scored property: the linear shift the layerwise "
        "theory's own per-mode error causes, [in theory std (independent per mode), in measurement std]",
        "theory_std_rel": SHEAR_THEORY_STD_REL,
        "summary": summary,
        "cases": cases,
    }
    args.out.write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
