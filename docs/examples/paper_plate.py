"""The paper's coated plate: twelve layer properties from three configurations.

A 150 x 150 x 1.1 mm steel sheet coated on both faces (the seed paper's virtual test
plate) is measured as delivered, with a 1 mm brass plate bonded under it, and over it.
One plate alone cannot tell the layers apart (its sensitivity matrix is singular); the
three configurations together can. This is the bundled example: the spec starts from
the paper's Table 6 values, the measurement is a virtual one of the Table 1 plate with
0.05 % scatter.

    .venv/bin/python docs/examples/paper_plate.py
"""

import designer
import identify
from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED


def main() -> identify.FitResult:
    model = identify.load_spec(COATED_PLATE)
    # Before testing: can these three configurations be identified? (paper section 4.6)
    three = designer.check(model).to_dict()
    print(f"three configurations: condition number {three['condition_number']:.1f} ({three['verdict']})")
    original = model.specimen.configurations[:1]
    one = designer.check(model.with_options(modes=15).with_configurations(original)).to_dict()
    print(
        f"the original plate alone, 15 modes: condition number {one['condition_number']:.3g} "
        f"({one['verdict']})"
    )

    data = identify.load_measurements(COATED_PLATE_MEASURED, model)
    result = identify.fit(model, data)
    print(result.report())
    return result


if __name__ == "__main__":
    main()
