"""Animate any static open tube with a known peristaltic wave (ground truth for real shapes).

Axial position comes from a harmonic coordinate h (0 on the inlet loop, 1 on
the outlet loop); the centroid of each h-slab gives a centre line whose arc
length is s (mm). Every vertex moves away from its slab's centroid by the
factor ``1 + A w(t - s / C)`` with the smooth periodic pulse
``w(phi) = sin^4(pi phi)`` (period T), so a section's area peaks when
``t = s / C + T / 2``: the wave travels at C (mm/s) from inlet to outlet. Its fronts
may wind round the tube (a helix) or come first on one side, as the phantom's do
(:func:`~oftimg.synthetic.phantom.front_lag_ms`), by the angle round the centre line
from a frame carried along it without turning (0 towards the inside of a bend).

On top of the wave, the tissue may slide within the surface as a beating heart's
does: a twist about the centre line that grows from 0 at the inlet to
``twist_deg`` at the outlet, and a longitudinal shortening towards the inlet by
``shortening`` of each point's arc length (each ring slid along the centre line
and turned with its tangent, so it stays across the tube), both following
``w(t / T)`` (0 at t = 0, full at T / 2). Each written frame's vertices are traced back to the
static mesh (``truth/``), so how far a grid drifts from the tissue can be
measured on any real shape.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..mesh.parameterize import harmonic_map, intrinsic_weights
from ..mesh.topology import MeshError, capped_signed_volume, check_tube, face_areas, loop_centroid
from .phantom import front_lag_ms


# Gaussian sigma (slabs) of the centre line's smoothing before the frame that angles
# round the tube are measured from is carried along it
FRAME_SMOOTHING_SLABS = 2.0


@dataclass(frozen=True)
class Animation:
    """The applied wave."""

    speed_mm_s: float
    amplitude: float
    period_ms: float
    n_frames: int
    twist_deg: float = 0.0
    shortening: float = 0.0
    helix_starts: int = 0  # the front winds this many times round the tube
    side_lag_ms: float = 0.0  # the front reaches the side opposite side_deg this late
    side_deg: float = 0.0  # where round the tube the front comes first

    def __post_init__(self):
        if self.speed_mm_s == 0 or not np.isfinite(self.speed_mm_s):
            raise InputError(f"speed_mm_s must be finite and non-zero, found {self.speed_mm_s}")
        if not -0.9 < self.amplitude < 2:
            raise InputError(f"amplitude must be in (-0.9, 2), found {self.amplitude}")
        if self.period_ms <= 0 or self.n_frames < 3:
            raise InputError("period_ms must be positive and n_frames at least 3")
        if not abs(self.twist_deg) <= 180:
            raise InputError(f"twist_deg must be within ±180 degrees, found {self.twist_deg}")
        if not 0 <= self.shortening < 0.9:
            raise InputError(f"shortening must be in [0, 0.9), found {self.shortening}")
        if self.helix_starts != int(self.helix_starts):
            raise InputError(f"helix_starts must be a whole number, found {self.helix_starts}")
        if not 0 <= self.side_lag_ms < self.period_ms:
            raise InputError(f"side_lag_ms must be in [0, period_ms), found {self.side_lag_ms}")

    def front_lag_ms(self, theta):
        """How much later than at angle 0 the front reaches angle ``theta`` (ms)."""
        return front_lag_ms(
            theta, self.period_ms, int(self.helix_starts), self.side_lag_ms, self.side_deg
        )


def pulse(phi):
    """Smooth periodic pulse in [0, 1], maximum at phi = 0.5."""
    return np.sin(np.pi * np.mod(phi, 1.0)) ** 4


def axial_coordinates(V, F, inlet, outlet, *, n_slabs: int = 64):
    """Harmonic coordinate ``h (n,)``, slab centroids ``(n_slabs, 3)``, their arc length
    ``s (n_slabs,)`` mm and each vertex's arc length and centroid."""
    W = intrinsic_weights(V, F, authalic_weight=0.0).tocoo()
    floor = 1e-3 * float(np.median(np.abs(W.data)))
    import scipy.sparse as sp

    W = sp.csr_matrix((np.maximum(W.data, floor), (W.row, W.col)), shape=W.shape)
    boundary = np.concatenate([inlet, outlet])
    values = np.concatenate([np.zeros(len(inlet)), np.ones(len(outlet))])[:, None]
    h = harmonic_map(W, boundary, np.repeat(values, 2, axis=1))[:, 0]
    # vertex areas as weights of the slab centroids
    area = np.zeros(len(V))
    fa = face_areas(V, F)
    for k in range(3):
        np.add.at(area, F[:, k], fa / 3)
    edges = np.linspace(0, 1, n_slabs + 1)
    slab = np.clip(np.searchsorted(edges, h, side="right") - 1, 0, n_slabs - 1)
    w = np.bincount(slab, weights=area, minlength=n_slabs)
    cent = (
        np.stack(
            [np.bincount(slab, weights=area * V[:, d], minlength=n_slabs) for d in range(3)], axis=1
        )
        / np.maximum(w, 1e-300)[:, None]
    )
    h_mid = 0.5 * (edges[1:] + edges[:-1])
    ok = w > 0
    h_mid, cent = h_mid[ok], cent[ok]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(cent, axis=0), axis=1))])
    s_v = np.interp(h, h_mid, s)
    c_v = np.stack([np.interp(h, h_mid, cent[:, d]) for d in range(3)], axis=1)
    return h, cent, s, s_v, c_v


