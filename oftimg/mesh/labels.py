"""From a label volume to the walls' surfaces: one frame's masks smoothed, meshed by
marching cubes at a chosen size, cut at two planes or left open where the tube leaves
the volume, cleaned of specks and cavities, Taubin-smoothed with the rims held.

Volumes are arrays ``(z, y, x)`` as TIFF readers and scikit-image give them; a voxel
``(k, j, i)`` sits at ``x = i * dx, y = j * dy, z = k * dz``. Surfaces come out as
``V (n, 3)`` in (x, y, z), the voxel size's unit, and ``F (m, 3)`` int64, outward.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from ..errors import InputError
from .curvature import taubin_smooth
from .ends import cut_by_plane, largest_piece
from .mask_topology import MaskRepair, solid_tube_mask
from .topology import MeshError, boundary_loops, check_tube, repair

# which labels each wall encloses: outer all three, inner the jelly and the lumen
WALL_LAYERS = {
    "outer": ("myocardium", "jelly", "lumen"),
    "inner": ("jelly", "lumen"),
    "lumen": ("lumen",),
}


def wall_masks(labels: np.ndarray, label_ids: dict[str, int]) -> dict[str, np.ndarray]:
    """Boolean masks ``(z, y, x)`` of what each wall encloses, for the layers that
    ``label_ids`` (layer name -> label value) names: with one layer, the outer wall
    alone. Raises :class:`~oftimg.errors.InputError` for float labels."""
    if not np.issubdtype(labels.dtype, np.integer) and labels.dtype != bool:
        raise InputError(
            f"labels are {labels.dtype}, not integers: a label volume holds "
            "whole numbers (0 background)"
        )
    masks = {}
    for wall, layers in WALL_LAYERS.items():
        present = [label_ids[layer] for layer in layers if layer in label_ids]
        if len(present) == len(layers) or (wall == "outer" and present):
            masks[wall] = _member(labels, present)
    return masks


def wall_occupancy(probabilities: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Each wall's occupancy ``(z, y, x)`` float32 in [0, 1] from its layers'
    probabilities (layer -> ``(z, y, x)``): their sum, clipped; for the walls whose
    layers are all given (the outer wall: whatever layers are)."""
    occupancy = {}
    for wall, layers in WALL_LAYERS.items():
        present = [probabilities[layer] for layer in layers if layer in probabilities]
        if len(present) == len(layers) or (wall == "outer" and present):
            occupancy[wall] = np.clip(np.sum(present, axis=0), 0.0, 1.0).astype(np.float32)
    return occupancy


def frame_masks(volume: np.ndarray | dict, label_ids: dict[str, int]) -> dict[str, np.ndarray]:
    """Each wall's mask ``(z, y, x)`` bool from one frame's labels or probabilities
    (:func:`wall_masks`; an occupancy above 0.5 for probabilities)."""
    if isinstance(volume, dict):
        return {w: occ > LEVEL for w, occ in wall_occupancy(volume).items()}
    return wall_masks(volume, label_ids)


def _member(labels: np.ndarray, values: list[int]) -> np.ndarray:
    """``np.isin(labels, values)``; for 8- and 16-bit labels by a lookup table (10x
    faster), OpenCV's for 8 bits (another 5x)."""
    if labels.dtype.kind in "ub" and labels.dtype.itemsize <= 2:
        table = np.zeros(2 ** (8 * labels.dtype.itemsize), bool)
        table[[v for v in values if 0 <= v < len(table)]] = True
        if labels.dtype.itemsize == 1 and labels.ndim == 3:
            import cv2

            rows = labels.view(np.uint8).reshape(-1, labels.shape[-1])
            return cv2.LUT(rows, table.view(np.uint8)).view(bool).reshape(labels.shape)
        return table[labels]
    return np.isin(labels, values)


def _values(labels: np.ndarray) -> np.ndarray:
    """The distinct values of ``labels`` (counted for 8- and 16-bit labels: 10x faster;
    for 8 bits by OpenCV's histogram, another 5x)."""
    if labels.dtype.kind in "ub" and labels.dtype.itemsize == 1 and labels.ndim == 3:
        import cv2

        rows = labels.view(np.uint8).reshape(-1, labels.shape[-1])
        return np.flatnonzero(cv2.calcHist([rows], [0], None, [256], [0, 256]).ravel())
    if labels.dtype.kind in "ub" and labels.dtype.itemsize <= 2:
        return np.flatnonzero(np.bincount(labels.ravel().astype(np.intp, copy=False)))
    return np.unique(labels)


