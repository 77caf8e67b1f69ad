"""Numbers and units as a reader sees them in tables, the report and on ticks: rounded
to their precision (a mean to the decimal of its SD), no raw exponent ("2.9e+04"),
no "nan" (a dash, which the page's note explains), units typeset (mm², µm, ±).

Machine-read files (the CSVs, summary.json) keep their own rounding; this is for text
a person reads.
"""

from __future__ import annotations

import math
import re

DASH = "–"  # no value: the table's note says why
SD_SIGNIFICANT = 2  # an SD is known to about two digits
SIGNIFICANT = 3  # a measurement with no precision of its own
PLAIN_RANGE = (1e-3, 1e6)  # |x| written out in full inside this range
_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
_UNIT_POWER = re.compile(r"\^(-?\d+)")


def is_finite_number(x) -> bool:
    """Whether ``x`` is an int or float (not a bool) with a finite value."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def leading_decimal(x: float) -> int:
    """The power of ten of ``x``'s first significant digit (0 for 0)."""
    return 0 if x == 0 else math.floor(math.log10(abs(x)))


def with_decimals(x: float, decimals: int) -> str:
    """``x`` rounded to ``decimals`` places (negative: to tens, hundreds...), written
    out in full; "-0" written as "0"."""
    if decimals < 0:
        x = round(x, decimals)
    text = f"{x:.{max(decimals, 0)}f}"
    return text[1:] if re.fullmatch(r"-0\.?0*", text) else text


def number(x, significant: int = SIGNIFICANT) -> str:
    """``x`` to ``significant`` digits, written out in full within
    :data:`PLAIN_RANGE` and as ``1.23 × 10⁻⁷`` outside it; :data:`DASH` for no value."""
    if not is_finite_number(x):
        return DASH
    if isinstance(x, int) and abs(x) < PLAIN_RANGE[1]:
        return str(x)
    x = float(x)
    if x == 0:
        return "0"
    x = round(x, significant - 1 - leading_decimal(x))  # 9.996 -> 10.0
    power = leading_decimal(x)
    if PLAIN_RANGE[0] <= abs(x) < PLAIN_RANGE[1]:
        return with_decimals(x, significant - 1 - power)
    return f"{x / 10.0**power:.{significant - 1}f} × {power_of_ten(power)}"


def p_value(p) -> str:
    """A p-value as every table gives it: two significant digits ("0.10", "0.032"),
    :data:`DASH` for none."""
    return number(p, 2)


def decimals_of(x, significant: int = SIGNIFICANT) -> int:
    """How many decimals :func:`number` gives ``x`` (0 for numbers of ``significant``
    digits or more before the point): a group mean is then given no finer than its
    embryos' rows."""
    if not is_finite_number(x) or x == 0:
        return 0
    return max(significant - 1 - leading_decimal(float(x)), 0)


def power_of_ten(power: int) -> str:
    """``10⁻⁷`` for -7."""
    return f"10{str(power).translate(_SUPERSCRIPT)}"


def mean_sd(mean, sd, decimals: int | None = None) -> str:
    """``"mean ± SD"``: the SD to :data:`SD_SIGNIFICANT` digits and the mean to the
    same decimal (never finer than ``decimals``, a quantity's own rounding, when
    given); the mean alone (3 digits or ``decimals``) when the SD is not finite."""
    if not is_finite_number(mean):
        return DASH
    if not is_finite_number(sd):
        return with_decimals(mean, decimals) if decimals is not None else number(mean)
    places = (SD_SIGNIFICANT - 1 - leading_decimal(sd)) if sd > 0 else (decimals or 0)
    if decimals is not None:
        places = min(places, decimals)
    if places < 8 and max(abs(mean), sd) < PLAIN_RANGE[1]:
        return f"{with_decimals(mean, places)} ± {with_decimals(sd, places)}"
    scale = leading_decimal(mean if mean != 0 else sd)  # (1.234 ± 0.045) × 10⁻⁹
    places = max(SD_SIGNIFICANT - 1 - (leading_decimal(sd) - scale) if sd > 0 else 0, 0)
    return (
        f"({with_decimals(mean / 10.0**scale, places)} ± "
        f"{with_decimals(sd / 10.0**scale, places)}) × {power_of_ten(scale)}"
    )


def with_interval(value, half_width, decimals: int | None = None) -> str:
    """``"value (low–high)"``: a value and the interval ``value ± half_width`` in brackets
    (a 95 % band; ± in the same table is a group's SD), all to the half-width's
    :data:`SD_SIGNIFICANT` digits (never finer than ``decimals``); the value alone
    (:func:`mean_sd`'s rounding) without a finite half-width."""
    if not is_finite_number(value) or not is_finite_number(half_width):
        return mean_sd(value, float("nan"), decimals)
    places = (
        (SD_SIGNIFICANT - 1 - leading_decimal(half_width)) if half_width > 0 else (decimals or 0)
    )
    if decimals is not None:
        places = min(places, decimals)
    return (
        f"{with_decimals(value, places)} ({with_decimals(value - half_width, places)}–"
        f"{with_decimals(value + half_width, places)})"
    )


def label_unit(text: str) -> str:
    """A unit as an axis or colour bar names it: :func:`unit`, and "dimensionless" for
    a pure number ("1"), which a label never gives as "(1)"."""
    return "dimensionless" if text == "1" else unit(text)


def unit(text: str) -> str:
    """A unit typeset: ``mm^3`` -> ``mm³``, ``mm^2/ms`` -> ``mm²/ms``, ``um`` ->
    ``µm``, ``1/mm`` unchanged; "" for a pure number ("1")."""
    if text in ("", "1"):
        return ""
    text = re.sub(r"\bum\b", "µm", text)
    return _UNIT_POWER.sub(lambda m: m.group(1).translate(_SUPERSCRIPT), text)
