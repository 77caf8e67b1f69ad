"""Units in every message (issue 71, point 3): "perimeter 689 mm" was a µm value with an
mm unit. Every f-string of the package that writes a length unit after a number is read
here: the number must be in that unit by its name (``*_mm``, ``*_um``), be converted on
the spot (``1000 * x_mm`` for µm), or take its unit from the data (``{unit}``)."""

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "oftimg"
LENGTH_UNITS = {"mm": "mm", "µm": "um", "um": "um"}


def templates():
    """(file:line, expression source, unit) for each formatted value followed by a
    length unit in a literal part of an f-string."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        source = path.read_text()
        for node in ast.walk(ast.parse(source)):
            if not isinstance(node, ast.JoinedStr):
                continue
            parts = node.values
            for value, after in zip(parts, parts[1:]):
                if not (isinstance(value, ast.FormattedValue) and isinstance(after, ast.Constant)):
                    continue
                word = after.value.lstrip(" ").split(" ")[0].split(")")[0].rstrip(",;:")
                unit = word.split("²")[0].split("/")[0].split("^")[0]
                if unit in LENGTH_UNITS:
                    found.append(
                        (
                            f"{path.relative_to(PACKAGE)}:{node.lineno}",
                            ast.get_source_segment(source, value.value),
                            unit,
                        )
                    )
    return found


def in_its_unit(expression: str, unit: str) -> bool:
    """The expression's number is in ``unit`` by its name (``inlet_mm``, ``speed_mm_s``,
    ``VOXEL_MM_RANGE``, ``area_um2``) or an explicit conversion."""
    name = LENGTH_UNITS[unit]
    if name == "um" and re.search(r"\b(1000|1e3) \*|\* (1000|1e3)\b", expression):
        return True  # mm converted on the spot
    return re.search(rf"(\b|_){name}(\d|_|\b)", expression, re.IGNORECASE) is not None


@pytest.mark.parametrize("where, expression, unit", templates())
def test_each_length_in_a_message_is_in_the_unit_it_names(where, expression, unit):
    assert in_its_unit(expression, unit), f"{where}: {{{expression}}} {unit}"


def test_the_scan_sees_the_templates():
    """The perimeter's template (in the dataset's unit now) and a few in mm are found."""
    units = {unit for _, _, unit in templates()}
    assert len(templates()) >= 8 and {"mm", "µm"} <= units