@dataclass(frozen=True)
class Cleaned:
    """What the clean-up dropped: pieces of surface apart from the wall (a
    segmentation's specks outside it and its pinholes' cavities inside it) and
    their vertices."""

    pieces: int
    vertices: int


LEVEL = 0.5  # the smoothed mask's level that is the wall
CURVATURE_PROPERTY = "oftimg_mean_curvature"  # a lumen PLY's stored curvature, per unit
CLOSED_PROPERTY = "oftimg_lumen_closed"  # a lumen PLY's vertices on a closure's bridge (1)
ANTI_ALIAS = 0.4  # the blur's sigma as a share of the sampling step, at least


@dataclass(frozen=True)
class MeshOptions:
    """How a wall's mask becomes a mesh.

    ``target_vertices``: about how many vertices each wall gets (the level set is
    sampled at the spacing that gives it); ``smoothing``: the Gaussian sigma applied
    to the mask before its level set is taken, in voxels along each axis (a
    binary mask's level set is a staircase of the voxels' size along each axis;
    a blur also moves a curved surface inwards by sigma^2 times its curvature
    over 2, so it stays small and Taubin steps do the rest; one-voxel specks and
    pinholes fall below the level); ``taubin_steps``: Taubin steps on the mesh with
    its boundary loops held; ``lumen_curvature_blur``: the lumen's mean curvature
    is read from its mask's level sets blurred by a Gaussian of this many voxels
    (of the smallest side; :func:`~oftimg.mesh.level_set.level_set_mean_curvature`)
    and stored with each vertex, instead of being taken from the mesh (0: from the
    mesh, as for a mesh dataset).
    """

    target_vertices: int = 8000
    smoothing: float = 0.5
    taubin_steps: int = 30
    lumen_curvature_blur: float = 2.0

    def __post_init__(self):
        if not (isinstance(self.target_vertices, int) and self.target_vertices >= 200):
            raise InputError(
                f"target vertices must be a whole number >= 200, found {self.target_vertices!r}"
            )
        if not (np.isfinite(self.smoothing) and self.smoothing >= 0):
            raise InputError(f"mesh smoothing must be >= 0 voxels, found {self.smoothing!r}")
        if not (isinstance(self.taubin_steps, int) and self.taubin_steps >= 0):
            raise InputError(
                f"taubin steps must be a whole number >= 0, found {self.taubin_steps!r}"
            )
        if not (np.isfinite(self.lumen_curvature_blur) and 0 <= self.lumen_curvature_blur <= 20):
            raise InputError(
                f"the lumen curvature's blur must lie in 0..20 voxels, found "
                f"{self.lumen_curvature_blur!r}"
            )

    def as_dict(self) -> dict:
        return asdict(self)


def sample_step(mask: np.ndarray, voxel_size_xyz, target_vertices: int) -> float:
    """The spacing at which marching cubes gives a mask's surface about
    ``target_vertices`` vertices: the voxel faces between inside and outside add up
    to about 1.5 times the surface's area, and a level set sampled at spacing h has
    about 1.5 area / h^2 vertices. Never finer than the smallest voxel side. A soft
    mask (occupancy in [0, 1]) counts as its voxels above 0.5."""
    if mask.dtype != bool:
        mask = mask > LEVEL
    dx, dy, dz = voxel_size_xyz
    faces = (
        np.count_nonzero(mask[1:] != mask[:-1]) * dx * dy
        + np.count_nonzero(mask[:, 1:] != mask[:, :-1]) * dx * dz
        + np.count_nonzero(mask[:, :, 1:] != mask[:, :, :-1]) * dy * dz
    )
    return max(float(np.sqrt(faces / target_vertices)), min(voxel_size_xyz))


