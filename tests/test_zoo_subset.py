"""The accuracy zoo in the suite (issue 72): a mesh draw, a label draw, a mesh draw
with a helical or one-sided wave front (issue 76) and one with sharp corners and notches,
its fields judged node by node (issue 84), at a seed drawn afresh on every run
(printed on failure, with the command that reruns it), each metric within its bound
over the zoo at the same settings (docs/accuracy.md's tables, BOUNDS below). The label
draw is one whose segmentation shifts no wall by a voxel (that error is the
segmentation's, and the tables give it apart). OFTIMG_ZOO_SEED reruns one seed."""

import json
import os
import random
import sys
from pathlib import Path

import pytest

from oftimg import InputError
from oftimg.synthetic.zoo import draw_scenario

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
from accuracy_zoo import draw_errors  # noqa: E402

pytestmark = pytest.mark.long  # make test-long (accuracy, rendering, whole runs)

FRAMES, VOXEL_MIN_UM = 30, 6.0  # the zoo's settings in docs/accuracy.md
FIRST = int(os.environ.get("OFTIMG_ZOO_SEED") or random.SystemRandom().randrange(10**6))

# kind -> metric -> bound on |error| in the metric's unit (scripts/accuracy_zoo.py's keys):
# 1.5 times the worst of docs/accuracy.md's draws whose segmentation shifted no wall (50
# mesh draws, 38 label draws, 2026-12-05; the cycle speed over the draws whose wave
# crosses the tube in 3 frames or more, as checked below). A random draw lies beyond the
# worst of n draws about once in n + 1 runs (on 11 label draws, seed 871832 came out at
# 1.02 times the bound in a suite run); half as much again beyond it, rarely, and a method that
# became half again as bad is caught. The expansion share's bound is the label draws' for
# every kind: its tail is the frames' (3.3 pp a frame at 30), whatever the input (the worst
# of 138 draws of three kinds 2.36 pp; mesh seed 479233 came out at 2.96 pp in a suite run,
# 1.8 times the mesh draws' worst, at this and the previous session's code alike).
BOUNDS = {
    "meshes": {
        "area_outer_p95_pct": 6.9,
        "volume_outer_pct": 1.2,
        "myocardial_change_pp": 2.0,
        "expand_pp": 3.5,
        "speed_cycle_pct": 8.6,
        "wall_thickness_pct": 5.9,
        "radial_curvature_outer_pct": 20.0,
        "radial_curvature_inner_pct": 24.0,
        "mean_curvature_lumen_pct": 66.0,
        "strain_energy_inner_pct": 39.0,
    },
    "labels": {
        "area_outer_p95_pct": 4.3,
        "volume_outer_pct": 1.6,
        "myocardial_change_pp": 5.3,
        "expand_pp": 3.5,
        "speed_cycle_pct": 15.0,
        "wall_thickness_pct": 4.7,
        "radial_curvature_outer_pct": 34.0,
        "radial_curvature_inner_pct": 35.0,
        "mean_curvature_lumen_pct": 80.0,
        "strain_energy_inner_pct": 18.0,
    },
    # a draw with a helical or one-sided front (draw_scenario(..., fronts=True)): 1.5 times
    # the worst of 30 mesh draws (docs/accuracy.md, Wave fronts on the wall)
    "meshes fronts": {
        "front_speed_pct": 5.1,
        "front_helix_deg": 0.2,
        "front_activation_rms_ms": 2.6,
    },
    # a draw with sharper corners, concave notches and 40-200 vertices round the tube
    # (draw_scenario(..., features=True), 40 frames): the 90th percentile node error, 1.5
    # times the worst of 50 draws (seeds 100-149, 2026-12-06; docs/accuracy.md, "The
    # lumen's mean curvature and the strain energy node by node")
    "meshes features": {
        "radial_curvature_outer_p90_pct": 220.0,
        "mean_curvature_lumen_p90_pct": 290.0,
        "strain_energy_inner_p90_pct": 111.0,
    },
    # the same as label volumes (4-8 um voxels; 1.5 times the worst of the 29 of 50 draws
    # whose segmentation shifts no wall, seeds 300-349, 2026-12-07)
    "labels features": {
        "radial_curvature_outer_p90_pct": 500.0,
        "mean_curvature_lumen_p90_pct": 435.0,
        "strain_energy_inner_p90_pct": 182.0,
    },
}
# the share of nodes inside their own 95 % band (issue 84), at least: 1.5 times the worst
# of those 50 draws' shortfall from 100 % below 100 % (radial curvature 82 %, the lumen's
# 79 %, the strain energy's 84 %, with the factors of oftimg.analysis.uncertainty)
FLOORS = {
    "meshes features": {
        "radial_curvature_outer_node_band_within_pct": 73.0,
        "mean_curvature_lumen_node_band_within_pct": 68.0,
        "strain_energy_inner_node_band_within_pct": 76.0,
    },
    # the label draws' (lowest 69, 82 and 87 %)
    "labels features": {
        "radial_curvature_outer_node_band_within_pct": 53.0,
        "mean_curvature_lumen_node_band_within_pct": 73.0,
        "strain_energy_inner_node_band_within_pct": 80.0,
    },
}
FEATURE_FRAMES = 40  # the feature and cushion draws' frames in docs/accuracy.md
FEATURE_VOXEL_MIN_UM = 4.0  # and their finest voxels
SPEED_CROSSING_FRAMES = 3  # speeds checked where the wave takes this many frames or more


