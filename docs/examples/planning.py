"""Planning a test: which plates to bond where, and the sheet the lab works from.

Before anything is bonded, `plan-tests` tells whether a set of configurations can tell
the layers apart: the condition number of the global relative sensitivity matrix (the
paper's criterion: good below 1e3, singular above 1e7) and the standard deviation each
property would have at the expected scatter of a measured frequency. `recommend`
searches the `[design]` table's space of added plates (materials, thicknesses, top or
bottom) for the best set; `check` then gives the test sheet: where to support the plate,
where to tap, where to put the sensor, and the frequencies to expect.

    .venv/bin/python docs/examples/planning.py
"""

import designer
import identify
from identify.examples import COATED_PLATE


def main() -> dict:
    model = identify.load_spec(COATED_PLATE)
    recommendation = designer.recommend(model)
    print(recommendation.report())

    check = designer.check(model)  # the spec's own three configurations
    print(check.report())
    sheet = check.to_dict()
    for entry in sheet["test_sheet"]:
        print(
            f"{entry['configuration']}: sensor at {entry['sensor_point_mm']} mm, tap at "
            f"{entry['excitation_point_mm']} mm, supports at {entry['support_points_mm']} mm"
        )
    return sheet


if __name__ == "__main__":
    main()
