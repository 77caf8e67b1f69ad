"""The accuracy zoo in the suite (issue 72): a mesh draw, a label draw and a mesh draw
with a helical or one-sided wave front (issue 76) at a seed drawn afresh on every run
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

FRAMES, VOXEL_MIN_UM = 30, 6.0          # the zoo's settings in docs/accuracy.md
FIRST = int(os.environ.get("OFTIMG_ZOO_SEED") or random.SystemRandom().randrange(10 ** 6))

# kind -> metric -> bound on |error| in the metric's unit (scripts/accuracy_zoo.py's keys):
# 1.5 times the worst of docs/accuracy.md's draws whose segmentation shifted no wall (50
# mesh draws, 38 label draws, 2026-12-05; the cycle speed over the draws whose wave
# crosses the tube in 3 frames or more, as checked below). A random draw lies beyond the
# worst of n draws about once in n + 1 runs (on 11 label draws, seed 871832 came out at
# 1.02 times the bound in a suite run); half as much again beyond it, rarely, and a method that
# became half again as bad is caught.
BOUNDS = {
    "meshes": {"area_outer_p95_pct": 6.9, "volume_outer_pct": 1.2, "myocardial_change_pp": 2.0,
               "expand_pp": 2.5, "speed_cycle_pct": 8.6, "wall_thickness_pct": 5.9,
               "radial_curvature_outer_pct": 20.0, "radial_curvature_inner_pct": 24.0,
               "mean_curvature_lumen_pct": 66.0, "strain_energy_inner_pct": 39.0},
    "labels": {"area_outer_p95_pct": 4.3, "volume_outer_pct": 1.6, "myocardial_change_pp": 5.3,
               "expand_pp": 3.5, "speed_cycle_pct": 15.0, "wall_thickness_pct": 4.7,
               "radial_curvature_outer_pct": 34.0, "radial_curvature_inner_pct": 35.0,
               "mean_curvature_lumen_pct": 80.0, "strain_energy_inner_pct": 18.0},
    # a draw with a helical or one-sided front (draw_scenario(..., fronts=True)): 1.5 times
    # the worst of 30 mesh draws (docs/accuracy.md, Wave fronts on the wall)
    "meshes fronts": {"front_speed_pct": 5.1, "front_helix_deg": 0.2,
                      "front_activation_rms_ms": 2.6},
}
SPEED_CROSSING_FRAMES = 3    # speeds checked where the wave takes this many frames or more


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
    kind, fronts = drawn.split()[0], drawn.endswith("fronts")
    seed = unshifted_seed(kind, FIRST)
    rerun = (f"rerun: python scripts/accuracy_zoo.py --seed {seed} --draws 1 --kinds {kind} "
             f"--frames {FRAMES} --voxel-min-um {VOXEL_MIN_UM:g} --no-pair"
             + " --fronts" * fronts)
    try:
        errors = draw_errors(seed, kind, tmp_path, frames=FRAMES, voxel_min_um=VOXEL_MIN_UM,
                             jobs=1, pair=False, fronts=fronts)
    except InputError as exc:
        pytest.fail(f"zoo draw {seed} ({drawn}) refused: {exc}; {rerun}")
    bounds = dict(BOUNDS[drawn])
    if not fronts and crossing_frames(tmp_path / "data" / f"{kind}_{seed}") < \
            SPEED_CROSSING_FRAMES:
        bounds = {k: v for k, v in bounds.items() if "speed" not in k}  # the frames' limit
    beyond = {key: round(errors.get(key, float("nan")), 3) for key, bound in bounds.items()
              if not abs(errors.get(key, float("nan"))) <= bound}
    assert not beyond, (f"zoo draw {seed} ({drawn}; {errors['draw']}) beyond its bounds "
                        f"{BOUNDS[drawn]}: {beyond}; {rerun}")