def centre_line_frame(cent: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents and normals ``(n_slabs, 3)`` of a centre line ``cent`` at arc
    lengths ``s`` (mm), along :func:`smoothed_line`: the normal carried from the line's
    middle towards either end without turning about the tangent (projected onto each
    next normal plane), starting towards the midpoint of the line's ends (the inside of
    a bend; any normal of a straight line). From the middle: the ends' centroids are
    the least sure (a slab there may hold part of a ring)."""
    cent = smoothed_line(cent)
    tangent = np.gradient(cent, s, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    middle = len(cent) // 2
    start = 0.5 * (cent[0] + cent[-1]) - cent[middle]
    normal = start - (start @ tangent[middle]) * tangent[middle]
    if np.linalg.norm(normal) < 1e-6 * max(s[-1], 1e-300):
        normal = np.cross(tangent[middle], np.eye(3)[np.argmin(np.abs(tangent[middle]))])
    normals = np.empty_like(cent)
    for order in (range(middle, len(cent)), range(middle, -1, -1)):
        carried = normal
        for k in order:
            carried = carried - (carried @ tangent[k]) * tangent[k]
            carried /= np.linalg.norm(carried)
            normals[k] = carried
    return tangent, normals


def smoothed_line(cent: np.ndarray) -> np.ndarray:
    """The slabs' centroids ``(n_slabs, 3)`` smoothed along the line (Gaussian of
    :data:`FRAME_SMOOTHING_SLABS`, its ends kept by linear extrapolation): where the
    harmonic coordinate's slabs cut the rings obliquely (a bend) the centroids zig-zag,
    and a frame carried along a zig-zag turns at random."""
    from scipy.ndimage import gaussian_filter1d

    pad = int(4 * FRAME_SMOOTHING_SLABS)
    ahead = cent[-1] + (cent[-1] - cent[-2]) * np.arange(1, pad + 1)[:, None]
    behind = cent[0] - (cent[1] - cent[0]) * np.arange(pad, 0, -1)[:, None]
    padded = np.concatenate([behind, cent, ahead])
    return gaussian_filter1d(padded, FRAME_SMOOTHING_SLABS, axis=0)[pad:-pad]


def around_angles(
    points: np.ndarray, s_points: np.ndarray, cent: np.ndarray, s: np.ndarray
) -> np.ndarray:
    """The angle (rad) round the centre line ``cent`` (at arc lengths ``s``) of
    ``points (n, 3)`` mm lying at arc lengths ``s_points (n,)``: about
    :func:`smoothed_line`, from :func:`centre_line_frame`'s normal there, right-handed
    about the tangent."""
    tangent, normals = centre_line_frame(cent, s)

    def at(values):
        return np.stack([np.interp(s_points, s, values[:, d]) for d in range(3)], axis=1)

    t_p, n_p = at(tangent), at(normals)
    n_p -= np.einsum("ij,ij->i", n_p, t_p)[:, None] * t_p / np.einsum("ij,ij->i", t_p, t_p)[:, None]
    radial = points - at(smoothed_line(cent))
    b_p = np.cross(t_p, n_p)
    return np.arctan2(np.einsum("ij,ij->i", radial, b_p), np.einsum("ij,ij->i", radial, n_p))


def animate_frames(V, F, inlet, outlet, anim: Animation):
    """Yield ``(t_ms, V_t)`` for every frame (same connectivity ``F``)."""
    _, cent, s, s_v, c_v = axial_coordinates(V, F, inlet, outlet)
    tangent = np.gradient(cent, s, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    t_v = np.stack([np.interp(s_v, s, tangent[:, d]) for d in range(3)], axis=1)
    t_v /= np.linalg.norm(t_v, axis=1, keepdims=True)
    lag_ms = anim.front_lag_ms(around_angles(V, s_v, cent, s))
    for k in range(anim.n_frames):
        t = k * anim.period_ms / anim.n_frames
        phi = (t - 1e3 * s_v / anim.speed_mm_s - lag_ms) / anim.period_ms
        R = (V - c_v) * (1.0 + anim.amplitude * pulse(phi))[:, None]
        beat = pulse(t / anim.period_ms)
        if anim.twist_deg:
            R = _rotated(R, t_v, np.radians(anim.twist_deg) * beat * s_v / s[-1])
        centre = c_v
        if anim.shortening:  # each ring slid along the centre line, turned
            to = s_v * (1.0 - anim.shortening * beat)  # with its tangent there
            centre = np.stack([np.interp(to, s, cent[:, d]) for d in range(3)], axis=1)
            t_to = np.stack([np.interp(to, s, tangent[:, d]) for d in range(3)], axis=1)
            t_to /= np.linalg.norm(t_to, axis=1, keepdims=True)
            axis = np.cross(t_v, t_to)
            sin = np.linalg.norm(axis, axis=1)
            angle = np.arctan2(sin, np.einsum("ij,ij->i", t_v, t_to))
            axis = np.where(sin[:, None] > 1e-12, axis / np.maximum(sin, 1e-300)[:, None], t_v)
            R = _rotated(R, axis, angle)
        yield t, centre + R


def _rotated(R: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Vectors ``R (n, 3)`` turned by ``angle (n,)`` rad about unit ``axis (n, 3)``
    (Rodrigues)."""
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    along = np.einsum("ij,ij->i", axis, R)[:, None]
    return R * c + np.cross(axis, R) * s + axis * along * (1 - c)