def level_set_field(mask: np.ndarray, voxel_size_xyz, sigma_voxels: float, step: float):
    """The mask smoothed by a Gaussian of ``sigma_voxels`` and resampled at
    about ``step`` along each axis, cropped to the mask's box (plus the blur's
    reach), with the sampling kept on the volume's first and last planes: ``(field
    (z, y, x) float32, its origin (x, y, z), its spacing (dx, dy, dz))``. Outside
    the volume the mask is taken as its border plane continued, so the surface
    meets the volume's faces square."""
    size_zyx = np.asarray(voxel_size_xyz[::-1], float)
    reach = int(np.ceil(3 * max(sigma_voxels, ANTI_ALIAS * step / min(size_zyx)))) + 1
    where = (
        np.nonzero(mask.any(axis=(1, 2)))[0],
        np.nonzero(mask.any(axis=(0, 2)))[0],
        np.nonzero(mask.any(axis=(0, 1)))[0],
    )
    lo = [max(int(w[0]) - reach, 0) for w in where]
    hi = [min(int(w[-1]) + reach, n - 1) for w, n in zip(where, mask.shape)]
    box = tuple(slice(a, b + 1) for a, b in zip(lo, hi))
    field = mask[box].astype(np.float32)
    # sampled coarser than the voxels, the blur grows to keep the staircase from aliasing
    sigma = np.maximum(sigma_voxels, ANTI_ALIAS * step / size_zyx)
    n_in = np.array(field.shape)
    n_out = np.maximum(np.round((n_in - 1) * size_zyx / step).astype(int) + 1, 2)
    # one axis at a time, each blurred then resampled before the next: the later
    # axes' blurs run on fewer samples (the same field, 2-3x faster than all at once)
    for axis in np.argsort(n_out / n_in):
        if sigma[axis] > 0:
            field = _blurred(field, float(sigma[axis]), int(axis))
        if n_out[axis] != n_in[axis]:
            field = _resampled(field, int(n_out[axis]), int(axis))
    # a sample exactly at the level puts a vertex on a grid point, and marching cubes
    # then gives triangles of no area, whose removal would leave pinholes
    field[field == LEVEL] = np.nextafter(np.float32(LEVEL), np.float32(1))
    spacing_zyx = (n_in - 1) * size_zyx / np.maximum(np.array(field.shape) - 1, 1)
    return field, tuple(np.array(lo)[::-1] * size_zyx[::-1]), tuple(spacing_zyx[::-1])


def _blurred(field: np.ndarray, sigma: float, axis: int, truncate: float = 3.0) -> np.ndarray:
    """``field`` (z, y, x) float32 blurred along ``axis`` by a Gaussian of ``sigma``
    samples, its border samples continued: scipy's ``gaussian_filter1d(mode="nearest")``
    to float32's last bit, by OpenCV's filters (2-4x faster: the blur was half of a
    label frame's meshing)."""
    import cv2

    radius = int(truncate * sigma + 0.5)  # scipy's kernel, float32
    x = np.arange(-radius, radius + 1)
    kernel = np.exp(-0.5 / sigma**2 * x**2)
    kernel = (kernel / kernel.sum()).astype(np.float32)
    one, border = np.ones(1, np.float32), cv2.BORDER_REPLICATE
    field = np.ascontiguousarray(field, dtype=np.float32)
    if axis == 2:  # rows of (z y, x)
        return cv2.filter2D(
            field.reshape(-1, field.shape[2]), -1, kernel[None, :], borderType=border
        ).reshape(field.shape)
    if axis == 0:  # columns of (z, y x)
        return cv2.sepFilter2D(
            field.reshape(field.shape[0], -1), -1, one, kernel, borderType=border
        ).reshape(field.shape)
    out = np.empty_like(field)  # columns of each (y, x) plane
    for k in range(field.shape[0]):
        out[k] = cv2.sepFilter2D(field[k], -1, one, kernel, borderType=border)
    return out


def _resampled(field: np.ndarray, n_out: int, axis: int) -> np.ndarray:
    """``field`` linearly interpolated to ``n_out`` samples along ``axis``, the first
    and last on the first and last (scipy's zoom does any axes at once, 5x slower)."""
    n_in = field.shape[axis]
    x = np.linspace(0.0, n_in - 1.0, n_out)
    low = np.minimum(x.astype(int), n_in - 2)
    shape = [1, 1, 1]
    shape[axis] = n_out
    w = (x - low).astype(np.float32).reshape(shape)
    below = np.take(field, low, axis=axis)
    return below + w * (np.take(field, low + 1, axis=axis) - below)


def _largest_piece(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray, Cleaned]:
    """The connected part of the mesh with the most faces, and what was dropped."""
    V, F, kept, others = largest_piece(V, F)
    return V, F, Cleaned(others, int((~kept).sum()))


