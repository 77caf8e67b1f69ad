"""Results checked for sense before anything is written: what no living tube can give
(walls that coincide or cross, a wall thinner than a micrometre, a frame's volume an
order of magnitude off the others') stops the run with one line that says what is
implausible and which input most likely causes it. What is unusual but possible stays
a warning (:func:`~oftimg.analysis.pipeline.analyse_dataset`'s).
"""
from __future__ import annotations

import numpy as np

CROSSING_SHARE = 0.05     # of the grid nodes: an inner wall outside the outer one beyond it
MIN_WALL_MM = 1e-3        # a wall thinner than a micrometre: one surface given twice
VOLUME_JUMP = 10.0        # a frame's outer volume this many times the frames' median
NESTED = (("outer", "inner"), ("inner", "lumen"), ("outer", "lumen"))


def implausible(grids: dict, volumes: dict, outside: dict, *, frame_names=None) -> list[str]:
    """What cannot be right in one dataset's stacked per-frame results, in words that
    name the likely cause ([] when nothing).

    ``grids``: wall -> ``(n_u, n_v, n_t, 3)`` mm, each frame's own grid (the inner
    wall's nodes on the lines from the outer wall's towards the axis);
    ``volumes``: wall -> ``(n_t,)`` mm³ enclosed; ``outside``: wall -> how many of its
    nodes over all frames lie outside the wall around it (``inner``: the outer wall;
    ``lumen``: the inner wall); ``frame_names``: each frame's file name, for the message.
    """
    problems = []
    walls = [w for w in ("outer", "inner", "lumen") if w in grids]
    n_nodes = grids["outer"][..., 0].size
    n_t = grids["outer"].shape[2]
    names = frame_names or [f"frame {t}" for t in range(n_t)]
    for wall, around in (("inner", "outer"), ("lumen", "inner")):
        share = outside.get(wall, 0) / n_nodes
        if wall in walls and around in walls and share > CROSSING_SHARE:
            problems.append(f"the {wall} wall lies outside the {around} one at {share:.0%} of "
                            f"the grid nodes (at most {CROSSING_SHARE:.0%} can be a "
                            f"segmentation's slip): are {wall}/ and {around}/ swapped, or the "
                            "label values (meta.json \"labels\") wrong?")
    for around, wall in NESTED:
        if around not in walls or wall not in walls or (around, wall) == ("outer", "lumen") \
                and "inner" in walls:
            continue
        larger = int(np.count_nonzero(volumes[wall] >= volumes[around]))
        if larger > n_t / 2:
            problems.append(f"the {wall} wall encloses as much as the {around} one or more in "
                            f"{larger} of {n_t} frames: are {wall}/ and {around}/ swapped, or "
                            "one surface given as both?")
    if "inner" in walls:
        gap_mm = float(np.median(np.linalg.norm(grids["outer"] - grids["inner"], axis=-1)))
        if gap_mm < MIN_WALL_MM:
            problems.append(f"the outer and inner walls lie {1e6 * gap_mm:.3g} nm apart (the "
                            f"median over the grid nodes; no myocardium is thinner than "
                            f"{1000 * MIN_WALL_MM:g} µm): one surface given as both, or the "
                            "label values (meta.json \"labels\") wrong?")
    for wall in walls:
        v = np.asarray(volumes[wall], float)
        if wall != "outer" or len(v) < 2:
            continue            # a lumen may close: only the outer wall's volume is checked
        if np.any(v <= 0):
            t = int(np.argmax(v <= 0))
            problems.append(f"the outer wall encloses no volume in {names[t]}: is its mesh "
                            "turned inside out, or not this tube?")
            continue
        off = np.log(v / np.median(v))
        t = int(np.argmax(np.abs(off)))
        if abs(off[t]) > np.log(VOLUME_JUMP):
            problems.append(f"the outer wall's volume in {names[t]} is {np.exp(off[t]):.3g} "
                            f"times the frames' median (a beat changes it by far less): is "
                            "that frame in other units, or of another embryo?")
    return problems