def static_points(Vt: np.ndarray, F: np.ndarray, V_static: np.ndarray, W: np.ndarray):
    """Where each point ``W (m, 3)`` of an animated frame ``(Vt, F)`` came from on the
    static mesh ``(V_static, F)``: its closest point on the frame, the triangle
    ``(m,)`` and barycentric coordinates ``(m, 3)`` there, and that point of the
    static mesh ``(m, 3)``."""
    import open3d as o3d

    mid = Vt.mean(axis=0)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor((Vt - mid).astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32))
    )
    hit = scene.compute_closest_points(o3d.core.Tensor((W - mid).astype(np.float32)))
    tri = hit["primitive_ids"].numpy().astype(np.int64)
    uv = hit["primitive_uvs"].numpy().astype(np.float64)
    bary = np.stack([1.0 - uv.sum(axis=1), uv[:, 0], uv[:, 1]], axis=1)
    return tri, bary, np.einsum("mk,mkd->md", bary, V_static[F[tri]])


def remesh(V, F, rng, *, keep=(0.5, 0.9), tries: int = 5):
    """Decimate to a random share of the faces (boundary kept) and shuffle the order.

    Returns a new open tube ``(V, F)``; falls back to shuffling alone if
    decimation does not leave a tube.
    """
    import open3d as o3d

    for _ in range(tries):
        m = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(V), o3d.utility.Vector3iVector(F.astype(np.int32))
        )
        target = int(len(F) * rng.uniform(*keep))
        d = m.simplify_quadric_decimation(target, boundary_weight=1e4)
        d.remove_unreferenced_vertices()
        V2, F2 = np.asarray(d.vertices), np.asarray(d.triangles).astype(np.int64)
        try:
            check_tube(V2, F2)
        except MeshError:
            continue
        V, F = V2, F2
        break
    perm = rng.permutation(len(V))
    inv = np.argsort(perm)
    return V[perm], inv[F][rng.permutation(len(F))]


