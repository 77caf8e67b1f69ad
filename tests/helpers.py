"""Analytic test shapes (meshes of cylinders, cones and elliptic tubes) and a
worker pool that runs each task at once."""

from __future__ import annotations

import concurrent.futures

import numpy as np

from oftimg.io.meshfile import write_ply


def tube_mesh(
    radius_in=0.2, radius_out=None, length=1.0, n_theta=48, n_s=30, ellipse=1.0, theta0=0.0
):
    """Straight tube along +z from z=0 (inlet) to z=length, outward-oriented.

    Radius tapers linearly from ``radius_in`` to ``radius_out`` (a cone); the
    y semi-axis is scaled by ``ellipse``. Returns ``V (n, 3)``, ``F (m, 3)``.
    """
    radius_out = radius_in if radius_out is None else radius_out
    z = np.linspace(0, length, n_s)
    th = theta0 + np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    r = radius_in + (radius_out - radius_in) * z / length
    Z, T = np.meshgrid(z, th, indexing="ij")
    R = r[:, None] * np.ones_like(T)
    V = np.stack([R * np.cos(T), ellipse * R * np.sin(T), Z], axis=-1).reshape(-1, 3)
    idx = np.arange(n_s * n_theta).reshape(n_s, n_theta)
    a = idx[:-1]
    b = np.roll(idx, -1, axis=1)[:-1]
    c = np.roll(idx, -1, axis=1)[1:]
    d = idx[1:]
    F = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    return V, F.astype(np.int64)


def write_series(folder, meshes, surface="outer"):
    """Write meshes as frames f0.ply, f1.ply, ... of ``folder/surface``."""
    sub = folder / surface
    sub.mkdir(parents=True, exist_ok=True)
    for k, (V, F) in enumerate(meshes):
        write_ply(sub / f"f{k}.ply", V, F)
    return folder


class InPlace(concurrent.futures.Executor):
    """Runs each task when it is submitted (a worker pool whose tasks all start at once)."""

    def submit(self, fn, *args, **kwargs):
        fut = concurrent.futures.Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except Exception as exc:
            fut.set_exception(exc)
        return fut


def square_warning_on_odd(k: int) -> int:
    """k^2, with a warning for odd k (the same text for k = 1 and 3): for worker tests."""
    import warnings

    from oftimg.errors import OftimgWarning

    if k % 2:
        warnings.warn(f"odd {min(k, 3)}", OftimgWarning)
    return k * k


