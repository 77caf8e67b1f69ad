"""MP4 videos of (u, v, t) fields and (v, t) maps (H.264, yuv420p: plays in browsers).

Frames are drawn with NumPy and OpenCV (colour map with an explicit range,
nearest-neighbour upscaling, a colour bar and the frame time in a corner) and
encoded by imageio-ffmpeg's bundled ffmpeg. This is the one place where arrays
in (u, v, t) order become video order (frames, rows, cols, 3): v runs up the
picture (inlet at the bottom), u to the right.
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
from matplotlib import colormaps

from .image_order import in_image_order


@lru_cache(maxsize=None)
def _lut(cmap: str) -> np.ndarray:
    """The colour map's 256 entries as uint8 RGB ``(256, 3)``."""
    return np.round(colormaps[cmap](np.arange(256))[:, :3] * 255).astype(np.uint8)


def to_rgb(values: np.ndarray, vmin: float, vmax: float, cmap: str = "jet") -> np.ndarray:
    """Colour-map ``values`` with the explicit range [vmin, vmax] to uint8 RGB
    (NaN: grey), by table look-up (matplotlib's 256 colours)."""
    span = vmax - vmin if vmax > vmin else 1.0
    x = np.clip((np.nan_to_num(values, nan=vmin) - vmin) / span, 0.0, 1.0)
    rgb = _lut(cmap)[np.minimum((x * 256).astype(np.int64), 255)]
    rgb[~np.isfinite(values)] = 128
    return rgb


