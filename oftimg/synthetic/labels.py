"""The phantom as a label dataset: its three walls rasterized into one label volume
per frame, as a segmentation of a 4-D scan gives them, with segmentation noise.

The phantom's arc is bent to a quarter circle (bend radius ``2 L / pi``) and turned
so that its inlet plane is the volume's face ``y = 0`` and its outlet plane the face
``x = 0``: the tube leaves the volume through its border at both ends, as an OCT
field of view cuts the outflow tract, and the window between the faces is the
phantom's window, so its ``truth.json`` holds unchanged. Voxel ``(k, j, i)`` sits at
``x = i dx, y = j dy, z = k dz`` (um); labels: myocardium 1, jelly 2, lumen 3.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.label_dataset import DEFAULT_LABEL_IDS as LABEL_VALUES
from .phantom import Phantom, PhantomParams

MARGIN_VOXELS = 3  # background between the tube and the volume's faces
ISLANDS = 30  # specks of the wrong label per frame, with noise
OUTER_REACH = 1.25  # the outer wall never lies further out than this x R0


def label_params(params: PhantomParams) -> PhantomParams:
    """The phantom bent to a quarter circle, so its window planes are two faces of a box."""
    return replace(params, bend_radius_mm=2 * params.length_mm / np.pi)


def volume_frame(
    phantom: Phantom, voxel_size_um, oblique_deg: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """The label volume's frame: ``(turn (3, 3), shift (3,) mm)`` with
    ``X_volume = X_phantom @ turn + shift``: turned about z so that the phantom's
    inlet (its angle alpha0 about the bend's centre) lies along the volume's x axis,
    and raised so that the tube clears the face z = 0 by a few voxels. With
    ``oblique_deg``, the volume's faces x = 0 and y = 0 cut the tube at that angle
    (between the centre line and the face's normal) through the window's end
    centres, as an OCT field of view cuts an outflow tract: the tube is turned about
    the diagonal between its ends (both ends tilt alike, out of the bend's plane)
    and moved so that each face passes through its end's centre."""
    p = phantom.p
    a = phantom.alpha0
    turn = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    reach = OUTER_REACH * max(p.radius_inlet_mm, p.radius_outlet_mm)
    margin = MARGIN_VOXELS * float(voxel_size_um[2]) * 1e-3
    if not oblique_deg:
        return turn, np.array([0.0, 0.0, reach + margin])
    if not 0 < oblique_deg < 70:
        raise InputError(f"the oblique cut must lie in 0..70 degrees, found {oblique_deg}")
    # about the diagonal d by gamma, an end's tangent (0, 1, 0) meets the face's normal
    # at arccos(cos^2(gamma / 2))
    gamma = 2 * np.arccos(np.sqrt(np.cos(np.radians(oblique_deg))))
    d = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    K = np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
    tilt = np.eye(3) + np.sin(gamma) * K + (1 - np.cos(gamma)) * K @ K  # Rodrigues
    turn = turn @ tilt.T
    inlet = phantom.frame_axes(0.0)[0] @ turn
    # the tube's surface (at its outer reach) near the box: z's range sets the lift
    s = np.linspace(-0.5, 1.5, 201) * p.length_mm
    theta = np.linspace(0, 2 * np.pi, 72, endpoint=False)
    c, N, B = phantom.frame_axes(s[:, None])
    rho = OUTER_REACH * phantom.base_radius(np.clip(s, 0, p.length_mm))[:, None, None]
    X = (c + rho * (np.cos(theta)[:, None] * N + np.sin(theta)[:, None] * B)) @ turn
    X = X.reshape(-1, 3) - [inlet[1], inlet[1], 0.0]
    X = X[(X[:, 0] >= 0) & (X[:, 1] >= 0)]
    return turn, np.array([-inlet[1], -inlet[1], margin - X[:, 2].min()])


def volume_transform(dataset: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """The ``(turn (3, 3), shift (3,) mm)`` of a label phantom's volume
    (:func:`volume_frame`), as its truth.json records them (older files: recomputed
    from meta.json's voxel size)."""
    from .phantom import read_truth

    ph, truth = read_truth(dataset)
    if "volume" in truth:
        return np.array(truth["volume"]["turn"]), np.array(truth["volume"]["shift_mm"])
    meta = json.loads((Path(dataset) / "meta.json").read_text())
    return volume_frame(ph, meta["voxel_size"])


def in_phantom_frame(dataset: str | Path, points_mm: np.ndarray) -> np.ndarray:
    """Points ``(..., 3)`` mm of a label phantom's volume (a run's grids, centroids) in
    its phantom's own frame, where :class:`~oftimg.synthetic.phantom.Phantom` gives
    their window coordinates (:func:`volume_transform`)."""
    turn, shift = volume_transform(dataset)
    return (np.asarray(points_mm, float) - shift) @ turn.T


class LabelGrid:
    """The voxel grid of a label phantom: each voxel centre's window coordinates
    ``(s, theta)`` and distance from the centre line (mm), for the voxels that can
    lie inside the outer wall; computed once, used for every frame. With
    ``offset_voxels`` (dx, dy, dz shares of a voxel), at points that far off the
    centres, in the same volume. ``oblique_deg``: the volume's faces cut the tube at
    that angle (:func:`volume_frame`); the tube then goes on past the window's ends
    (its model continued there) to the faces."""

    def __init__(
        self,
        phantom: Phantom,
        voxel_size_um,
        offset_voxels=(0.0, 0.0, 0.0),
        oblique_deg: float = 0.0,
    ):
        p = phantom.p
        self.phantom = phantom
        self.voxel_mm = np.asarray(voxel_size_um, float) * 1e-3  # dx, dy, dz
        self.turn, self.shift = volume_frame(phantom, voxel_size_um, oblique_deg)
        reach = OUTER_REACH * max(p.radius_inlet_mm, p.radius_outlet_mm)
        R = p.bend_radius_mm
        margin = MARGIN_VOXELS * self.voxel_mm
        if oblique_deg:
            extent = self._oblique_extent(reach) + margin
        else:
            extent = np.array([R + reach + margin[0], R + reach + margin[1], 2 * self.shift[2]])
        self.shape = tuple(
            int(n) for n in (np.ceil(extent / self.voxel_mm).astype(int) + 1)[::-1]
        )  # (z, y, x)
        nz, ny, nx = self.shape
        # sampled at each voxel's centre, or off it by offset_voxels (partial volumes)
        ox, oy, oz = offset_voxels
        x = (np.arange(nx) + ox) * self.voxel_mm[0]
        y = (np.arange(ny) + oy) * self.voxel_mm[1]
        z = (np.arange(nz) + oz) * self.voxel_mm[2]
        index, X = [], []
        for k in range(nz):  # a plane at a time: the box may be large
            P = np.stack(np.broadcast_arrays(x[None, :], y[:, None], z[k]), axis=-1)
            P = (P.reshape(-1, 3) - self.shift) @ self.turn.T  # the phantom's frame
            near = (np.abs(np.hypot(P[:, 0], P[:, 1]) - R) < reach) & (np.abs(P[:, 2]) < reach)
            index.append(k * ny * nx + np.flatnonzero(near))
            X.append(P[near])
        self.index, X = np.concatenate(index), np.concatenate(X)
        self.s, self.theta = phantom.window_coordinates(X)
        if not oblique_deg:
            self.s = np.clip(self.s, 0.0, p.length_mm)
        c, _, _ = phantom.frame_axes(self.s)
        self.distance = np.linalg.norm(X - c, axis=-1)
        near = self.distance <= OUTER_REACH * phantom.base_radius(self.s)
        self.index, self.s, self.theta, self.distance = (
            a[near] for a in (self.index, self.s, self.theta, self.distance)
        )

    def _oblique_extent(self, reach: float) -> np.ndarray:
        """The box (mm, x y z) that holds the tube between the faces x = 0 and y = 0."""
        p = self.phantom.p
        s = np.linspace(-0.5, 1.5, 401) * p.length_mm
        theta = np.linspace(0, 2 * np.pi, 72, endpoint=False)
        c, N, B = self.phantom.frame_axes(s[:, None])
        X = (
            c + reach * (np.cos(theta)[:, None] * N + np.sin(theta)[:, None] * B)
        ) @ self.turn + self.shift
        X = X.reshape(-1, 3)
        return X[(X[:, 0] >= 0) & (X[:, 1] >= 0)].max(axis=0)

    def labels(self, t_ms: float) -> np.ndarray:
        """The frame's label volume ``(z, y, x)`` uint8 at time ``t_ms``."""
        out = np.zeros(self.shape, np.uint8)
        flat = out.reshape(-1)
        at = np.arange(len(self.index))  # the voxels inside the walls so far
        for wall, layer in (("outer", "myocardium"), ("inner", "jelly"), ("lumen", "lumen")):
            radius = self.phantom.radius(wall, self.s[at], self.theta[at], t_ms)
            at = at[self.distance[at] <= radius]
            flat[self.index[at]] = LABEL_VALUES[layer]
        return out


def segmentation_noise(
    labels: np.ndarray, flip: float, rng: np.random.Generator, islands: int = ISLANDS
) -> np.ndarray:
    """``labels`` as a segmentation would give them: a share ``flip`` of the voxels
    on a boundary between two labels takes a neighbour's label (the boundary
    roughened by one voxel), and ``islands`` specks of 1-8 voxels of a wrong label
    appear in the background and inside the tissue (islands and pinholes)."""
    out = labels.copy()
    boundary = np.zeros(labels.shape, bool)
    for axis in range(3):
        a = [slice(None)] * 3
        b = [slice(None)] * 3
        a[axis], b[axis] = slice(1, None), slice(None, -1)
        differs = labels[tuple(a)] != labels[tuple(b)]
        boundary[tuple(a)] |= differs
        boundary[tuple(b)] |= differs
    where = np.flatnonzero(boundary)
    chosen = where[rng.random(len(where)) < flip]
    idx = np.array(np.unravel_index(chosen, labels.shape))
    axis = rng.integers(0, 3, len(chosen))
    idx[axis, np.arange(len(chosen))] += rng.choice([-1, 1], len(chosen))
    for a in range(3):
        np.clip(idx[a], 0, labels.shape[a] - 1, out=idx[a])
    out.reshape(-1)[chosen] = labels[tuple(idx)]
    for _ in range(islands):
        size = rng.integers(1, 3, 3)
        corner = [int(rng.integers(0, n - s)) for n, s in zip(labels.shape, size)]
        box = tuple(slice(c, c + s) for c, s in zip(corner, size))
        out[box] = 0 if out[box].any() else rng.integers(1, 4)
    return out


PSF_VOXELS = 0.5  # a probability map's blur (Gaussian sigma, voxels)
NOISE = {
    "labels": 0.05,  # share of boundary voxels flipped
    "probabilities": 0.3,
}  # SD of the noise on each class's log-probability


def partial_volumes(grids: list[LabelGrid], t_ms: float) -> dict[str, np.ndarray]:
    """Each layer's share of each voxel ``(z, y, x)`` float32 at ``t_ms``: the labels
    sampled on ``grids`` (one volume sampled at points spread over each voxel)."""
    counts = {layer: None for layer in LABEL_VALUES}
    for grid in grids:
        labels = grid.labels(t_ms)
        for layer, value in LABEL_VALUES.items():
            hit = (labels == value).astype(np.float32)
            counts[layer] = hit if counts[layer] is None else counts[layer] + hit
    return {layer: c / len(grids) for layer, c in counts.items()}


def probability_maps(
    shares: dict[str, np.ndarray], noise: float, rng: np.random.Generator
) -> dict[str, np.ndarray]:
    """The layers' shares of each voxel as a segmenter's softmax gives them: blurred by
    a point spread (:data:`PSF_VOXELS`), Gaussian noise of SD ``noise`` on each class's
    log-probability (the background's too), the classes normalised to add up to one;
    each layer's map as uint8 (255 = 1). Noise on the logits, not on the
    probabilities: a confident background stays near 0 in every layer, as a
    segmenter's does, instead of gaining the clipped noise of three maps."""
    from scipy import ndimage

    blurred = {k: ndimage.gaussian_filter(v, PSF_VOXELS, mode="nearest") for k, v in shares.items()}
    blurred["background"] = np.clip(1.0 - sum(blurred.values()), 0.0, 1.0)
    weights = {
        k: np.maximum(v, 1e-4) * (np.exp(rng.normal(0.0, noise, v.shape)) if noise > 0 else 1.0)
        for k, v in blurred.items()
    }
    total = sum(weights.values())
    return {
        k: np.round(w / total * 255).astype(np.uint8)
        for k, w in weights.items()
        if k != "background"
    }


def write_label_phantom(
    out: str | Path,
    params: PhantomParams,
    voxel_size_um,
    *,
    noise: float | None = None,
    name: str | None = None,
    progress=None,
    probabilities: bool = False,
    intensity: bool = False,
    texture=None,
    islands: int = ISLANDS,
    oblique_deg: float = 0.0,
) -> Path:
    """Write a label phantom dataset: ``meta.json``, ``labels/f000.tif ...`` (one
    zlib-compressed uint8 TIFF per frame, (z, y, x)) and ``truth.json``. ``noise``:
    the share of boundary voxels flipped (with specks, :func:`segmentation_noise`;
    0 for none; None: :data:`NOISE`). With ``probabilities``, ``probabilities/<layer>/f000.tif ...``
    instead: each layer's partial volume (2 x 2 x 2 samples a voxel), blurred and
    with noise of SD ``noise`` on the log-probabilities (:func:`probability_maps`). With
    ``intensity``, ``intensity/f000.tif ...`` too: the volumes OCT would give, a
    texture fixed in the tissue (:func:`~oftimg.synthetic.texture.intensity_volume`),
    looking as ``texture`` (:class:`~oftimg.synthetic.texture.TextureParams`, default
    the textured phantom's) says. ``islands``: the label noise's specks per frame.
    ``oblique_deg``: the volume's faces cut the tube at that angle through the
    window's end centres (:func:`volume_frame`; truth.json's ``volume`` holds the
    turn and shift into the volume). ``params`` are bent by :func:`label_params`.
    Returns the folder."""
    import tifffile

    if noise is None:
        noise = NOISE["probabilities" if probabilities else "labels"]
    voxel = tuple(float(d) for d in voxel_size_um)
    if len(voxel) != 3 or not all(np.isfinite(d) and d > 0 for d in voxel):
        raise InputError(f"--voxel-size must be three positive lengths in um, found {voxel}")
    if not (0 <= noise < 1 or (probabilities and 0 <= noise <= 5)):
        raise InputError(
            f"--segmentation-noise must be a share in [0, 1) (for probability "
            f"maps: a log-probability SD in [0, 5]), found {noise}"
        )
    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise FileExistsError(f"{out}: exists and is not empty")
    params = label_params(params)
    ph = Phantom(params)
    grid = LabelGrid(ph, voxel, oblique_deg=oblique_deg)
    rng = np.random.default_rng([params.seed, 53])
    width = len(str(params.n_frames - 1))
    if probabilities:
        grids = [
            LabelGrid(ph, voxel, (ox, oy, oz), oblique_deg)
            for ox in (-0.25, 0.25)
            for oy in (-0.25, 0.25)
            for oz in (-0.25, 0.25)
        ]
        for layer in LABEL_VALUES:
            (out / "probabilities" / layer).mkdir(parents=True, exist_ok=True)
    else:
        (out / "labels").mkdir(parents=True, exist_ok=True)
    if intensity:
        from .texture import (
            SPECKLE_VOXELS,
            TextureParams,
            TissueSpeckle,
            TissueTexture,
            intensity_volume,
        )

        texture = TissueTexture(
            ph, np.random.default_rng([params.seed, 59]), texture or TextureParams()
        )
        speckle_rng = np.random.default_rng([params.seed, 61])
        borne = texture.params.speckle_decorrelation_um
        speckle = (
            TissueSpeckle(
                ph, np.random.default_rng([params.seed, 63]), SPECKLE_VOXELS * min(voxel), borne
            )
            if borne > 0
            else None
        )
        (out / "intensity").mkdir(parents=True, exist_ok=True)
    for k, t in enumerate(ph.frame_times_ms()):
        frame = f"f{k:0{width}d}.tif"
        if probabilities:
            for layer, p in probability_maps(partial_volumes(grids, t), noise, rng).items():
                tifffile.imwrite(out / "probabilities" / layer / frame, p, compression="zlib")
        else:
            labels = grid.labels(t)
            if noise > 0:
                labels = segmentation_noise(labels, noise, rng, islands)
            tifffile.imwrite(out / "labels" / frame, labels, compression="zlib")
        if intensity:
            tifffile.imwrite(
                out / "intensity" / frame,
                intensity_volume(grid, texture, t, speckle_rng, speckle),
                compression="zlib",
            )
        if progress is not None:
            progress(k + 1)
    inlet_um = (ph.frame_axes(0.0)[0] @ grid.turn + grid.shift) * 1e3
    meta = {
        "name": name or out.name,
        "group": params.group,
        "period_ms": params.period_ms,
        "length_unit": "um",
        "voxel_size": list(voxel),
        "axes": "zyx",
        **({} if probabilities else {"labels": LABEL_VALUES}),
        "inlet": [round(float(x), 6) for x in inlet_um],
    }
    (out / "meta.json").write_text(json.dumps(meta, indent=2))
    volume = {
        "oblique_deg": float(oblique_deg),
        "turn": grid.turn.tolist(),
        "shift_mm": grid.shift.tolist(),
    }
    (out / "truth.json").write_text(json.dumps(ph.truth() | {"volume": volume}, indent=1))
    return out