def _own_vertices(F: np.ndarray, n_vert: int) -> np.ndarray:
    """A triangle ``(n_vert,)`` at each vertex (the last one listed there)."""
    tri = np.zeros(n_vert, dtype=np.int64)
    tri[F.ravel()] = np.repeat(np.arange(len(F)), 3)
    return tri


TEXTURE_VOXELS = 2.0e6  # about so many voxels in a textured animation's volume
TEXTURE_DEPTH_VOXELS = 3.0  # the texture's thickness about the surface (Gaussian sigma)
TEXTURE_BLOB_VOXELS = 1.5  # its grain in the static tissue (Gaussian sigma)


class StaticTexture:
    """A random texture fixed in the static tube's tissue: a smooth random field on a
    lattice of ``voxel`` mm over the static mesh's box (plus a margin), read at static
    points; values about 1 (SD 0.35), blobs of :data:`TEXTURE_BLOB_VOXELS`."""

    def __init__(self, V_static: np.ndarray, voxel: float, rng: np.random.Generator):
        from .texture import random_texture

        self.origin = V_static.min(axis=0) - 4 * voxel
        self.voxel = voxel
        shape = np.ceil((V_static.max(axis=0) + 4 * voxel - self.origin) / voxel).astype(int) + 1
        self.values = random_texture(tuple(shape), TEXTURE_BLOB_VOXELS, rng)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        from scipy.ndimage import map_coordinates

        return map_coordinates(
            self.values, ((points - self.origin) / self.voxel).T, order=1, mode="nearest"
        )


def intensity_box(
    frames: list[np.ndarray], n_voxels: float = TEXTURE_VOXELS
) -> tuple[np.ndarray, float, tuple[int, int, int]]:
    """The volume that holds every frame ``(n, 3)`` mm with a margin: its origin (x, y,
    z) mm, its cubic voxel (mm, about ``n_voxels`` in all) and its shape (z, y, x)."""
    lo = np.min([f.min(axis=0) for f in frames], axis=0)
    hi = np.max([f.max(axis=0) for f in frames], axis=0)
    extent = hi - lo
    voxel = float((np.prod(extent) / n_voxels) ** (1 / 3))
    origin = lo - 6 * voxel
    shape = tuple(int(n) for n in (np.ceil((extent + 12 * voxel) / voxel) + 1)[::-1])
    return origin, voxel, shape


def textured_frame(
    Vt: np.ndarray,
    F: np.ndarray,
    V_static: np.ndarray,
    texture: StaticTexture,
    origin: np.ndarray,
    voxel: float,
    shape: tuple,
    rng: np.random.Generator,
) -> np.ndarray:
    """One frame's intensity ``(z, y, x)`` uint8: at each voxel near the animated
    surface ``(Vt, F)``, the texture at the static point its closest surface point came
    from, fading with the distance (:data:`TEXTURE_DEPTH_VOXELS`); times a speckle new
    in every frame, plus noise, on a dark background (:func:`~oftimg.synthetic.texture.imaged`)."""
    from .texture import LEVEL, imaged

    k, j, i = np.indices(shape)
    points = origin + np.stack([i, j, k], axis=-1).reshape(-1, 3) * voxel
    tri, bary, came_from = static_points(Vt, F, V_static, points)
    on_surface = np.einsum("mk,mkd->md", bary, Vt[F[tri]])
    depth = np.linalg.norm(points - on_surface, axis=1) / voxel
    near = depth < 4 * TEXTURE_DEPTH_VOXELS
    out = np.full(len(points), LEVEL["background"], np.float32)
    out[near] += (
        LEVEL["myocardium"]
        * texture(came_from[near])
        * np.exp(-0.5 * (depth[near] / TEXTURE_DEPTH_VOXELS) ** 2)
    )
    return imaged(out.reshape(shape), rng)


