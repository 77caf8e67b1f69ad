"""One unit per quantity wherever a person or a table reads it: the cohort tables, the
pages, the figures and the videos (issue 87: thickness had been µm on pages and
figures and mm in cohort.csv, area rates µm²/ms and mm²/ms, volume changes % and
fractions).

The house's units (CONVENTIONS: lengths mm, areas mm², times ms, speeds mm/s; shares of
the cycle, changes and thickenings as %). summary.json and arrays.npz keep their own
values (fractions, mm), their unit in their names; :func:`shown` says how each kind of
quantity is written for a reader, and every writer asks it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Shown:
    """How a kind of quantity is shown: its ``unit`` (as :func:`oftimg.output.numbers.unit`
    typesets it) and the ``scale`` from summary.json's or arrays.npz's value to it."""

    unit: str
    scale: float = 1.0


THICKNESS = Shown("mm")  # a wall's or the jelly's (arrays: *_thickness_mm)
THICKENING = Shown("%", 100.0)  # largest over smallest minus 1 (a fraction stored)
VOLUME_CHANGE = Shown("%", 100.0)  # (largest - smallest) / smallest
SHARE_OF_CYCLE = Shown("%", 100.0)  # expansion, contraction, time expanded
AREA_RATE = Shown("mm^2/ms")  # the area map's time derivative
DISPLACEMENT = Shown("mm")  # a node's or a point's
KINDS = {
    "thickness": THICKNESS,
    "thickening": THICKENING,
    "volume_change": VOLUME_CHANGE,
    "share_of_cycle": SHARE_OF_CYCLE,
    "area_rate": AREA_RATE,
    "displacement": DISPLACEMENT,
}


def kind_of(key: str) -> str | None:
    """The kind of quantity a summary.json or arrays.npz key holds (a key of
    :data:`KINDS`), from its name; None for a quantity with a unit of its own."""
    if "thickening" in key:
        return "thickening"
    if "thickness" in key:
        return "thickness"
    if key.endswith("volume_change"):
        return "volume_change"
    if key in ("expand_fraction", "contract_fraction") or key.startswith("expanded_fraction"):
        return "share_of_cycle"
    if "rate_mm2_ms" in key:
        return "area_rate"
    if "displacement" in key:
        return "displacement"
    return None


def shown(key: str) -> Shown | None:
    """How the quantity under summary.json's or arrays.npz's ``key`` is shown everywhere
    (:data:`KINDS`), or None when it has no kind here (its own unit, as named)."""
    kind = kind_of(key)
    return None if kind is None else KINDS[kind]


def label(what: str, kind: str) -> str:
    """An axis's, colour bar's or column's text: ``what`` and the kind's unit in brackets,
    typeset ("wall thickness (mm)")."""
    from .numbers import unit

    return f"{what} ({unit(KINDS[kind].unit)})"
