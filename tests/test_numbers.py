"""Numbers and units as a reader sees them (oftimg.output.numbers)."""

import math

import pytest

from oftimg.output.numbers import DASH, mean_sd, number, unit


@pytest.mark.parametrize(
    "x, text",
    [
        (24.568, "24.6"),
        (6.493, "6.49"),
        (0.02789, "0.0279"),
        (-29508.0, "-29500"),
        (9.996, "10.0"),
        (0.0, "0"),
        (12, "12"),
        (999999.9, "1.00 × 10⁶"),
        (1.23e-7, "1.23 × 10⁻⁷"),
        (-0.0001, "-1.00 × 10⁻⁴"),
        (-0.0004, "-4.00 × 10⁻⁴"),
        (float("nan"), DASH),
        (math.inf, DASH),
        (None, DASH),
        (True, DASH),
    ],
)
def test_a_number_has_three_digits_and_never_a_raw_exponent_or_nan(x, text):
    assert number(x) == text


@pytest.mark.parametrize(
    "mean, sd, decimals, text",
    [
        (8.2715, 1.266, None, "8.3 ± 1.3"),  # the demo's "8.2715 ± 1.266"
        (0.02585, 0.003446, None, "0.0259 ± 0.0034"),
        (12.7, 2.9791, None, "12.7 ± 3.0"),
        (47.68, 0.6213, 2, "47.68 ± 0.62"),  # the column's own 2 decimals
        (364.2, 8.3, 0, "364 ± 8"),  # never finer than the column
        (0.91, 0.0173, 2, "0.91 ± 0.02"),
        (-9875.3, 17002.0, None, "-10000 ± 17000"),
        (1.234e-9, 4.5e-11, None, "(1.234 ± 0.045) × 10⁻⁹"),
        (3.0, float("nan"), None, "3.00"),
        (float("nan"), 1.0, None, DASH),
    ],
)
def test_a_mean_is_given_to_the_decimal_of_its_sd(mean, sd, decimals, text):
    assert mean_sd(mean, sd, decimals) == text


def test_units_are_typeset():
    assert [unit(u) for u in ("mm^3", "mm^2/ms", "um", "1/mm", "mm^-1", "1", "mm/s")] == [
        "mm³",
        "mm²/ms",
        "µm",
        "1/mm",
        "mm⁻¹",
        "",
        "mm/s",
    ]
