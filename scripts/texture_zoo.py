"""How far texture tracking's grid drifts from the tissue on the speckled zoo, against
shape tracking's, draw by draw.

Each draw (``draw_scenario(seed, "labels+intensity", speckled=True)``: fully developed
speckle carried by the tissue and renewed as it moves, grain from under a voxel to
coarse, slide up to 20 % of the length, twist up to 40 degrees) is written, meshed and
analysed once without tracking (cached in ``--root``: the per-frame outer grids and the
myocardium pullback); each tracking then carries frame 0's nodes through the cycle and
is compared with the phantom's tissue:

- drift along (% of the length) and around (rad): median over nodes and frames;
- the outer wall's strain energy node by node against the truth's (the phantom's own
  material grid from the run's frame-0 nodes): median and 90th percentile |error| over
  the true median;
- for texture tracking, the share of nodes that fell back to the shape.

    python scripts/texture_zoo.py --seeds 500 501 ... [--frames N] [--voxel-min-um 4]
        [--max-frames N] [--root DIR] [--modes material texture] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset
from oftimg.analysis.texture_tracking import texture_pathlines
from oftimg.analysis.tracking import follow, track_grid
from oftimg.inputs import _load, _meshed
from oftimg.io.dataset import validate_dataset
from oftimg.mesh.labels import MeshOptions
from oftimg.mesh.strain import grid_strain
from oftimg.synthetic.labels import LabelGrid
from oftimg.synthetic.phantom import read_truth
from oftimg.synthetic.zoo import draw_scenario, volume_offset_um, write_scenario

sys.path.insert(0, str(Path(__file__).resolve().parent))
from texture_accuracy import drift, true_energy  # noqa: E402


def untracked(
    seed: int,
    root: Path,
    frames: int | None,
    voxel_min_um: float | None,
    max_frames: int | None = None,
) -> tuple[Path, dict]:
    """The draw written into ``root/data`` and analysed without tracking: its folder
    and the cached arrays (``grid_outer (n_u, n_v, n_t, 3)`` mm, each frame's own;
    ``pullback (n_u f_u, (n_v - 1) f_v + 1, n_t)``; ``t0_frame``; ``seconds``)."""
    scenario = draw_scenario(
        seed, "labels+intensity", n_frames=frames, voxel_um_min=voxel_min_um, speckled=True
    )
    if max_frames is not None and scenario.phantom.n_frames > max_frames:
        scenario = draw_scenario(
            seed, "labels+intensity", n_frames=max_frames, voxel_um_min=voxel_min_um, speckled=True
        )
    dataset = root / "data" / f"speckled_{seed}"
    cache = root / "cache" / f"speckled_{seed}.npz"
    if cache.is_file():
        return dataset, dict(np.load(cache))
    if not (dataset / "scenario.json").is_file():
        write_scenario(scenario, dataset)
    tick = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = _meshed(_load(dataset), root / "meshes" / dataset.name, MeshOptions(), None, True)
        validate_dataset(ds)  # a bad mesh: the run's one line, not a traceback
        result = analyse_dataset(ds, PipelineOptions(tracking="none"), quiet=True)
    out = {
        "grid_outer": result["grids"]["outer"].astype(np.float32),
        "pullback": result["pullbacks"]["pullback_outer_mean"],
        "t0_frame": result["summary"]["t0_frame"],
        "seconds": time.perf_counter() - tick,
    }
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.savez(cache, **out)
    return dataset, out


def tracked_coords(mode: str, G: np.ndarray, pullback: np.ndarray) -> tuple[np.ndarray, dict]:
    """Pathlines ``(n_u, n_v, n_t, 2)`` grid steps by ``mode`` and its diagnostics."""
    shape, info = track_grid(G)
    if mode == "material":
        return shape, info
    n_u, n_v = G.shape[:2]
    factors = (pullback.shape[0] // n_u, (pullback.shape[1] - 1) // (n_v - 1))
    return texture_pathlines(pullback, factors, shape)


def errors(dataset: Path, cached: dict, modes: list[str]) -> dict:
    """Each mode's drift and strain-energy errors on one cached draw."""
    sc = json.loads((dataset / "scenario.json").read_text())
    ph, truth = read_truth(dataset)
    grid = LabelGrid(ph, sc["voxel_um"], oblique_deg=sc.get("oblique_deg", 0.0))
    offset = 1e-3 * volume_offset_um(sc)
    t_ms = np.roll(np.asarray(truth["t_ms"]), -int(cached["t0_frame"]))
    G = cached["grid_outer"].astype(float)
    out = {
        "frames": int(G.shape[2]),
        "voxel_um": [round(v, 2) for v in sc["voxel_um"]],
        "look": {k: round(v, 3) for k, v in sc["texture"].items()},
        "slide_pct": round(100 * sc["phantom"]["stretch"], 1),
        "twist_deg": round(sc["phantom"]["twist_deg"], 1),
        "twist": sc["phantom"]["twist_profile"],
    }
    for mode in modes:
        tick = time.perf_counter()
        coords, info = tracked_coords(mode, G, cached["pullback"])
        seconds = time.perf_counter() - tick
        Gt = follow(G, coords)
        keep = (coords[..., 1] >= 0) & (coords[..., 1] <= G.shape[1] - 1)
        d = drift(ph, grid, Gt - offset, t_ms, keep)
        energy = grid_strain(Gt)[0]
        truth_energy = true_energy(ph, grid, Gt[:, :, 0] - offset, t_ms)
        scale = float(np.nanmedian(truth_energy))
        err = np.abs(energy - truth_energy)[keep & np.isfinite(energy)] / scale
        out[mode] = {
            "along_pct": d["along_pct"],
            "around_rad": d["around_rad"],
            "energy_median_pct": 100 * float(np.median(err)),
            "energy_p90_pct": 100 * float(np.percentile(err, 90)),
            "seconds": seconds,
            **{
                k: v
                for k, v in info.items()
                if k.startswith("fallback_share") or k == "forward_backward_gap_steps"
            },
            **({"support_median": float(np.median(info["support"]))} if "support" in info else {}),
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", required=True)
    ap.add_argument("--frames", type=int, default=None, help="every draw this many frames")
    ap.add_argument(
        "--max-frames",
        type=int,
        default=None,
        help="draws of more frames cut to this many (quicker)",
    )
    ap.add_argument("--voxel-min-um", type=float, default=None)
    ap.add_argument("--root", type=Path, default=Path("texture_zoo"))
    ap.add_argument("--modes", nargs="+", default=["material", "texture"])
    ap.add_argument("--json", type=Path, default=None, help="append each draw's errors here")
    args = ap.parse_args()
    results = json.loads(args.json.read_text()) if args.json and args.json.is_file() else {}
    for seed in args.seeds:
        dataset, cached = untracked(
            seed, args.root, args.frames, args.voxel_min_um, args.max_frames
        )
        e = errors(dataset, cached, args.modes)
        results[str(seed)] = e
        line = "  ".join(
            f"{m}: {e[m]['along_pct']:.2f} % L {e[m]['around_rad']:.4f} rad "
            f"E {e[m]['energy_median_pct']:.0f}/{e[m]['energy_p90_pct']:.0f} %"
            for m in args.modes
        )
        print(
            f"{seed}: {e['frames']} frames, slide {e['slide_pct']} %, twist "
            f"{e['twist_deg']} deg, speckle {e['look']['speckle']}, grain "
            f"{e['look']['blob_um']} um  |  {line}",
            flush=True,
        )
        if args.json:
            args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