def _colour_bar(height: int, vmin: float, vmax: float, cmap: str, label: str) -> np.ndarray:
    bar = to_rgb(np.linspace(vmax, vmin, height)[:, None] * np.ones((1, 16)), vmin, vmax, cmap)
    panel = np.full((height, 112, 3), 255, np.uint8)
    panel[:, 4:20] = bar
    for text, y in ((f"{vmax:.3g}", 12), (f"{vmin:.3g}", height - 4)):
        cv2.putText(panel, text, (24, y), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 0), 1, cv2.LINE_AA)
    for k, word in enumerate(label.split()[:4]):
        cv2.putText(panel, word, (24, height // 2 - 10 + 13 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.36,
                    (0, 0, 0), 1, cv2.LINE_AA)
    return panel


def _stack(n: int, draw) -> np.ndarray:
    """Frames ``draw(t)`` for t < n in one preallocated ``(n, rows, cols, 3)`` array."""
    first = draw(0)
    out = np.empty((n,) + first.shape, np.uint8)
    out[0] = first
    for t in range(1, n):
        out[t] = draw(t)
    return out


def _even(img: np.ndarray, multiple: int = 16) -> np.ndarray:
    """Pad to a multiple of ``multiple`` pixels (H.264 macro blocks, even sizes)."""
    h, w = img.shape[:2]
    H, W = -(-h // multiple) * multiple, -(-w // multiple) * multiple
    out = np.full((H, W, 3), 255, np.uint8)
    out[:h, :w] = img
    return out


def field_frames(field: np.ndarray, t_ms: np.ndarray, *, vmin=None, vmax=None, cmap="jet",
                 label="", scale: int = 6, per_frame: bool = False, grid_note: str = ""):
    """Video frames ``(n_t, rows, cols, 3)`` uint8 of a ``(n_u, n_v, n_t)`` field.

    One colour range for the whole cycle (``vmin``/``vmax``, default the
    field's 1st and 99th percentiles), or with ``per_frame`` each frame's own.
    ``grid_note``: which grid the field is on ("tracked grid"), written under the
    time stamp.
    """
    finite = field[np.isfinite(field)]
    lo = np.percentile(finite, 1) if vmin is None else vmin
    hi = np.percentile(finite, 99) if vmax is None else vmax
    height = field.shape[1] * scale
    fixed_bar = None if per_frame else _colour_bar(height, lo, hi, cmap, label)

    def draw(t):
        img, _ = in_image_order(field[:, :, t], ["u", "v"])  # rows: v, inlet at the bottom
        a, b = lo, hi
        if per_frame:
            f = img[np.isfinite(img)]
            a, b = (f.min(), f.max()) if f.size else (0.0, 1.0)
        rgb = cv2.resize(to_rgb(img, a, b, cmap), None, fx=scale, fy=scale,
                         interpolation=cv2.INTER_NEAREST)
        bar = fixed_bar if fixed_bar is not None else _colour_bar(height, a, b, cmap, label)
        rgb = np.concatenate([rgb, bar], axis=1)
        for line, text in enumerate((f"t = {t_ms[t]:.0f} ms", grid_note)):
            for colour, weight in (((0, 0, 0), 3), ((255, 255, 255), 1)):   # outlined: any frame
                cv2.putText(rgb, text, (6, 16 + 16 * line), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                            colour, weight, cv2.LINE_AA)
        return _even(rgb)

    return _stack(field.shape[2], draw)


def map_cursor_frames(area: np.ndarray, t_ms: np.ndarray, *, width: int = 400,
                      height: int = 300, cmap="jet"):
    """Frames of a ``(n_v, n_t)`` map (about ``width`` x ``height`` pixels) with a
    moving time cursor."""
    sx = max(1, round(width / area.shape[1]))
    sy = max(1, round(height / area.shape[0]))
    image, _ = in_image_order(area, ["v", "t"])
    base = cv2.resize(to_rgb(image, np.nanmin(area), np.nanmax(area), cmap), None,
                      fx=sx, fy=sy, interpolation=cv2.INTER_NEAREST)
    base = np.concatenate([base, _colour_bar(base.shape[0], np.nanmin(area), np.nanmax(area),
                                             cmap, "area mm^2")], axis=1)
    def draw(t):
        img = base.copy()
        x = int((t + 0.5) * sx)
        img[:, max(0, x - 1):x + 1] = 255
        cv2.putText(img, f"t = {t_ms[t]:.0f} ms", (6, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (255, 255, 255), 1, cv2.LINE_AA)
        return _even(img)

    return _stack(area.shape[1], draw)


def write_mp4(path: Path, frames, *, fps: float = 30.0) -> Path:
    """Encode ``frames`` (``(n, rows, cols, 3)`` uint8, or an iterable of
    ``(rows, cols, 3)`` frames) as H.264/yuv420p MP4.

    x264's "ultrafast" preset at ``quality=7`` (CRF 15): measured on a 195-frame
    field video, a mean error of 1.4 of 255 (1.2 with "superfast" at CRF 10),
    0.6 s of encoder CPU instead of 0.9 and 2.0 MB instead of 2.5 MB; the
    arrays themselves are in ``arrays.npz``.
    """
    # format named: if imageio cannot load its ffmpeg plugin, it says so instead of
    # handing the .mp4 to another plugin (tifffile, whose error names an "fps" argument)
    writer = imageio.get_writer(str(path), format="FFMPEG", fps=fps, codec="libx264",
                                pixelformat="yuv420p", macro_block_size=16, quality=7,
                                ffmpeg_log_level="error", ffmpeg_params=["-preset", "ultrafast"])
    try:
        for frame in frames:
            writer.append_data(frame)
    finally:
        writer.close()
    return path


# (file, array, per-pixel normalized?, field_frames options): the (u, v) field videos
FIELD_VIDEOS = [
    ("radial_curvature_outer", "radial_curvature_outer_per_mm", False,
     dict(cmap="coolwarm", label="curvature 1/mm")),
    ("radial_curvature_outer_normalized", "radial_curvature_outer_per_mm", True,
     dict(vmin=0, vmax=1, cmap="gray", label="per-pixel normalized")),
    ("strain_energy_outer", "strain_energy_outer", False,
     dict(cmap="RdYlGn_r", label="strain energy")),
    ("strain_energy_outer_per_frame", "strain_energy_outer", False,
     dict(cmap="RdYlGn_r", per_frame=True, label="strain energy (frame)")),
    ("radial_curvature_inner", "radial_curvature_inner_per_mm", False,
     dict(cmap="coolwarm", label="curvature 1/mm")),
    ("strain_energy_inner", "strain_energy_inner", False,
     dict(cmap="RdYlGn_r", label="strain energy")),
    ("wall_thickness", "wall_thickness_mm", False,
     dict(cmap="viridis", label="wall thickness mm")),
    ("jelly_thickness", "jelly_thickness_mm", False,
     dict(cmap="viridis", label="jelly thickness mm")),
    ("mean_curvature_lumen", "mean_curvature_lumen_per_mm", False,
     dict(cmap="coolwarm", label="mean curv. 1/mm")),
]


# the tasks that need only the aligned area maps, grids and lumen mean curvature
# (:func:`oftimg.analysis.pipeline.analyse_dataset`'s ``on_aligned``): the slow 3-D renders;
# the others need the shape fields
EARLY_VIDEOS = ("area", "lumen_3d")
LATER_VIDEOS = ("field",)


def video_tasks(arrays: dict, grids: dict | None = None, kinds=None, *,
                grid_note: str = "") -> list[tuple]:
    """The videos of one dataset as independent ``(kind, inputs)`` tasks for
    :func:`render_videos`, each holding only the arrays it needs; only those of
    ``kinds`` (default: all). ``grid_note``: which grid the (u, v) fields are on,
    written on their frames."""
    if kinds is not None:
        return [t for t in video_tasks(arrays, grids, grid_note=grid_note) if t[0] in kinds]
    t_ms = arrays["t_ms"]
    # the slow 3-D renders first, so that workers finish together;
    # the area-map cursor frames are drawn once for both videos that show them
    tasks = [("area", dict(area=arrays["area_outer_mm2"], t_ms=t_ms,
                           grid=None if grids is None else grids["outer"]))]
    h = arrays.get("mean_curvature_lumen_per_mm")
    if grids is not None and h is not None and "lumen" in grids:
        tasks.append(("lumen_3d", dict(grid=grids["lumen"], h=h, t_ms=t_ms)))
    tasks += [("field", dict(name=name, field=arrays[key], normalize=normalize, t_ms=t_ms,
                             options=dict(opts, grid_note=grid_note)))
              for name, key, normalize, opts in FIELD_VIDEOS if key in arrays]
    return tasks


def render_videos(kind: str, inputs: dict, fps: float = 30.0) -> list[tuple[str, bytes]]:
    """Encode one task's videos; returns ``(file name, MP4 bytes)`` pairs (so that
    a worker on another machine need not see the output folder)."""
    import tempfile

    from ..image.normalize import per_pixel_normalize

    t_ms = inputs["t_ms"]
    if kind == "field":
        field = per_pixel_normalize(inputs["field"]) if inputs["normalize"] else inputs["field"]
        movies = {inputs["name"]: field_frames(field, t_ms, **inputs["options"])}
    elif kind == "area":
        cursor = map_cursor_frames(inputs["area"], t_ms)
        movies = {"area_map_cursor": cursor}
        G = inputs["grid"]
        if G is not None:
            area_field = np.broadcast_to(inputs["area"][None], G.shape[:3])
            movies["outer_wall_3d_area_map"] = surface_and_map_frames(
                G, area_field, t_ms, cmap="jet", flat=cursor)
    elif kind == "lumen_3d":
        movies = {"lumen_mean_curvature_3d": surface_and_map_frames(
            inputs["grid"], inputs["h"], t_ms, label="mean curv. 1/mm")}
    else:
        raise ValueError(f"unknown video task {kind!r}")
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, frames in movies.items():
            path = write_mp4(Path(tmp) / f"{name}.mp4", frames, fps=fps)
            out.append((path.name, path.read_bytes()))
    return out


def start_videos(arrays: dict, grids: dict | None = None, *, fps: float = 30.0,
                 executor=None, kinds=None, grid_note: str = ""):
    """Submit a dataset's video tasks (those of ``kinds``, default all) to
    ``executor`` (without one, render them now); pass the result to
    :func:`save_videos`. In between the caller is free to do other work (the
    figures) while the workers render. ``grid_note``: see :func:`video_tasks`."""
    tasks = [(kind, inputs, fps)
             for kind, inputs in video_tasks(arrays, grids, kinds, grid_note=grid_note)]
    if executor is None:
        return [render_videos(*args) for args in tasks]
    return [executor.submit(render_videos, *args) for args in tasks]


def save_videos(folder: Path, pending: list) -> list[Path]:
    """Write the videos of :func:`start_videos` into ``folder``; returns their paths."""
    out = []
    for task in pending:
        for name, data in (task.result() if hasattr(task, "result") else task):
            (folder / name).write_bytes(data)
            out.append(folder / name)
    return out


def dataset_videos(folder: Path, arrays: dict, grids: dict | None = None, *,
                   fps: float = 30.0, executor=None, grid_note: str = "") -> list[Path]:
    """All per-dataset videos into ``folder`` (``videos/``), rendered in
    ``executor``'s workers when one is given."""
    return save_videos(folder, start_videos(arrays, grids, fps=fps, executor=executor,
                                            grid_note=grid_note))


# ------------------------------------------------------------------ 3-D renders
class SurfaceCamera:
    """A fixed pinhole camera looking at a deforming grid along its thinnest axis.

    Set up once from all frames ``G (n_u, n_v, n_t, 3)`` so every frame is
    seen from the same place; renders headless with open3d's ray casting (no
    display, no GPU). With ``crop``, rays are cast only in the window that any
    frame projects into (the same pictures, fewer rays).
    """

    def __init__(self, G: np.ndarray, *, size: int = 320, fov_deg: float = 40.0,
                 crop: bool = True):
        pts = G.reshape(-1, 3)
        pts = pts[np.isfinite(pts).all(axis=1)]
        center = pts.mean(axis=0)
        _, _, axes = np.linalg.svd(pts - center, full_matrices=False)
        view = axes[2]                        # normal of the plane the tube bends in
        radius = np.linalg.norm(pts - center, axis=1).max()
        dist = 1.15 * radius / np.sin(np.radians(fov_deg) / 2)
        self.eye = center + dist * view
        self.center, self.up, self.size, self.fov = center, axes[0], size, fov_deg
        self.light = view
        import open3d as o3d

        from ..mesh.strain import grid_triangles

        rays = self._all_rays()
        self._window = self.window(pts, rays) if crop else (slice(0, size), slice(0, size))
        # made once for all frames: the rays of the pixels any frame can cover, the triangles
        self._rays = o3d.core.Tensor(np.ascontiguousarray(rays[self._window]))
        self._F = grid_triangles(*G.shape[:2])
        self._F_tensor = o3d.core.Tensor(self._F.astype(np.uint32))

    def _all_rays(self) -> np.ndarray:
        """Ray origins and directions ``(size, size, 6)`` of every pixel."""
        import open3d as o3d

        return o3d.t.geometry.RaycastingScene.create_rays_pinhole(
            self.fov, self.center.tolist(), self.eye.tolist(), self.up.tolist(), self.size,
            self.size).numpy()

    def window(self, pts: np.ndarray, rays: np.ndarray, margin: int = 2) -> tuple[slice, slice]:
        """Rows and columns of the pixels onto which the points ``pts (n, 3)`` project
        (plus ``margin``), for the camera's ``rays`` (:meth:`_all_rays`): the pinhole's
        ray directions are affine in the pixel indices on the plane of their tips, so
        two steps of it invert the projection."""
        d00, d01, d10 = rays[0, 0, 3:], rays[0, 1, 3:], rays[1, 0, 3:]
        col_step, row_step = d01 - d00, d10 - d00
        ahead = np.cross(col_step, row_step)          # normal of the tips' plane
        rel = pts - self.eye
        tips = rel * ((d00 @ ahead) / (rel @ ahead))[:, None] - d00
        col = tips @ col_step / (col_step @ col_step)
        row = tips @ row_step / (row_step @ row_step)
        lo = np.floor([row.min(), col.min()]).astype(int) - margin
        hi = np.ceil([row.max(), col.max()]).astype(int) + margin + 1
        lo, hi = np.clip(lo, 0, self.size), np.clip(hi, 0, self.size)
        return slice(lo[0], hi[0]), slice(lo[1], hi[1])

    def render(self, X: np.ndarray, values: np.ndarray, *, vmin: float, vmax: float,
               cmap: str = "coolwarm") -> np.ndarray:
        """RGB uint8 ``(size, size, 3)`` of the grid surface ``X (n_u, n_v, 3)`` (a frame of
        the camera's ``G``) coloured by ``values (n_u, n_v)`` with simple Lambert shading
        on a white background."""
        import open3d as o3d

        F = self._F
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(X.reshape(-1, 3).astype(np.float32)), self._F_tensor)
        hit = scene.cast_rays(self._rays)
        prim = hit["primitive_ids"].numpy().astype(np.int64)
        ok = prim != np.iinfo(np.uint32).max
        img = np.full((self.size, self.size, 3), 255, np.uint8)
        if not ok.any():
            return img
        view = img[self._window]                      # only its pixels can show the tube
        tri = F[prim[ok]]
        b = hit["primitive_uvs"].numpy()[ok].astype(float)
        w = np.column_stack([1 - b.sum(axis=1), b])
        val = np.einsum("ij,ij->i", w, values.reshape(-1)[tri])
        normals = hit["primitive_normals"].numpy()[ok]
        shade = 0.35 + 0.65 * np.abs(normals @ self.light)
        rgb = to_rgb(val, vmin, vmax, cmap).astype(float) * shade[:, None]
        view[ok] = np.clip(rgb, 0, 255).astype(np.uint8)
        return img


def _fit_height(img: np.ndarray, height: int) -> np.ndarray:
    scale = height / img.shape[0]
    return cv2.resize(img, (int(round(img.shape[1] * scale)), height),
                      interpolation=cv2.INTER_NEAREST)


def surface_and_map_frames(G: np.ndarray, values: np.ndarray, t_ms: np.ndarray, *,
                           flat: np.ndarray | None = None, cmap: str = "coolwarm",
                           label: str = "", size: int = 320):
    """Frames ``(rows, cols, 3)`` uint8, one at a time (a 195-frame video would hold
    ~190 MB): the 3-D grid surface coloured by ``values (n_u, n_v, n_t)`` next to a
    flat picture (default the unfolded (u, v) map of the same values)."""
    finite = values[np.isfinite(values)]
    lo, hi = np.percentile(finite, [1, 99])
    camera = SurfaceCamera(G, size=size)
    if flat is None:
        flat = field_frames(values, t_ms, vmin=lo, vmax=hi, cmap=cmap, label=label, scale=4)
    def draw(t):
        view = camera.render(G[:, :, t], values[:, :, t], vmin=lo, vmax=hi, cmap=cmap)
        return _even(np.concatenate([view, _fit_height(flat[t], size)], axis=1))

    return (draw(t) for t in range(G.shape[2]))