@dataclass(frozen=True)
class WallMesh:
    """One wall of one frame: ``V (n, 3)`` in (x, y, z) length units, ``F (m, 3)``
    outward, what the clean-up removed, and the level set's sampling step."""

    V: np.ndarray
    F: np.ndarray
    cleaned: Cleaned
    step: float
    repair: MaskRepair | None = None  # the mask's topology mended first (or not)
    mean_curvature: np.ndarray | None = None  # (n,) per length unit, from the level sets
    nested: int | None = None  # voxels cut to keep it inside a mended wall
    closed: np.ndarray | None = None  # (n,) bool: on the bridge across a closed lumen
    closure: dict | None = None  # how the closed lumen's pieces were joined


def mesh_wall(
    mask: np.ndarray,
    voxel_size_xyz,
    options: MeshOptions = MeshOptions(),
    ends=None,
    *,
    curvature: bool = False,
    length_unit: str = "um",
) -> WallMesh:
    """One wall's surface from its mask ``(z, y, x)``, bool or an occupancy in [0,
    1] (float32: a blend of masks or a probability map): the mask smoothed and
    resampled (:func:`level_set_field`), its level 0.5 by marching cubes (not
    padded: open where the tube leaves the volume), cut at the ``ends`` planes (two
    ``(point, normal)``, normals into the tube's part to keep) when given, the
    largest piece kept (a speck's surface or a pinhole's cavity is a piece of its
    own: cheaper dropped from a mesh of thousands of vertices than labelled in a
    volume of millions of voxels), Taubin-smoothed with its boundary loops held,
    faces outward; with ``curvature`` (and ``options.lumen_curvature_blur``), the mean
    curvature of the mask's level sets at each vertex. Raises :class:`MeshError`
    when the result is not an open tube (one message, no file name, lengths in
    ``length_unit``: the voxel size's)."""
    from skimage.measure import marching_cubes

    step = sample_step(mask, voxel_size_xyz, options.target_vertices)
    field, origin, spacing = level_set_field(mask, voxel_size_xyz, options.smoothing, step)
    if field.max() <= LEVEL:
        raise MeshError("is too thin to mesh: after smoothing no voxel is inside")
    if field.min() >= LEVEL:
        raise MeshError(
            "fills the whole volume: it has no surface inside it (are the labels right?)"
        )
    verts, faces, _, _ = marching_cubes(field, LEVEL, spacing=spacing[::-1])
    V = verts[:, ::-1] + np.asarray(origin)  # (z, y, x) -> (x, y, z)
    F = np.ascontiguousarray(faces[:, ::-1], dtype=np.int64)
    V, F, _ = repair(V, F)
    for point, normal in ends or ():
        V, F = cut_by_plane(V, F, point, normal)
    if len(F) == 0:
        raise MeshError(
            "lies wholly outside the part between the ends planes (meta.json "
            '"ends"): is each normal pointing into the tube\'s part to keep?'
        )
    V, F, cleaned = _largest_piece(V, F)
    loops = boundary_loops(F)
    if len(loops) == 1:
        raise MeshError(
            "leaves the volume at one end only (one open end): a tube that "
            "ends inside the volume needs two cutting planes, meta.json "
            '"ends"'
        )
    topo = check_tube(V, F, mend=True, length_unit=length_unit)  # marching cubes' pinholes
    V = V if topo.V is None else topo.V
    rim = np.concatenate(topo.loops)
    V = taubin_smooth(V, topo.F, options.taubin_steps, fixed=rim)
    H = None
    if curvature and options.lumen_curvature_blur > 0:
        from .level_set import level_set_mean_curvature

        H = level_set_mean_curvature(
            mask, voxel_size_xyz, V, options.lumen_curvature_blur * min(voxel_size_xyz)
        )
    return WallMesh(V, topo.F, cleaned, float(step), mean_curvature=H)


