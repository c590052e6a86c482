"""Rounding a value to its uncertainty (GUM 7.2.6: the std to at most two significant
digits, the value to the same decimal), per cent, and one status line."""

import math

import pytest

from identify.reporting.rounding import percent, status_line, with_std


@pytest.mark.parametrize(
    "value, std, unit, expected",
    [
        (67.8287, 1.15955, "GPa", "67.8 ± 1.2 GPa (1.7 %)"),
        (0.310937, 0.0084567, "", "0.3109 ± 0.0085 (2.7 %)"),
        (201.09, 0.99, "GPa", "201.09 ± 0.99 GPa (0.49 %)"),  # 0.99 stays 2 digits
        (12345.6, 234.5, "N/m", "12350 ± 230 N/m (1.9 %)"),  # std above 10: tens
        (-3.14159, 0.0271, "deg", "-3.142 ± 0.027 deg (0.86 %)"),
        (1e-10, 0.2, "", "0.00 ± 0.20"),  # reads as zero: no relative std
        (0.0, 0.2, "", "0.00 ± 0.20"),
        (0.004, 0.2, "", "0.00 ± 0.20"),
        (0.006, 0.2, "", "0.01 ± 0.20 (3300 %)"),
    ],
)
def test_value_rounded_to_two_digits_of_its_std(value, std, unit, expected):
    assert with_std(value, std, unit) == expected


def test_without_a_std_the_value_says_so():
    assert with_std(67.8287, math.nan, "GPa") == "67.83 ± n/a GPa"
    assert with_std(math.nan, 1.0) == "n/a"


def test_percent_and_status_line():
    assert percent(0.0170953) == "1.7 %" and percent(-4.1873e-05, 3) == "-0.00419 %" and percent(0) == "0 %"
    assert status_line("converged", "converged: the step is small") == "converged: the step is small"
    assert status_line("poor_fit", "poor fit: misfit 40x") == "poor fit: misfit 40x"
    assert status_line("not_converged", "stopped: no step") == "not converged: stopped: no step"
