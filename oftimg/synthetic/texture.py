"""Intensity volumes of the label phantom, as OCT would image it: a texture fixed in
the tissue (cell-sized blobs in the myocardium, in material coordinates, so that it
slides and twists with the tissue beneath the walls), speckle that changes in every
frame (or, as the instrument's, is carried by the tissue and decorrelates as it
moves), attenuation with depth along the beam, and noise.

The texture is what lets a run follow the tissue along the tube, which the walls'
shapes cannot show (:meth:`~oftimg.synthetic.phantom.Phantom.material_from_window`).
Volumes are ``(z, y, x)`` uint8 on the labels' voxels
(:class:`~oftimg.synthetic.labels.LabelGrid`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .phantom import Phantom

TWIST_DEG = 20.0  # the textured phantom's tissue twist at the inlet (contracted)
BLOB_UM = 6.0  # the texture's grain (Gaussian sigma of its random field), um
LATTICE_UM = 3.0  # the texture's sampling in the tissue
DEPTH_LAYERS = 8  # the texture's samples across the myocardium
# mean intensity of each layer (0..1 before 8-bit scaling) and the texture's contrast
LEVEL = {"myocardium": 0.55, "jelly": 0.22, "lumen": 0.08, "background": 0.04}
CONTRAST = 0.35  # the texture's SD over the myocardium's mean
SPECKLE = 0.2  # SD of the multiplicative speckle, new in every frame
SPECKLE_VOXELS = 0.6  # its grain (Gaussian sigma, voxels)
ATTENUATION_MM = 1.5  # the beam's 1/e depth along y
NOISE = 0.015  # SD of the additive noise
DEPTH_SIGMA = 0.6  # the texture's correlation through the wall, in depth samples
SPECKLE_DEPTH_LAYERS = 24  # a tissue-borne speckle's samples across the myocardium


@dataclass(frozen=True)
class TextureParams:
    """How the tissue looks and is imaged: the texture's grain (``blob_um``, Gaussian
    sigma), ``contrast`` (its SD over its mean), its correlation through the wall
    (``depth_sigma``, in :data:`DEPTH_LAYERS` samples across the myocardium: small, a
    texture that changes with depth), the ``speckle`` new in every frame (SD), the
    beam's 1/e depth ``attenuation_mm`` and the additive ``noise`` (SD, 1 = 255).
    The defaults are the textured phantom's.

    ``speckle_decorrelation_um`` > 0 makes the myocardium's speckle the instrument's:
    fully developed (log-normal, SD ``speckle`` up to 1 and beyond), of
    :data:`SPECKLE_VOXELS` grain, carried by the tissue and renewed as it moves (its
    correlation from frame to frame ``exp(-step / speckle_decorrelation_um)``, step the
    tissue's median motion between the frames); 0: a speckle new in every frame."""

    blob_um: float = BLOB_UM
    contrast: float = CONTRAST
    depth_sigma: float = DEPTH_SIGMA
    speckle: float = SPECKLE
    attenuation_mm: float = ATTENUATION_MM
    noise: float = NOISE
    speckle_decorrelation_um: float = 0.0


class TissueTexture:
    """A random texture in the myocardium's material coordinates: ``(S, theta,
    depth)``, S the material position along the tube (mm), theta the material angle
    (rad, periodic), depth 0 at the outer wall and 1 at the inner wall. Values about
    1 on average (SD ``params.contrast``), blobs of ``params.blob_um``."""

    def __init__(
        self, phantom: Phantom, rng: np.random.Generator, params: TextureParams = TextureParams()
    ):
        p = phantom.p
        self.params = params
        r = max(p.radius_inlet_mm, p.radius_outlet_mm)
        step_mm = LATTICE_UM * 1e-3
        self.n_s = int(np.ceil(p.length_mm / step_mm)) + 1
        self.n_theta = int(np.ceil(2 * np.pi * r / step_mm))
        self.ds = p.length_mm / (self.n_s - 1)
        sigma = params.blob_um / LATTICE_UM
        self.values = random_texture(
            (self.n_s, self.n_theta, DEPTH_LAYERS),
            (sigma, sigma, params.depth_sigma),
            rng,
            mode=("nearest", "wrap", "nearest"),
            contrast=params.contrast,
        )

    def __call__(self, S: np.ndarray, theta: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """The texture at material points (broadcasting), linear between samples."""
        from scipy.ndimage import map_coordinates

        S, theta, depth = np.broadcast_arrays(S, theta, depth)
        i = np.clip(S / self.ds, 0, self.n_s - 1)
        j = np.mod(theta / (2 * np.pi) * self.n_theta, self.n_theta)
        k = np.clip(depth, 0, 1) * (DEPTH_LAYERS - 1)
        wrapped = np.concatenate([self.values, self.values[:, :1]], axis=1)  # theta's wrap
        return map_coordinates(wrapped, [i, j, k], order=1, mode="nearest")


class TissueSpeckle:
    """A speckle carried by the myocardium (:class:`TissueTexture`'s material
    coordinates) and renewed as it moves: a unit Gaussian field of ``grain_um`` (its
    lattice one grain a sample) that each :meth:`advance` mixes with a fresh one,
    ``rho x old + sqrt(1 - rho^2) x new`` with ``rho = exp(-step / decorrelation)``.
    The instrument's speckle is the tissue's scatterers seen through the beam: still
    tissue keeps it, motion renews it (real OCT's decorrelation, which a speckle new
    in every frame overstates at slow motion and a fixed one understates)."""

    def __init__(
        self, phantom: Phantom, rng: np.random.Generator, grain_um: float, decorrelation_um: float
    ):
        p = phantom.p
        self.phantom, self.rng = phantom, rng
        self.decorrelation_um = decorrelation_um
        r = max(p.radius_inlet_mm, p.radius_outlet_mm)
        step_mm = grain_um * 1e-3
        self.shape = (
            int(np.ceil(p.length_mm / step_mm)) + 1,
            int(np.ceil(2 * np.pi * r / step_mm)),
            SPECKLE_DEPTH_LAYERS,
        )
        self.ds = p.length_mm / (self.shape[0] - 1)
        self.values = self._fresh()
        self.t_ms = None

    def _fresh(self) -> np.ndarray:
        from scipy import ndimage

        field = ndimage.gaussian_filter(
            self.rng.standard_normal(self.shape).astype(np.float32),
            1.0,
            mode=("nearest", "wrap", "nearest"),
        )
        return field / field.std()

    def step_um(self, t0_ms: float, t1_ms: float) -> float:
        """The myocardium's median motion (um) from ``t0_ms`` to ``t1_ms``: its outer
        wall's material points (a 24 x 36 lattice) in both frames."""
        ph, L = self.phantom, self.phantom.p.length_mm
        S, Theta = np.meshgrid(
            np.linspace(0.02, 0.98, 24) * L,
            np.linspace(-np.pi, np.pi, 36, endpoint=False),
            indexing="ij",
        )
        points = []
        for t in (t0_ms, t1_ms):
            s = np.clip(L - (L - S) * ph.stretch(t), 0.0, L)
            points.append(ph.point("outer", s, Theta + ph.twist(s, t), t))
        return 1e3 * float(np.median(np.linalg.norm(points[1] - points[0], axis=-1)))

    def advance(self, t_ms: float) -> None:
        """The speckle at ``t_ms``: renewed by the tissue's motion since the last."""
        if self.t_ms is not None:
            rho = np.exp(-self.step_um(self.t_ms, t_ms) / self.decorrelation_um)
            self.values = rho * self.values + np.sqrt(1 - rho**2) * self._fresh()
        self.t_ms = t_ms

    def __call__(self, S: np.ndarray, theta: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """The unit field at material points (broadcasting), linear between samples."""
        from scipy.ndimage import map_coordinates

        n_s, n_theta, n_d = self.shape
        i = np.clip(S / self.ds, 0, n_s - 1)
        j = np.mod(theta / (2 * np.pi) * n_theta, n_theta)
        k = np.clip(depth, 0, 1) * (n_d - 1)
        wrapped = np.concatenate([self.values, self.values[:, :1]], axis=1)
        return map_coordinates(wrapped, [i, j, k], order=1, mode="nearest")


def developed(field: np.ndarray, contrast: float) -> np.ndarray:
    """A unit Gaussian ``field`` as a fully developed speckle: log-normal, mean 1 and
    SD ``contrast`` (positive however large the contrast, unlike ``1 + c g``)."""
    sigma = np.sqrt(np.log1p(contrast**2))
    return np.exp(sigma * field - 0.5 * sigma**2).astype(np.float32)


def intensity_volume(
    grid,
    texture: TissueTexture,
    t_ms: float,
    rng: np.random.Generator,
    speckle: TissueSpeckle | None = None,
) -> np.ndarray:
    """The frame's intensity ``(z, y, x)`` uint8 at ``t_ms`` on ``grid`` (a
    :class:`~oftimg.synthetic.labels.LabelGrid`): each layer's level, the
    myocardium's times its texture at each voxel's material point, times a speckle
    new in this frame (with ``speckle``, the myocardium's carried by the tissue and
    advanced to ``t_ms`` here), attenuated along y, plus noise (scaled so that 1 is
    255: :func:`imaged`)."""
    ph = grid.phantom
    out = np.full(grid.shape, LEVEL["background"], np.float32)
    flat = out.reshape(-1)
    s, theta, dist = grid.s, grid.theta, grid.distance
    outer = ph.radius("outer", s, theta, t_ms)
    inner = ph.radius("inner", s, theta, t_ms)
    lumen = ph.radius("lumen", s, theta, t_ms)
    myo = (dist <= outer) & (dist > inner)
    S, theta_m = ph.material_from_window(s[myo], theta[myo], t_ms)
    depth = (outer[myo] - dist[myo]) / (outer[myo] - inner[myo])
    flat[grid.index[myo]] = LEVEL["myocardium"] * texture(S, theta_m, depth)
    flat[grid.index[(dist <= inner) & (dist > lumen)]] = LEVEL["jelly"]
    flat[grid.index[dist <= lumen]] = LEVEL["lumen"]
    y_mm = np.arange(grid.shape[1]) * grid.voxel_mm[1]
    look = texture.params
    out *= np.exp(-y_mm / look.attenuation_mm)[None, :, None]
    if speckle is None:
        return imaged(out, rng, speckle=look.speckle, noise=look.noise)
    from scipy import ndimage

    speckle.advance(t_ms)
    lab = ndimage.gaussian_filter(rng.standard_normal(out.shape).astype(np.float32), SPECKLE_VOXELS)
    factor = developed(lab / lab.std(), look.speckle).reshape(-1)
    factor[grid.index[myo]] = developed(speckle(S, theta_m, depth), look.speckle)
    out = out * factor.reshape(out.shape)
    return imaged(out, rng, speckle=0.0, noise=look.noise)


def random_texture(
    shape: tuple, sigma, rng: np.random.Generator, mode="nearest", contrast: float = CONTRAST
) -> np.ndarray:
    """A smooth random field ``shape`` float32 about 1 (SD ``contrast``, at least
    0.2): white noise blurred by ``sigma`` (samples, per axis; ``mode`` at the edges)."""
    from scipy import ndimage

    field = ndimage.gaussian_filter(rng.standard_normal(shape).astype(np.float32), sigma, mode=mode)
    return np.clip(1.0 + contrast * field / field.std(), 0.2, None).astype(np.float32)


def imaged(
    volume: np.ndarray, rng: np.random.Generator, *, speckle: float = SPECKLE, noise: float = NOISE
) -> np.ndarray:
    """A clean intensity ``volume`` (0..1) as an OCT frame: times a speckle new in this
    frame (SD ``speckle``, grain :data:`SPECKLE_VOXELS`), plus noise (SD ``noise``),
    as uint8 (1 is 255)."""
    from scipy import ndimage

    out = volume
    if speckle > 0:
        grain = ndimage.gaussian_filter(
            rng.standard_normal(volume.shape).astype(np.float32), SPECKLE_VOXELS
        )
        out = volume * np.clip(1.0 + speckle * grain / grain.std(), 0.0, None)
    out = out + rng.normal(0.0, noise, volume.shape).astype(np.float32)
    return np.clip(np.round(out * 255), 0, 255).astype(np.uint8)