def mesh_walls(
    labels: np.ndarray | dict,
    label_ids: dict[str, int],
    voxel_size_xyz,
    options: MeshOptions = MeshOptions(),
    ends=None,
    *,
    length_unit: str = "um",
) -> dict[str, WallMesh | str]:
    """Every wall of one frame's label volume ``(z, y, x)`` (:func:`wall_masks`), or of
    its probabilities (layer -> ``(z, y, x)`` in [0, 1]: :func:`wall_occupancy`), by
    :func:`mesh_wall`, outer first. A wall that is not an open tube has its mask
    mended (:func:`~oftimg.mesh.mask_topology.solid_tube_mask`: a handle, a tunnel or
    a bridge opened or closed away, recorded in the wall's ``repair``), and the walls
    inside it are kept inside its mended mask (:func:`keep_inside`, the voxels cut
    in ``nested``). A wall that cannot
    be meshed even so, or whose layer's label is absent, comes back as the reason
    (a str: "the lumen wall: no voxel labelled lumen (3)"), to be filled from the
    neighbouring frames. Raises :class:`InputError` for float labels."""
    if isinstance(labels, dict):  # probabilities, layer -> (z, y, x)
        masks = wall_occupancy(labels)
        present = {layer: bool(np.max(p) > LEVEL) for layer, p in labels.items()}
        nothing = "no voxel has a probability above 0.5"

        def missing(layer):
            return f"no voxel above 0.5 in {layer}"
    else:
        masks = wall_masks(labels, label_ids)
        values = _values(labels)
        present = {layer: v in values for layer, v in label_ids.items()}
        nothing = "holds no labelled voxel (all zero)"

        def missing(layer):
            return f"no voxel labelled {layer} ({label_ids[layer]})"

    walls: dict[str, WallMesh | str] = {}
    enclosing = None  # the mended mask of the wall around this one, if any
    inner = None  # the inner wall's mask as meshed: it holds the lumen
    for wall, mask in masks.items():
        # a wall's surface is its outermost layer's (one named layer: the outer wall's)
        layer = next(la for la in WALL_LAYERS[wall] if la in label_ids)
        if not any(present.values()):
            walls[wall] = nothing
            continue
        if not present[layer]:
            walls[wall] = f"the {wall} wall: {missing(layer)}"
            continue
        nested = None
        if enclosing is not None:  # nested by the labels' design, unless one was mended
            mask, nested = keep_inside(mask, enclosing)
        closed = None
        if wall == "lumen" and inner is not None:  # in pieces: the cushions closed it
            closed = closed_lumen_mesh(
                mask,
                inner,
                voxel_size_xyz,
                options,
                ends,
                openings=(0, 1, 2, 3),
                length_unit=length_unit,
            )
        if closed is not None:
            walls[wall] = closed
        else:
            walls[wall], enclosing = _mesh_or_mend(
                wall,
                mask,
                voxel_size_xyz,
                options,
                ends,
                curvature=wall == "lumen",
                length_unit=length_unit,
            )
        if wall == "lumen" and isinstance(walls[wall], str) and inner is not None:
            # one piece, but its slit closing through a sieve of voxels (opened, bridged),
            # or closed up to an end of the tube (bridged to it)
            walls[wall] = (
                closed_lumen_mesh(
                    mask,
                    inner,
                    voxel_size_xyz,
                    options,
                    ends,
                    openings=(0, 1, 2, 3),
                    to_ends=True,
                    length_unit=length_unit,
                )
                or walls[wall]
            )
        if nested is not None and isinstance(walls[wall], WallMesh):
            walls[wall] = replace(walls[wall], nested=nested)
        if wall == "inner":
            inner = (
                enclosing
                if enclosing is not None
                else (mask if mask.dtype == bool else mask > LEVEL)
            )
    return walls


