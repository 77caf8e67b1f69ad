"""How far the (u, v, t) grid drifts from the tissue, on a real shape with known motion.

The 8k midgut copy (tests/data) animated by ``oftimg animate`` over 40 remeshed frames:
a radial wave (1.5 mm/s, amplitude 0.3), a twist (20 degrees at the outlet) and a
longitudinal shortening (15 %), each vertex of each frame traced to the static mesh
(truth/). For each tracking mode, prints:

- drift: each grid node's static (material) point in each frame against its point at
  t = 0, median and 90th percentile over nodes and frames, in % of the tube's length
  and against the tissue's own median displacement over the cycle;
- stretch error: the principal stretches oftimg reports (principal_stretch_outer,
  smoothed in time as usual) against those of the true material grid (the t = 0
  nodes carried through the cycle by the animation), median of |measured / true - 1|
  over nodes and frames; the strain energy's median beside the true one;
- seconds for the analysis.

Then the same for a normal phantom (195 frames, each wall meshed anew in each frame,
2 um of radial roughness): the s.d. over time of each outer node's material angle and
of its material position along the tube (the phantom's tissue slides through the inlet
plane by up to 15 % of the length as it stretches), median over nodes.

With ``--texture``, the animation has intensity volumes too (``oftimg animate
--texture``: a texture fixed in the tissue) and ``texture`` can be among the modes.

    python scripts/tracking_accuracy.py [--frames 40] [--seed 0] [--modes none material]
                                        [--texture --modes material texture]
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from oftimg.synthetic.animate import (
    Animation,
    grid_material_points,
    tissue_positions,
    write_animation,
)
from oftimg.io.dataset import load_dataset
from oftimg.mesh.strain import grid_strain
from oftimg.synthetic.phantom import read_truth, sample_params, write_phantom
from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset

MIDGUT = Path(__file__).resolve().parent.parent / "tests" / "data" / "midgut_8k.ply"


def measure(dataset: Path, tracking: str) -> dict:
    tick = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = analyse_dataset(
            load_dataset(dataset), PipelineOptions(tracking=tracking), quiet=True
        )
    seconds = time.perf_counter() - tick
    G, t0 = result["grids"]["outer"], result["summary"]["t0_frame"]
    length = result["summary"]["tube_length_mm"]
    S = grid_material_points(dataset, G, t0)
    drift = np.linalg.norm(S - S[:, :, :1], axis=-1)[:, :, 1:]
    P = tissue_positions(dataset, S[:, :, 0].reshape(-1, 3), t0).reshape(G.shape)
    moved = np.linalg.norm(P - P[:, :, :1], axis=-1)[:, :, 1:]
    measured = result["arrays"]["principal_stretch_outer"]  # as the user gets them
    energy = result["arrays"]["strain_energy_outer"]
    true_energy, true = grid_strain(P)
    stretch_error = np.abs(measured / true - 1)
    return {
        "drift_median_pct": 100 * np.median(drift) / length,
        "drift_p90_pct": 100 * np.percentile(drift, 90) / length,
        "drift_over_motion": np.median(drift) / np.median(moved),
        "motion_median_pct": 100 * np.median(moved) / length,
        "stretch_error_median": float(np.nanmedian(stretch_error)),
        "energy_median": float(np.nanmedian(energy)),
        "true_energy_median": float(np.nanmedian(true_energy)),
        "seconds": seconds,
        "tracking": result["summary"].get("tracking"),
    }


def phantom_drift(dataset: Path, tracking: str) -> dict:
    ph, truth = read_truth(dataset)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = analyse_dataset(
            load_dataset(dataset), PipelineOptions(tracking=tracking), quiet=True
        )
    t_ms = np.roll(np.asarray(truth["t_ms"]), -result["summary"]["t0_frame"])
    S, theta = ph.material_coordinates(result["grids"]["outer"], t_ms[None, None, :])
    return {
        "angle_sd_rad": float(np.median(np.unwrap(theta, axis=2).std(axis=2))),
        "position_sd_pct": float(100 * np.median(S.std(axis=2)) / ph.p.length_mm),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--twist-deg", type=float, default=20.0)
    parser.add_argument("--shortening", type=float, default=0.15)
    parser.add_argument("--modes", nargs="+", default=["none", "material"])
    parser.add_argument("--phantom-frames", type=int, default=195)
    parser.add_argument(
        "--texture",
        action="store_true",
        help="the animated gut with intensity volumes (for --modes texture)",
    )
    args = parser.parse_args()
    anim = Animation(
        speed_mm_s=1.5,
        amplitude=0.3,
        period_ms=360.0,
        n_frames=args.frames,
        twist_deg=args.twist_deg,
        shortening=args.shortening,
    )
    with tempfile.TemporaryDirectory() as tmp:
        dataset = write_animation(
            MIDGUT,
            Path(tmp) / "midgut",
            anim,
            scale_to_mm=0.2619e-3,
            do_remesh=True,
            seed=args.seed,
            texture=args.texture,
        )
        for mode in args.modes:
            m = measure(dataset, mode)
            print(
                f"tracking {mode}: drift median {m['drift_median_pct']:.2f} % of the length "
                f"(p90 {m['drift_p90_pct']:.2f} %), {m['drift_over_motion']:.2f} x the tissue's "
                f"median displacement ({m['motion_median_pct']:.2f} %); principal stretches "
                f"{100 * m['stretch_error_median']:.1f} % off (median); strain energy median "
                f"{m['energy_median']:.4f} (true {m['true_energy_median']:.4f}); "
                f"{m['seconds']:.1f} s"
            )
            if m["tracking"]:
                print(f"  summary.json tracking: {m['tracking']}")
        phantom = write_phantom(
            Path(tmp) / "phantom",
            sample_params("normal", 0, n_frames=args.phantom_frames, noise_mm=0.002),
        )
        for mode in [m for m in args.modes if m != "texture"]:  # the phantom has none
            m = phantom_drift(phantom, mode)
            print(
                f"phantom, tracking {mode}: material angle s.d. {m['angle_sd_rad']:.4f} rad, "
                f"material position s.d. {m['position_sd_pct']:.2f} % of the length "
                "(median over nodes)"
            )


if __name__ == "__main__":
    main()
