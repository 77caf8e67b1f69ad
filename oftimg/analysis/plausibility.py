"""Results checked for sense before anything is written: what no living tube can give
(walls that coincide or cross, a wall thinner than a micrometre, a frame's volume an
order of magnitude off the others') stops the run with one line that says what is
implausible and which input most likely causes it. What is unusual but possible stays
a warning (:func:`~oftimg.analysis.pipeline.analyse_dataset`'s).
"""

from __future__ import annotations

import numpy as np

CROSSING_SHARE = 0.05  # of the grid nodes: a wall outside the one around it beyond it
CROSSING_DEPTH = 0.5  # outside by this share of the layer's median thickness, or more
MIN_WALL_MM = 1e-3  # a wall thinner than a micrometre: one surface given twice
VOLUME_JUMP = 10.0  # a frame's outer volume this many times the frames' median
NESTED = (("outer", "inner"), ("inner", "lumen"), ("outer", "lumen"))
LAYER = {"inner": "myocardium", "lumen": "cardiac jelly"}


def implausible(volumes: dict, thickness: dict, *, frame_names=None) -> list[str]:
    """What cannot be right in one dataset's stacked per-frame results, in words that
    name the likely cause ([] when nothing).

    ``volumes``: wall -> ``(n_t,)`` mm³ enclosed; ``thickness``: ``inner`` -> the
    myocardium's signed thickness ``(n_u, n_v, n_t)`` mm (outer grid node to its inner
    one, negative where the inner wall lies outside the outer), ``lumen`` -> the
    cardiac jelly's (inner node to the lumen), for the walls the dataset has;
    ``frame_names``: each frame's file name, for the message. A wall counts as
    crossing the one around it where it lies outside it by :data:`CROSSING_DEPTH` of
    the layer's median thickness or more: a segmentation of a layer thinner than its
    voxels leaves the two walls touching, each a little outside the other here and
    there (the zoo's coarse draws: 16 % of the nodes by a fraction of a voxel), which
    is no swap.
    """
    problems = []
    walls = [w for w in ("outer", "inner", "lumen") if w in volumes]
    n_t = len(volumes["outer"])
    names = frame_names or [f"frame {t}" for t in range(n_t)]
    for wall, around in (("inner", "outer"), ("lumen", "inner")):
        if wall not in thickness:
            continue
        d = np.asarray(thickness[wall], float)
        typical = float(np.nanmedian(np.abs(d)))
        share = float(np.nanmean(d < -CROSSING_DEPTH * typical))
        if share > CROSSING_SHARE:
            problems.append(
                f"the {wall} wall lies outside the {around} one at {share:.0%} of "
                f"the grid nodes, by half the {LAYER[wall]}'s median thickness or "
                f"more (at most {CROSSING_SHARE:.0%} can be a segmentation's slip): "
                f"are {wall}/ and {around}/ swapped, or the label values "
                '(meta.json "labels") wrong?'
            )
    for around, wall in NESTED:
        if (
            around not in walls
            or wall not in walls
            or (around, wall) == ("outer", "lumen")
            and "inner" in walls
        ):
            continue
        larger = int(np.count_nonzero(volumes[wall] >= volumes[around]))
        if larger > n_t / 2:
            problems.append(
                f"the {wall} wall encloses as much as the {around} one or more in "
                f"{larger} of {n_t} frames: are {wall}/ and {around}/ swapped, or "
                "one surface given as both?"
            )
    if "inner" in thickness:
        gap_mm = float(np.nanmedian(np.abs(thickness["inner"])))
        if gap_mm < MIN_WALL_MM:
            problems.append(
                f"the outer and inner walls lie {1e6 * gap_mm:.3g} nm apart (the "
                f"median over the grid nodes; no myocardium is thinner than "
                f"{1000 * MIN_WALL_MM:g} µm): one surface given as both, or the "
                'label values (meta.json "labels") wrong?'
            )
    v = np.asarray(volumes["outer"], float)
    if np.any(v <= 0):
        t = int(np.argmax(v <= 0))
        problems.append(
            f"the outer wall encloses no volume in {names[t]}: is its mesh "
            "turned inside out, or not this tube?"
        )
    elif len(v) > 1:  # a lumen may close: only the outer wall's volume is checked
        off = np.log(v / np.median(v))
        t = int(np.argmax(np.abs(off)))
        if abs(off[t]) > np.log(VOLUME_JUMP):
            problems.append(
                f"the outer wall's volume in {names[t]} is {np.exp(off[t]):.3g} "
                f"times the frames' median (a beat changes it by far less): is "
                "that frame in other units, or of another embryo?"
            )
    return problems