def closed_lumen_mesh(
    mask: np.ndarray,
    inner: np.ndarray,
    voxel_size_xyz,
    options: MeshOptions,
    ends,
    *,
    openings=(0, 1, 2),
    to_ends: bool = False,
    length_unit: str = "um",
) -> WallMesh | None:
    """The lumen's wall where the cushions close it over a stretch: its mask (boolean,
    or an occupancy in [0, 1]) in pieces joined by a thin bridge
    (:func:`~oftimg.mesh.closure.bridged_lumen`, inside the boolean ``inner`` mask) and
    meshed as one tube, each vertex flagged when it lies on the bridge
    (``WallMesh.closed``). A slit thinner than a segmentation holds open comes as a
    sieve of voxels: each of ``openings`` (in the smallest voxel side; 0 none) is tried
    in turn, the mask opened by a ball of that radius first, until one gives a tube;
    then each again with the level set blurred by :data:`WIDER_BLUR` (the slit's
    fragments beside the bridge can close handles under the usual blur, as for any
    wall: :func:`_mesh_or_mend`). ``to_ends``: a lumen closed up to a tube's end (the
    volume's face or a cutting plane of ``ends``) is bridged to it too
    (:func:`~oftimg.mesh.closure.tube_ends`); for a lumen that cannot be meshed as it
    is. None when the lumen is not in pieces (nor short of an end) under any, or no
    bridged mask can be meshed as a tube."""
    from scipy import ndimage

    from .closure import BRIDGE_RADIUS_VOXELS, bridged_lumen, tube_ends

    tube = tube_ends(inner, voxel_size_xyz, ends) if to_ends else None

    inside = mask if mask.dtype == bool else mask > LEVEL
    # the bridge as thick as the level set's sampling: thinner, it falls between samples
    radius = max(
        BRIDGE_RADIUS_VOXELS,
        sample_step(inside, voxel_size_xyz, options.target_vertices) / min(voxel_size_xyz),
    )
    joined = {}  # opening radius -> (opened mask, bridge), or None
    blurs = [options] + [replace(options, smoothing=WIDER_BLUR)] * (options.smoothing < WIDER_BLUR)
    for blur in blurs:
        for radius in openings:
            if radius not in joined:
                opened = (
                    inside
                    if radius == 0
                    else ndimage.binary_opening(
                        inside, _ball_um(radius * min(voxel_size_xyz), voxel_size_xyz)
                    )
                )
                bridged = bridged_lumen(
                    opened, inner, voxel_size_xyz, ends=tube, radius_voxels=radius
                )
                joined[radius] = None if bridged is None else (opened, bridged[1])
            if joined[radius] is not None:
                mesh = _bridged_mesh(
                    mask, inside, *joined[radius], voxel_size_xyz, blur, ends, length_unit
                )
                if mesh is not None:
                    return replace(
                        mesh,
                        closure={
                            **mesh.closure,
                            "opened_voxels": radius,
                            "blur_voxels": blur.smoothing,
                        },
                    )
    return None


def _bridged_mesh(
    mask: np.ndarray,
    inside: np.ndarray,
    opened: np.ndarray,
    bridge: np.ndarray,
    voxel_size_xyz,
    options: MeshOptions,
    ends,
    length_unit: str,
) -> WallMesh | None:
    """The lumen ``mask`` (``inside`` its boolean) as opened, joined by ``bridge``,
    meshed with its bridge's vertices flagged (:func:`closed_lumen_mesh`): the opening's
    voxels away from the bridge given back first (:func:`_kept_of_opening`), then not;
    None when neither is a tube."""
    from .closure import bridge_flags, lumen_pieces

    for kept in _kept_of_opening(inside, opened, bridge, voxel_size_xyz):
        whole = kept | bridge
        if mask.dtype != bool:  # an occupancy: its own values where it is kept
            whole = np.where(bridge, 1.0, np.where(kept, mask, np.minimum(mask, 0.25))).astype(
                np.float32
            )
        try:
            mesh = mesh_wall(
                whole, voxel_size_xyz, options, ends, curvature=True, length_unit=length_unit
            )
        except MeshError:
            continue
        return replace(
            mesh,
            closed=bridge_flags(mesh.V, bridge, kept, voxel_size_xyz),
            closure={
                "pieces": lumen_pieces(kept)[1],
                "bridge_voxels": int(bridge.sum()),
                "opened_away": int(np.count_nonzero(inside & ~kept)),
            },
        )
    return None


# voxels: the blur tried when a wall's surface is no tube although its mask is one (or
# was mended into one): folds a voxel apart, which the usual blur's level set parts
# into handles (the zoo's eroded, folded lumens: every such frame meshed with 1 voxel)
WIDER_BLUR = 1.0


