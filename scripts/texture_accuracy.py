"""How far the grid drifts from the tissue on the textured label phantom, by tracking mode.

The phantom (``oftimg phantom --labels --intensity``: a texture fixed in the tissue,
which slides along the tube by up to 15 % of its length at the inlet and twists by
20 degrees beneath the walls, 4 x 4 x 8 um voxels) is run with each ``--tracking``
mode; each outer grid node's material point (truth.json's model) in each frame is
compared with its point in frame 0:

- along: |S_t - S_0|, median over nodes and frames, % of the tube's length;
- around: |theta_t - theta_0|, median, rad;
- the same for the nodes whose tissue stays in view (texture tracking's grid_in_view);
- the strain energy's median against the truth's (the model's own material grid from
  the run's frame-0 nodes), and node by node: the median |error| over the true median;
- seconds for the analysis.

    python scripts/texture_accuracy.py [--frames 48] [--cache DIR] [--modes none material texture]
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset
from oftimg.inputs import _load, _meshed
from oftimg.mesh.labels import MeshOptions
from oftimg.mesh.strain import grid_strain
from oftimg.synthetic.labels import LabelGrid, write_label_phantom
from oftimg.synthetic.phantom import Phantom, read_truth, sample_params
from oftimg.synthetic.texture import TWIST_DEG

VOXEL_UM = (4.0, 4.0, 8.0)


def drift(
    ph: Phantom, grid: LabelGrid, G: np.ndarray, t_ms: np.ndarray, keep: np.ndarray | None
) -> dict:
    """Median drift along (% of the length) and around (rad) of the grid ``G (n_u,
    n_v, n_t, 3)`` mm (the volume's frame) from the tissue of its frame 0."""
    X = (G - grid.shift) @ grid.turn.T
    S, theta = ph.material_coordinates(X, t_ms[None, None, :])
    along = np.abs(S - S[:, :, :1])[:, :, 1:]
    around = np.abs(np.angle(np.exp(1j * (theta - theta[:, :, :1]))))[:, :, 1:]
    out = {
        "along_pct": 100 * float(np.median(along)) / ph.p.length_mm,
        "around_rad": float(np.median(around)),
    }
    if keep is not None:
        k = keep[:, :, 1:]
        out.update(
            along_in_view_pct=100 * float(np.median(along[k])) / ph.p.length_mm,
            around_in_view_rad=float(np.median(around[k])),
        )
    return out


def true_energy(ph: Phantom, grid: LabelGrid, G0: np.ndarray, t_ms: np.ndarray) -> np.ndarray:
    """The strain energy ``(n_u, n_v, n_t)`` of the model's own material grid: the
    tissue at the nodes ``G0 (n_u, n_v, 3)`` mm of frame 0 carried through the cycle
    (its slide along the tube and its twist undone, on the outer wall)."""
    L = ph.p.length_mm
    s0, theta0 = ph.window_coordinates((G0 - grid.shift) @ grid.turn.T)
    S, Theta = ph.material_from_window(s0, theta0, t_ms[0])
    frames = []
    for t in t_ms:
        s = np.clip(L - (L - S) * ph.stretch(t), 0.0, L)
        frames.append(ph.point("outer", s, Theta + ph.twist(s, t), t) @ grid.turn + grid.shift)
    return grid_strain(np.stack(frames, axis=2))[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=48)
    ap.add_argument("--group", default="normal")
    ap.add_argument("--cache", type=Path, default=None, help="keep the phantom here (made once)")
    ap.add_argument("--modes", nargs="+", default=["none", "material", "texture"])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = args.cache or Path(tmp)
        path = root / f"textured_{args.group}_{args.frames}f"
        if not path.exists():
            tick = time.perf_counter()
            write_label_phantom(
                path,
                sample_params(args.group, 0, n_frames=args.frames, twist_deg=TWIST_DEG),
                VOXEL_UM,
                intensity=True,
            )
            print(f"phantom written in {time.perf_counter() - tick:.0f} s")
        ph, truth = read_truth(path)
        grid = LabelGrid(ph, VOXEL_UM)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds = _meshed(_load(path), Path(tmp) / "meshes", MeshOptions(), None, True)
            for mode in args.modes:
                tick = time.perf_counter()
                result = analyse_dataset(ds, PipelineOptions(tracking=mode), quiet=True)
                seconds = time.perf_counter() - tick
                t_ms = np.roll(np.asarray(truth["t_ms"]), -result["summary"]["t0_frame"])
                keep = result["arrays"].get("grid_in_view")
                d = drift(ph, grid, result["grids"]["outer"], t_ms, keep)
                energy = float(np.nanmedian(result["arrays"]["strain_energy_outer"]))
                true_field = true_energy(ph, grid, result["grids"]["outer"][:, :, 0], t_ms)
                truth_energy = float(np.nanmedian(true_field))
                node_error = float(
                    np.nanmedian(np.abs(result["arrays"]["strain_energy_outer"] - true_field))
                    / truth_energy
                )
                extra = (
                    f"; in view ({100 * keep.mean():.0f} %): along "
                    f"{d['along_in_view_pct']:.2f} %, around {d['around_in_view_rad']:.4f} "
                    f"rad"
                    if keep is not None
                    else ""
                )
                print(
                    f"tracking {mode}: drift along {d['along_pct']:.2f} % of the length, "
                    f"around {d['around_rad']:.4f} rad{extra}; strain energy median "
                    f"{energy:.4f} (true {truth_energy:.4f}; node by node, median |error| "
                    f"{100 * node_error:.0f} % of the true median); {seconds:.1f} s"
                )


if __name__ == "__main__":
    main()
