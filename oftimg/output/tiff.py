"""A dataset's maps and fields, and a cohort's maps, as TIFF images that Fiji /
ImageJ open as they are: float32 with NaN kept (masks as 8-bit 0 / 255), time as the
frames of a stack, the two principal stretches as channels, the embryos of a cohort
as its slices, and what the pixels are in the image's info (Image > Show Info): for
image analysis outside Python."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .image_order import in_image_order

IMAGE_DIMS = (["v", "t"], ["u", "v"], ["u", "v", "t"], ["u", "v", "t", "l1,l2"])


def tiff_names(described: dict) -> list[str]:
    """The arrays of ``arrays.json`` (``described``: name -> {"dims", "file", ...})
    that are images: (v, t) maps, (u, v) phase maps, (u, v, t) fields and the
    principal stretches; not coordinates."""
    return [
        name
        for name, d in described.items()
        if d.get("file", "arrays.npz") == "arrays.npz" and d["dims"] in IMAGE_DIMS
    ]


def tiff_image(
    values: np.ndarray, info: dict, t_ms: np.ndarray, s_mm: np.ndarray
) -> tuple[np.ndarray, dict]:
    """One array on its named axes (``info``: its arrays.json entry) as ``(image,
    ImageJ metadata)``: float32 (bool as uint8 0 / 255) in image order
    (:func:`oftimg.output.image_order.in_image_order`), with its axes, the frame interval
    (s) and each frame's time as labels when it has frames, and an Info text saying
    what rows, columns and values are."""
    image, axes = in_image_order(values, info["dims"])
    image = image.astype(np.uint8) * 255 if image.dtype == bool else image.astype(np.float32)
    across = (
        "u around the tube from the seam (u = 0)"
        if "u" in info["dims"]
        else (f"t, time since the minimum volume (ms): {_listed(t_ms)}")
    )
    text = [
        _with_unit(info),
        f"rows: v, from the outlet (top) to the inlet (bottom), at s_mm from the inlet: "
        f"{_listed(s_mm[::-1])}",
        f"columns: {across}",
    ]
    metadata = {"axes": axes}
    if "T" in axes:
        text.append(f"frames: t (ms) {_listed(t_ms)}")
        metadata["finterval"] = float(np.median(np.diff(t_ms))) / 1000.0
        metadata["Labels"] = [
            f"t = {t:.1f} ms" for t in t_ms for _ in range(image.shape[1] if "C" in axes else 1)
        ]
    if "C" in axes:
        text.append("channels: " + ", ".join(info["dims"][-1].split(",")))
    metadata["Info"] = "\n".join(text)
    return image, metadata


def _with_unit(described: dict) -> str:
    """An array's description, and its unit in brackets where it has one."""
    unit = described.get("unit", "")
    return described["description"] + (f" ({unit})" if unit not in ("", "1", "bool") else "")


def _listed(values: np.ndarray) -> str:
    return " ".join(f"{v:.4g}" for v in values)


def write_tiff_images(results: Path, out: Path) -> list[Path]:
    """Every image of one dataset's results folder (``arrays.npz``, ``arrays.json``;
    :func:`tiff_names`) as ``out/<array name>.tif``. Returns the files written."""
    import tifffile

    described = json.loads((results / "arrays.json").read_text())
    out.mkdir(parents=True)
    written = []
    with np.load(results / "arrays.npz") as npz:
        t_ms, s_mm = npz["t_ms"], npz["s_mm"]
        for name in tiff_names(described):
            image, metadata = tiff_image(npz[name], described[name], t_ms, s_mm)
            path = out / f"{name}.tif"
            tifffile.imwrite(path, image, imagej=True, metadata=metadata)
            written.append(path)
    if (results / "pullbacks.npz").is_file():
        with np.load(results / "pullbacks.npz") as npz:
            for name in npz.files:
                image, metadata = pullback_tiff(npz[name], described[name], t_ms)
                path = out / f"{name}.tif"
                tifffile.imwrite(path, image, imagej=True, metadata=metadata)
                written.append(path)
    return written


def pullback_tiff(values: np.ndarray, info: dict, t_ms: np.ndarray) -> tuple[np.ndarray, dict]:
    """A pullback ``(u_fine, v_fine, t)`` as a 16-bit ImageJ stack ``(t, v, u)`` (rows v
    from the outlet at the top): its values rounded and clipped to 0..65535, as the
    intensity volumes' own (8- or 16-bit) values are; 0 where not imaged (NaN)."""
    image, axes = in_image_order(values, ["u", "v", "t"])
    image = np.clip(np.round(np.nan_to_num(image, nan=0.0)), 0, 65535).astype(np.uint16)
    text = [
        _with_unit(info) + "; 0: not imaged",
        "rows: v_fine, from the outlet (top) to the inlet (bottom)",
        "columns: u_fine, around the tube from the seam (u = 0)",
        f"frames: t (ms) {_listed(t_ms)}",
    ]
    metadata = {
        "axes": axes,
        "finterval": float(np.median(np.diff(t_ms))) / 1000.0,
        "Labels": [f"t = {t:.1f} ms" for t in t_ms],
        "Info": "\n".join(text),
    }
    return image, metadata


def write_cohort_map_images(run: Path, out: Path) -> list[Path]:
    """A run's (or ``oftimg cohort``'s) ``cohort_maps.npz`` (``cohort_maps.json``) as
    ``out/<map>.tif``: each map of every embryo (or each comparison of groups) a slice,
    labelled with its name and group; rows the position along the tube (inlet at the
    bottom), columns the phase of the cycle. Returns the files written."""
    import tifffile

    described = json.loads((run / "cohort_maps.json").read_text())
    out.mkdir(parents=True)
    written = []
    with np.load(run / "cohort_maps.npz") as npz:
        labels = {
            "embryo": [f"{n} ({g})" for n, g in zip(npz["names"], npz["groups"])],
            "comparison": [str(c) for c in npz["comparisons"]],
        }
        position, phase = npz["position_fraction"], npz["cycle_fraction"]
        for name, d in described.items():
            if d["dims"][1:] != ["position", "phase"] or not npz[name].size:
                continue
            image = np.stack([in_image_order(m, ["v", "t"])[0] for m in npz[name]])
            info = [
                _with_unit(d),
                f"slices: {d['dims'][0]}s: " + ", ".join(labels[d["dims"][0]]),
                f"rows: position along the tube as a fraction of its length, from the "
                f"outlet (top) to the inlet (bottom): {_listed(position[::-1])}",
                f"columns: phase, fraction of the cycle since the minimum volume: {_listed(phase)}",
            ]
            path = out / f"{name}.tif"
            tifffile.imwrite(
                path,
                image.astype(np.float32),
                imagej=True,
                metadata={"axes": "ZYX", "Labels": labels[d["dims"][0]], "Info": "\n".join(info)},
            )
            written.append(path)
    return written