def retriangulated_tube(
    rng, *, radius_in=2.0, radius_out=None, length=10.0, n_vertices=3000, jitter=0.3
):
    """A straight tube (a cone if ``radius_out`` differs) along +z, meshed anew:
    a random start angle, vertices jittered along the surface by ``jitter`` of a
    step (the end rings' z kept), random quad diagonals, vertices and faces in a
    random order. Independent meshes of one rigid shape: the null test's frames.
    Returns ``V (n, 3)`` mm, ``F (m, 3)``, outward-oriented."""
    radius_out = radius_in if radius_out is None else radius_out
    n_th = max(12, int(round(np.sqrt(n_vertices * 2 * np.pi * radius_in / length))))
    n_s = max(4, n_vertices // n_th)
    z = np.linspace(0, length, n_s)[:, None] * np.ones((1, n_th))
    dz, dth = length / (n_s - 1), 2 * np.pi / n_th
    th = rng.uniform(0, 2 * np.pi) + dth * np.arange(n_th)[None, :] * np.ones((n_s, 1))
    jit = rng.uniform(-jitter, jitter, z.shape) * dz
    jit[[0, -1]] = 0.0
    z = z + jit
    th = th + rng.uniform(-jitter, jitter, th.shape) * dth
    r = radius_in + (radius_out - radius_in) * z / length
    V = np.stack([r * np.cos(th), r * np.sin(th), z], axis=-1).reshape(-1, 3)
    idx = np.arange(n_s * n_th).reshape(n_s, n_th)
    a, b = idx[:-1], np.roll(idx, -1, axis=1)[:-1]
    c, d = np.roll(idx, -1, axis=1)[1:], idx[1:]
    diag = rng.random(a.shape) < 0.5
    t1 = np.where(diag[..., None], np.stack([a, b, c], -1), np.stack([a, b, d], -1))
    t2 = np.where(diag[..., None], np.stack([a, c, d], -1), np.stack([b, c, d], -1))
    F = np.concatenate([t1.reshape(-1, 3), t2.reshape(-1, 3)])
    perm = rng.permutation(len(V))
    inv = np.argsort(perm)
    return V[perm], inv[F][rng.permutation(len(F))].astype(np.int64)


def label_phantom_area_errors(
    page, phantom_folder, n_frames: int, group: str = "normal", seed: int = 0
) -> dict:
    """|area / truth - 1| ``(n_v, n_t)`` per wall of a run's results ``page`` (its
    summary.json and arrays.npz) of a label phantom written with ``sample_params(group,
    seed, n_frames=n_frames)``, in the results' time order: each section against the
    square one at its own place along the phantom (its centroid's; a run whose ends
    were cut square begins past the window's inlet)."""
    import json

    from oftimg.synthetic.labels import in_phantom_frame, label_params
    from oftimg.synthetic.phantom import Phantom, sample_params

    summary = json.loads((page / "summary.json").read_text())
    arrays = np.load(page / "arrays.npz")
    truth = json.loads((phantom_folder / "truth.json").read_text())
    ph = Phantom(label_params(sample_params(group, seed, n_frames=n_frames)))
    t_ms = np.roll(np.array(truth["t_ms"]), -summary["t0_frame"])
    s_mm, _ = ph.window_coordinates(in_phantom_frame(phantom_folder, arrays["centroid_outer_mm"]))
    return {
        wall: np.abs(arrays[f"area_{wall}_mm2"] / ph.area_mm2(wall, s_mm, t_ms[None, :]) - 1)
        for wall in ("outer", "inner", "lumen")
    }


# ------------------------------------------------------ valid but unusual datasets
SMALL_MESH = dict(vertices_min=1200, vertices_max=1600)


def _phantom_case(
    folder,
    walls=("outer", "inner", "lumen"),
    *,
    group="normal",
    seed=5,
    n_frames=12,
    um=False,
    **overrides,
):
    """A phantom (:func:`~oftimg.synthetic.phantom.write_phantom`) with ``walls`` only;
    ``um``: its meshes and inlet given in µm (``length_unit`` "um")."""
    import json

    from oftimg.io.meshfile import read_mesh_file
    from oftimg.synthetic.phantom import sample_params, write_phantom

    params = sample_params(group, seed, n_frames=n_frames, **{**SMALL_MESH, **overrides})
    write_phantom(folder, params, walls=walls)
    if um:
        for path in sorted(folder.glob("*/*.ply")):
            V, F = read_mesh_file(path)
            write_ply(path, V * 1000.0, F)
        meta = json.loads((folder / "meta.json").read_text())
        meta.update(length_unit="um", inlet=[1000.0 * x for x in meta["inlet"]])
        (folder / "meta.json").write_text(json.dumps(meta))
    return folder


def _straight_case(folder, radii, n_frames=16):
    """A straight tube meshed anew in every frame (:func:`retriangulated_tube`), its
    radius ``radii(k)`` in frame ``k``: outer wall only, mm, 400 ms a beat."""
    import json

    rng = np.random.default_rng(1)
    write_series(
        folder,
        [retriangulated_tube(rng, radius_in=radii(k), n_vertices=1500) for k in range(n_frames)],
    )
    (folder / "meta.json").write_text(
        json.dumps(
            {"name": folder.name, "period_ms": 400.0, "length_unit": "mm", "inlet": [0, 0, 0]}
        )
    )
    return folder


def _label_case(folder, n_frames=8, voxel_um=(8.0, 8.0, 16.0), **kwargs):
    from oftimg.synthetic.labels import write_label_phantom
    from oftimg.synthetic.phantom import sample_params

    return write_label_phantom(
        folder, sample_params("normal", 2, n_frames=n_frames), voxel_um, **kwargs
    )


# name -> a function of an empty folder that writes the dataset there (issue 71, point 4)
UNUSUAL_DATASETS = {
    "rigid": lambda f: _straight_case(f, lambda k: 2.0),
    "breathing": lambda f: _straight_case(
        f, lambda k: 2.0 * (1 + 0.2 * np.sin(np.pi * k / 16) ** 4)
    ),
    "outer_alone": lambda f: _phantom_case(f, ("outer",)),
    "outer_and_lumen": lambda f: _phantom_case(f, ("outer", "lumen")),
    "five_frames": lambda f: _phantom_case(f, n_frames=5),
    "400_frames": lambda f: _phantom_case(
        f, ("outer",), n_frames=400, vertices_min=600, vertices_max=800
    ),
    "short_tube": lambda f: _phantom_case(f, length_mm=0.3, speed_knee_mm=0.12),
    "long_tube": lambda f: _phantom_case(
        f,
        length_mm=5.0,
        bend_radius_mm=3.0,
        radius_inlet_mm=0.1,
        radius_outlet_mm=0.07,
        speed_knee_mm=2.0,
        vertices_min=3000,
        vertices_max=3500,
    ),
    "um": lambda f: _phantom_case(f, um=True),
    "banded": lambda f: _phantom_case(f, group="banded", n_frames=16),
    "labels": _label_case,
    "labels_intensity": lambda f: _label_case(f, intensity=True),
    "probabilities": lambda f: _label_case(f, 6, (12.0, 12.0, 24.0), probabilities=True),
}


# what every dataset's results hold, by the walls and inputs it has (issue 71, point 4)
FIGURES = {
    "outer": {
        "area_derivative_outer",
        "area_map_outer",
        "frame_t0_contours",
        "max_area_profile",
        "ridge_speed",
        "shape_pca",
        "time_expanded",
        "volume_over_cycle",
    },
    "inner": {"trim_over_cycle", "wall_thickness_map"},
    "lumen": {"lumen_cushions"},
    "jelly": {"jelly_thickness_map"},
    "intensity": {"pullback_outer"},
}
VIDEOS = {
    "outer": {
        "area_map_cursor",
        "outer_wall_3d_area_map",
        "radial_curvature_outer",
        "radial_curvature_outer_normalized",
        "strain_energy_outer",
    },
    "inner": {"radial_curvature_inner", "strain_energy_inner", "wall_thickness"},
    "lumen": {"mean_curvature_lumen", "lumen_mean_curvature_3d"},
    "jelly": {"jelly_thickness"},
    "intensity": {"pullback_outer", "surface_speed_outer", "surface_divergence_outer"},
}


def expected_outputs(walls: set, intensity: bool) -> tuple[set, set]:
    """The figures and videos (names without suffix) of a dataset with ``walls``."""
    parts = (
        set(walls)
        | ({"jelly"} if {"inner", "lumen"} <= set(walls) else set())
        | ({"intensity"} if intensity else set())
    )
    return (
        set().union(*(FIGURES.get(p, set()) for p in parts)),
        set().union(*(VIDEOS.get(p, set()) for p in parts)),
    )


def run_to_the_end(dataset, work) -> dict:
    """``dataset`` through `oftimg run` (in this process, one job) and every export
    (`oftimg paraview`, `oftimg tiff`, `oftimg ome-zarr`, the napari reader), each checked to end with
    exit 0 and complete outputs: every figure and video its walls and inputs give,
    each readable and not blank; every file the pages link there; no "nan" where a
    person reads (pages, tables, warnings). Returns the dataset's summary."""
    import html
    import json
    import re
    from pathlib import Path

    import cv2
    import imageio.v3 as iio

    from oftimg.cli import main
    from oftimg.napari.reader import results_layers

    work = Path(work)
    out = work / "results"
    assert main(["run", str(dataset), "--out", str(out), "--quiet", "--jobs", "1"]) == 0
    folder = next(p for p in out.iterdir() if (p / "summary.json").is_file())
    summary = json.loads((folder / "summary.json").read_text())
    walls = {w for w in ("outer", "inner", "lumen") if (dataset / w).is_dir()} or set(
        summary["provenance"]["meshing"]["vertices"]
    )
    figures, videos = expected_outputs(walls, (dataset / "intensity").is_dir())
    assert {p.stem for p in (folder / "figures").glob("*.png")} >= figures
    assert {p.stem for p in (folder / "videos").glob("*.mp4")} >= videos
    for png in (folder / "figures").glob("*.png"):
        image = iio.imread(png)
        assert image.std() > 1, f"{png.name} is blank"
    for mp4 in (folder / "videos").glob("*.mp4"):
        video = cv2.VideoCapture(str(mp4))
        frames = int(video.get(cv2.CAP_PROP_FRAME_COUNT))
        video.set(cv2.CAP_PROP_POS_FRAMES, frames // 2)
        ok, frame = video.read()
        video.release()
        assert ok and frames >= summary["n_frames"] and frame.std() > 1, (
            f"{mp4.name}: {frames} frames, none readable or all blank"
        )
    for page in (out / "index.html", folder / "index.html"):
        text = page.read_text()
        for link in re.findall(r'(?:src|href)="([^"#:]+)"', text):
            assert (page.parent / html.unescape(link)).exists(), f"{page}: {link} missing"
        visible = re.sub(
            r"<[^>]+>", " ", re.sub(r"<(script|style)[^>]*>.*?</\1>", " ", text, flags=re.S)
        )
        assert not re.search(r"\bnan\b", visible, re.I), f"{page}: nan in the text"
    assert not re.search(r"\bnan\b", (out / "table1.md").read_text(), re.I)
    assert not [w for w in summary["warnings"] if re.search(r"\bnan\b", w, re.I)]
    page = (folder / "index.html").read_text()
    for warning in summary["warnings"]:  # each on the page, its path cut
        assert html.escape(warning.split(": ", 1)[-1]) in page, warning
    assert (
        main(["paraview", str(out), "--out", str(work / "paraview"), "--quiet", "--jobs", "1"]) == 0
    )
    assert any((work / "paraview").rglob("*.vt*"))
    assert main(["tiff", str(out), "--out", str(work / "tiff"), "--quiet"]) == 0
    assert any((work / "tiff").rglob("*.tif"))
    assert main(["ome-zarr", str(out), "--out", str(work / "ome-zarr"), "--quiet"]) == 0
    assert any((work / "ome-zarr").rglob("*.ome.zarr"))
    layers = results_layers(out)
    surfaces = [layer for layer in layers if layer[2] == "surface"]
    assert len(surfaces) == len(walls)
    assert any(layer[1]["name"].endswith(", unrolled") for layer in layers)  # fields as images
    if (dataset / "labels").is_dir() or (dataset / "intensity").is_dir():
        assert any(
            layer[1]["name"].endswith((": labels", ": intensity")) for layer in layers
        )  # its volumes too
    return summary
