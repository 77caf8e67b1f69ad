"""The runs' own error bars calibrated on the accuracy zoo (issue 72, point 4).

    python scripts/zoo_calibration.py --cache DIR [--kinds labels meshes ...]
                                      [--split 25] [--markdown] [--factors KIND]

Reads the draws and runs that ``scripts/accuracy_zoo.py --cache DIR`` kept, and for
each input kind and shape field finds the factor k by which the noise a run reports
(summary.json: ``field_noise``, ``noise_sd_smoothed``) must be widened for its 95 %
band (1.96 k times that noise) to hold the true error at 95 % of the nodes and frames
of the draws with seeds below ``--split`` (pooled); then measures that band on the
draws from ``--split`` on, which it was not fitted to: the share of their nodes and
frames inside it (pooled), and per draw (median, 10th percentile, lowest). k = 1: the
noise estimate alone is calibrated. The draws whose segmentation grew or shrank a
wall by a voxel are left out of both (the segmentation's own bias, which nothing
measured from the data can bound) and their coverage is printed apart.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from accuracy import embryo_errors  # noqa: E402

from oftimg.analysis.uncertainty import BAND_FACTORS  # noqa: E402

FIELDS = [
    "radial_curvature_outer",
    "radial_curvature_inner",
    "mean_curvature_lumen",
    "wall_thickness",
    "jelly_thickness",
]


def draw_ratios(dataset: Path, results: Path) -> dict[str, np.ndarray]:
    """Per field, each node's and frame's |error| over 1.96 times the noise the run
    reports (finite values only)."""
    keep: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        embryo_errors(dataset, results, keep)
    out = {}
    for name, (error, noise_sd) in keep.items():
        r = np.abs(error) / (1.96 * noise_sd)
        out[name] = r[np.isfinite(r)].ravel()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", type=Path, required=True)
    ap.add_argument(
        "--kinds", nargs="+", default=["meshes", "labels", "probabilities", "labels_intensity"]
    )
    ap.add_argument(
        "--split", type=int, default=25, help="fit on seeds below this, measure on the rest"
    )
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument(
        "--factors",
        choices=["meshes", "labels", "probabilities"],
        default=None,
        help="measure oftimg's own factors for this input kind "
        "(oftimg.analysis.uncertainty.BAND_FACTORS) on every draw: no fit",
    )
    args = ap.parse_args()
    factors = {}
    for kind in args.kinds:
        draws = {}
        for dataset in sorted((args.cache / "data").glob(f"{kind}_*")):
            results = args.cache / "results" / dataset.name / dataset.name
            if dataset.name.endswith("_meshes") or not (results / "summary.json").is_file():
                continue
            scenario = json.loads((dataset / "scenario.json").read_text())
            shifted = bool(
                (scenario.get("segmentation") or {}).get("systematic")
                and scenario["kind"] != "probabilities"
            )  # written for labels only
            draws[scenario["seed"]] = (shifted, draw_ratios(dataset, results))
        split = -1 if args.factors else args.split  # given factors: every draw held out
        fit = [d for s, (shifted, d) in draws.items() if s < split and not shifted]
        held = {s: d for s, (shifted, d) in draws.items() if s >= split and not shifted}
        apart = {s: d for s, (shifted, d) in draws.items() if shifted}
        if not fit and not args.factors:
            continue
        print(
            f"\n{kind}: "
            + (
                f"oftimg's factors for {args.factors}, measured on {len(held)} draws"
                if args.factors
                else f"fitted on {len(fit)} draws (seeds < {args.split}), measured "
                f"on {len(held)} others"
            )
            + f"; {len(apart)} with a wall shifted apart"
        )
        if args.markdown:
            print(
                "\n| field | k | held-out nodes within 1.96 k noise | per draw: median, 10th "
                "percentile, lowest | within 1.96 noise (k = 1) | walls shifted, within "
                "1.96 k |\n|---|---|---|---|---|---|"
            )
        factors[kind] = {}
        for name in FIELDS:
            if args.factors:
                k = BAND_FACTORS[args.factors][name]
            else:
                pooled = np.concatenate([d[name] for d in fit if name in d] or [np.array([])])
                if not len(pooled):
                    continue
                k = float(np.percentile(pooled, 95))
            factors[kind][name] = round(k, 2)
            share = {s: 100 * np.mean(d[name] <= k) for s, d in held.items() if name in d}
            pooled_held = np.concatenate(
                [d[name] for d in held.values() if name in d] or [np.array([])]
            )
            inside = 100 * np.mean(pooled_held <= k) if len(pooled_held) else np.nan
            plain = 100 * np.mean(pooled_held <= 1) if len(pooled_held) else np.nan
            per = np.array(list(share.values())) if share else np.array([np.nan])
            shifted_in = np.concatenate(
                [d[name] for d in apart.values() if name in d] or [np.array([])]
            )
            shifted_share = f"{100 * np.mean(shifted_in <= k):.0f} %" if len(shifted_in) else "-"
            low_seed = min(share, key=share.get) if share else "-"
            if args.markdown:
                print(
                    f"| {name.replace('_', ' ')} | {k:.2f} | {inside:.0f} % | {np.median(per):.0f}, "
                    f"{np.percentile(per, 10):.0f}, {per.min():.0f} % (seed {low_seed}) | "
                    f"{plain:.0f} % | {shifted_share} |"
                )
            else:
                print(
                    f"  {name:<26} k {k:5.2f}  held out {inside:5.1f} % (per draw median "
                    f"{np.median(per):.0f}, p10 {np.percentile(per, 10):.0f}, lowest "
                    f"{per.min():.0f} at {low_seed}); k = 1: {plain:.0f} %; walls shifted: "
                    f"{shifted_share}"
                )
    print("\nfactors:", json.dumps(factors))


if __name__ == "__main__":
    main()
