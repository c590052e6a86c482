"""A soft bond line: when the thin-plate model is not enough, and the layerwise one is.

A 5 mm cross-ply laminate (carbon 0 / glass 90 / carbon 0) with a 2 mm aluminium plate
bonded under it on a soft 0.1 mm bond line (E = 1 GPa). Its first ten flexural
frequencies were computed in 3-D elasticity (CalculiX, 20-node hexahedra, converged to
1e-5; stored with the test data in `tests/data/solid3d/`). Three plate models of the
tool predict them from the true properties:

- the Kirchhoff plate (the paper's model): no transverse shear, far too stiff here;
- the Mindlin plate (`[[effects]] kind = "thick_plate"`): shear, but one rotation for the
  whole stack, so the bond line cannot shear on its own;
- the layerwise plate (`[model] theory = "layerwise"`): every soft layer shears on its
  own.

    .venv/bin/python docs/examples/soft_bond_line.py
"""

import json
import tempfile
from pathlib import Path

import numpy as np

import identify

REFERENCE = Path(__file__).resolve().parents[2] / "tests" / "data" / "solid3d" / "laminate_on_adhesive.json"
CONFIGURATION = "al_bottom"
MODES = 10
MODELS = {
    "Kirchhoff": "",
    "Mindlin (thick_plate)": '\n[[effects]]\nkind = "thick_plate"\n',
    "layerwise": None,
}


def reference() -> tuple[str, np.ndarray]:
    """The spec with the true properties, and the 3-D flexural frequencies [Hz]."""
    data = json.loads(REFERENCE.read_text())
    configuration = next(c for c in data["configurations"] if c["name"] == CONFIGURATION)
    flexural = [m["frequency_hz"] for m in configuration["modes"] if m["classification"] == "flexural"]
    return data["spec_toml"], np.array(flexural[:MODES])


def main() -> dict[str, float]:
    spec, solid = reference()
    folder = Path(tempfile.mkdtemp())
    worst = {}
    for name, extra in MODELS.items():
        text = spec.replace("[model]\n", '[model]\ntheory = "layerwise"\n') if extra is None else spec + extra
        path = folder / "plate.toml"
        path.write_text(text)
        predicted = identify.predict(identify.load_spec(path)).frequencies_hz[CONFIGURATION][:MODES]
        error = predicted / solid - 1
        worst[name] = float(np.abs(error).max())
        print(
            f"{name:22s} largest error against 3-D elasticity, first {MODES} modes: {100 * worst[name]:7.3f} "
            "%"
        )
    return worst


if __name__ == "__main__":
    main()