def unshifted_seed(kind: str, first: int) -> int:
    """The first seed from ``first`` on whose draw shifts no wall by a voxel."""
    seed = first
    while kind != "meshes" and draw_scenario(seed, kind).segmentation.systematic is not None:
        seed += 1
    return seed


def crossing_frames(dataset: Path) -> float:
    """How many frames the draw's wave takes to cross its tube (its truth)."""
    truth = json.loads((dataset / "truth.json").read_text())
    frame_ms = truth["params"]["period_ms"] / truth["params"]["n_frames"]
    return 1000 * truth["tube_length_mm"] / abs(truth["wave_speed_mm_s"]["cycle"]) / frame_ms


@pytest.mark.slow
@pytest.mark.parametrize("drawn", sorted(BOUNDS))
def test_a_random_draw_is_within_the_zoos_bounds(tmp_path, drawn):
    kind, fronts, features, cushions = (
        drawn.split()[0],
        drawn.endswith("fronts"),
        drawn.endswith("features"),
        drawn.endswith("cushions"),
    )
    frames = FEATURE_FRAMES if features or cushions else FRAMES
    voxel_min = FEATURE_VOXEL_MIN_UM if features or cushions else VOXEL_MIN_UM
    seed = unshifted_seed(kind, FIRST)
    rerun = (
        f"rerun: python scripts/accuracy_zoo.py --seed {seed} --draws 1 --kinds {kind} "
        f"--frames {frames} --voxel-min-um {voxel_min:g} --no-pair"
        + " --fronts" * fronts
        + " --features" * features
        + " --cushions" * cushions
    )
    try:
        errors = draw_errors(
            seed,
            kind,
            tmp_path,
            frames=frames,
            voxel_min_um=voxel_min,
            jobs=1,
            pair=False,
            fronts=fronts,
            features=features,
            cushions=cushions,
        )
    except InputError as exc:
        pytest.fail(f"zoo draw {seed} ({drawn}) refused: {exc}; {rerun}")
    bounds = dict(BOUNDS[drawn])
    plain = not (fronts or features or cushions)
    if plain and crossing_frames(tmp_path / "data" / f"{kind}_{seed}") < SPEED_CROSSING_FRAMES:
        bounds = {k: v for k, v in bounds.items() if "speed" not in k}  # the frames' limit
    beyond = {
        key: round(errors.get(key, float("nan")), 3)
        for key, bound in bounds.items()
        if not abs(errors.get(key, float("nan"))) <= bound
    }
    assert not beyond, (
        f"zoo draw {seed} ({drawn}; {errors['draw']}) beyond its bounds "
        f"{BOUNDS[drawn]}: {beyond}; {rerun}"
    )
    below = {
        key: round(errors.get(key, float("nan")), 1)
        for key, floor in FLOORS.get(drawn, {}).items()
        if not errors.get(key, float("nan")) >= floor
    }
    assert not below, (
        f"zoo draw {seed} ({drawn}; {errors['draw']}) under its floors "
        f"{FLOORS[drawn]}: {below}; {rerun}"
    )