def _mesh_or_mend(
    wall: str,
    mask: np.ndarray,
    voxel_size_xyz,
    options: MeshOptions,
    ends,
    *,
    curvature: bool = False,
    length_unit: str = "um",
) -> tuple[WallMesh | str, np.ndarray | None]:
    """The wall meshed from ``mask``; when that fails, from the mask mended
    (:func:`~oftimg.mesh.mask_topology.solid_tube_mask`), and then, if the surface is
    still no tube, with its level set blurred by ``WIDER_BLUR`` voxels; with the mended
    mask (None when not mended). Or the reason it cannot be meshed."""

    def meshed(m, opts=options):
        return mesh_wall(
            m, voxel_size_xyz, opts, ends, curvature=curvature, length_unit=length_unit
        )

    try:
        return meshed(mask), None
    except MeshError as exc:  # a handle, a tunnel, a bridge: mend the mask, once
        failed = exc
    inside = mask if mask.dtype == bool else mask > LEVEL
    solid, repair = solid_tube_mask(inside)
    mended = mask
    if repair is None:
        solid = None  # a solid tube already: not mended
    else:
        # an occupancy keeps its values where the mending left the voxel as it was
        mended = (
            solid
            if mask.dtype == bool
            else np.where(solid == inside, mask, solid).astype(np.float32)
        )
        try:
            return replace(meshed(mended), repair=repair), solid
        except MeshError as again:
            failed = again
    if options.smoothing < WIDER_BLUR:
        try:
            mesh = meshed(mended, replace(options, smoothing=WIDER_BLUR))
        except MeshError:
            pass
        else:
            what = f"level set blurred by {WIDER_BLUR:g} voxel" + (
                f" after its mask's {repair.what}" if repair else ""
            )
            return replace(
                mesh,
                repair=MaskRepair(
                    what, repair.voxels if repair else 0, repair.euler_before if repair else 1
                ),
            ), solid
    return f"the {wall} wall {failed}" + (
        f" (after its mask's {repair.what})" if repair else ""
    ), None


# the voxels an opening took that lie this far (um per smallest voxel side) from the
# bridge are given back: the slit's sieve is where it closes, not all along the tube
KEPT_FROM_BRIDGE_VOXELS = 4.0


def _kept_of_opening(
    inside: np.ndarray, opened: np.ndarray, bridge: np.ndarray, voxel_size_xyz
) -> list[np.ndarray]:
    """The lumen's masks to try beside a bridge: its opened mask with what the opening
    took further than :data:`KEPT_FROM_BRIDGE_VOXELS` from the bridge given back (a slit
    still open there, thin but no sieve), then the opened mask itself."""
    from scipy import ndimage

    took = inside & ~opened
    if not took.any():
        return [opened]
    size_zyx = np.asarray(voxel_size_xyz, float)[::-1]
    far = ndimage.distance_transform_edt(~bridge, sampling=size_zyx) > (
        KEPT_FROM_BRIDGE_VOXELS * size_zyx.min()
    )
    return [opened | (took & far), opened]


def _ball_um(radius: float, voxel_size_xyz) -> np.ndarray:
    """A ball of ``radius`` (the voxels' length unit) as a boolean structuring element
    ``(z, y, x)`` on voxels of ``voxel_size_xyz``: an opening by it removes what is
    thinner than its diameter alike along every axis, however long the voxels."""
    size = np.asarray(voxel_size_xyz, float)[::-1]
    reach = np.floor(radius / size + 1e-9).astype(int)
    offsets = np.indices(2 * reach + 1).reshape(3, -1).T - reach
    inside = ((offsets * size) ** 2).sum(axis=1) <= radius**2 + 1e-9
    ball = np.zeros(tuple(2 * reach + 1), bool)
    ball[tuple((offsets[inside] + reach).T)] = True
    return ball


def keep_inside(mask: np.ndarray, enclosing: np.ndarray) -> tuple[np.ndarray, int | None]:
    """``mask`` cut to ``enclosing`` (the mask of the wall around it; after that wall's
    mask was mended, an opening say, the two could cross). Returns the mask and the
    voxels this cut from the wall's body (None for none; specks of a layer alone in
    the background, which the meshing drops anyway, are not counted). Walls that
    touch (no voxel of the layer between them) are left touching: a layer can thin
    to nothing, and a forced gap of a voxel pierced thin layers."""
    from scipy import ndimage

    inside = mask if mask.dtype == bool else mask > LEVEL  # an occupancy: above 0.5
    cut = inside & ~enclosing
    if not cut.any():
        return mask, None
    six = ndimage.generate_binary_structure(3, 1)
    moved = int(np.count_nonzero(cut & ndimage.binary_dilation(inside & enclosing, six)))
    kept = (
        mask & enclosing if mask.dtype == bool else np.where(enclosing, mask, 0).astype(np.float32)
    )
    return kept, moved or None