def write_animation(
    mesh_path,
    out,
    anim: Animation,
    *,
    scale_to_mm: float = 1.0,
    do_remesh: bool = False,
    seed: int = 0,
    progress=None,
    texture: bool = False,
    texture_voxels: float = TEXTURE_VOXELS,
) -> Path:
    """Write an animated dataset (meta.json, outer/, truth.json, truth/) from one static
    tube; ``out`` appears only when complete.

    ``truth/static.ply`` is the static mesh in mm; ``truth/<frame>.npz`` gives, for
    every vertex of that frame, the point of the static mesh it came from:
    ``static_point_mm (n, 3)``, on the static triangle ``triangle (n,)`` at the
    barycentric coordinates ``barycentric (n, 3)`` (for a remeshed frame, of the
    vertex's closest point on the animated surface before remeshing). With
    ``texture``, ``intensity/f000.tif ...`` too (:func:`textured_frame`: a texture
    fixed in the tissue, so that it twists and shortens with it) on about
    ``texture_voxels`` cubic voxels, placed by meta.json's ``intensity``."""
    from ..output.export import require_new_folder, staged_output
    from ..io.tube import load_tube
    from ..io.meshfile import write_ply

    if not (np.isfinite(scale_to_mm) and scale_to_mm > 0):
        raise InputError(f"the scale to mm must be positive, found {scale_to_mm}")
    out = Path(out)
    require_new_folder(out)
    tube = load_tube(mesh_path, unit_scale=scale_to_mm)
    V, F = tube.V, tube.F
    rng = np.random.default_rng(seed)
    _, _, s, _, _ = axial_coordinates(V, F, tube.inlet, tube.outlet)
    volumes = []
    width = len(str(anim.n_frames - 1))
    frames = list(animate_frames(V, F, tube.inlet, tube.outlet, anim))
    if texture:
        import tifffile

        box = intensity_box([Vt for _, Vt in frames], texture_voxels)
        tissue = StaticTexture(V, box[1], np.random.default_rng([seed, 67]))
        speckle_rng = np.random.default_rng([seed, 71])
    with staged_output(out) as tmp:
        (tmp / "outer").mkdir()
        (tmp / "truth").mkdir()
        write_ply(tmp / "truth" / "static.ply", V, F)
        if texture:
            (tmp / "intensity").mkdir()
        for k, (t, Vt) in enumerate(frames):
            if texture:
                tifffile.imwrite(
                    tmp / "intensity" / f"f{k:0{width}d}.tif",
                    textured_frame(Vt, F, V, tissue, *box, speckle_rng),
                    compression="zlib",
                )
            volumes.append(capped_signed_volume(Vt, F, [tube.inlet, tube.outlet]))
            Vw, Fw = remesh(Vt, F, rng) if do_remesh else (Vt, F)
            write_ply(tmp / "outer" / f"f{k:0{width}d}.ply", Vw, Fw)
            if do_remesh:
                tri, bary, came_from = static_points(Vt, F, V, Vw)
            else:  # each vertex is its own static vertex
                tri, came_from = _own_vertices(F, len(V)), V
                bary = (F[tri] == np.arange(len(V))[:, None]).astype(float)
            np.savez_compressed(
                tmp / "truth" / f"f{k:0{width}d}.npz",
                static_point_mm=came_from,
                triangle=tri,
                barycentric=bary,
            )
            if progress:
                progress(k + 1)
        meta = {
            "name": out.name,
            "group": "animated",
            "period_ms": anim.period_ms,
            "length_unit": "mm",
            "inlet": loop_centroid(V[tube.inlet]).tolist(),
        }
        if texture:
            meta["intensity"] = {"voxel_size": [box[1]] * 3, "origin": box[0].tolist()}
        (tmp / "meta.json").write_text(json.dumps(meta, indent=2))
        s_grid = np.linspace(0, s[-1], 101)
        truth = {
            "animation": asdict(anim),
            "source": str(mesh_path),
            "scale_to_mm": scale_to_mm,
            "remeshed": do_remesh,
            "seed": seed,
            "centre_line_length_mm": float(s[-1]),
            "s_mm": s_grid.tolist(),
            "arrival_ms": (1e3 * s_grid / anim.speed_mm_s % anim.period_ms).tolist(),
            "ridge_t_ms": (
                (1e3 * s_grid / anim.speed_mm_s + anim.period_ms / 2) % anim.period_ms
            ).tolist(),
            "wave_speed_mm_s": {"cycle": anim.speed_mm_s},
            "volume_mm3": volumes,
        }
        (tmp / "truth.json").write_text(json.dumps(truth, indent=1))
    return out


def grid_material_points(dataset, grid: np.ndarray, t0_frame: int) -> np.ndarray:
    """Where on the static mesh each node of an analysed grid sat: ``(n_u, n_v, n_t, 3)``
    mm, from an animated ``dataset`` folder's ``truth/`` and its frames.

    ``grid (n_u, n_v, n_t, 3)`` mm in aligned time (frame ``t`` of the grid is file
    ``(t + t0_frame) % n_t``, as in an unwarped analysis). Each node goes to its
    closest point on its frame's written mesh, and on through that triangle's
    vertices' static points."""
    from ..io.dataset import load_dataset
    from ..io.meshfile import read_mesh_file

    ds = load_dataset(dataset)
    n_t = grid.shape[2]
    out = np.empty(grid.shape)
    for t in range(n_t):
        path = ds.frames["outer"][(t + t0_frame) % n_t]
        V, F = read_mesh_file(path)
        V = V * ds.meta.scale_to_mm
        static = np.load(Path(dataset) / "truth" / f"{path.stem}.npz")["static_point_mm"]
        X = grid[:, :, t].reshape(-1, 3)
        out[:, :, t] = static_points(V, F, static, X)[2].reshape(grid.shape[:2] + (3,))
    return out


def wave_arrival_ms(dataset, points: np.ndarray) -> np.ndarray:
    """When the drawn wave reaches the static mesh's ``points (n, 3)`` mm of an animated
    ``dataset``: ``(n,)`` ms, not wrapped into the cycle (0 at the inlet, growing by
    the period over each ``speed x period`` along the animation's centre line), plus
    its front's lag round the tube (:meth:`Animation.front_lag_ms`).

    Measured against a run's own positions along the tube (one row's tissue, its
    ``s_mm``), this gives the wave's true speed in the run's coordinates: the
    animation's own arc length depends on how finely its centre line is sampled on a
    coiled tube (the midgut's 0.41-0.72 mm for 8-128 slabs), so its speed in those
    units is not a number a run can be held to."""
    from ..io.tube import load_tube

    truth = json.loads((Path(dataset) / "truth.json").read_text())
    tube = load_tube(Path(dataset) / "truth" / "static.ply")
    anim = Animation(**truth["animation"])
    _, cent, s, s_v, _ = axial_coordinates(tube.V, tube.F, tube.inlet, tube.outlet)
    tri, bary, on_mesh = static_points(tube.V, tube.F, tube.V, np.asarray(points, float))
    s_points = np.einsum("mk,mk->m", bary, s_v[tube.F[tri]])
    lag_ms = anim.front_lag_ms(around_angles(on_mesh, s_points, cent, s))
    return 1e3 * s_points / anim.speed_mm_s + lag_ms


def tissue_positions(dataset, points: np.ndarray, t0_frame: int) -> np.ndarray:
    """Where the static mesh's ``points (n, 3)`` mm are in every frame of an animated
    ``dataset``: ``(n, n_t, 3)`` mm in aligned time (frame t is animation frame
    ``(t + t0_frame) % n_t``)."""
    from ..io.tube import load_tube

    truth = json.loads((Path(dataset) / "truth.json").read_text())
    tube = load_tube(Path(dataset) / "truth" / "static.ply")
    anim = Animation(**truth["animation"])
    tri, bary, _ = static_points(tube.V, tube.F, tube.V, points)
    frames = [Vt for _, Vt in animate_frames(tube.V, tube.F, tube.inlet, tube.outlet, anim)]
    n_t = len(frames)
    return np.stack(
        [
            np.einsum("mk,mkd->md", bary, frames[(t + t0_frame) % n_t][tube.F[tri]])
            for t in range(n_t)
        ],
        axis=1,
    )
