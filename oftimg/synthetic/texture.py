"""Intensity volumes of the label phantom, as OCT would image it: a texture fixed in
the tissue (cell-sized blobs in the myocardium, in material coordinates, so that it
slides and twists with the tissue beneath the walls), speckle that changes in every
frame, attenuation with depth along the beam, and noise.

The texture is what lets a run follow the tissue along the tube, which the walls'
shapes cannot show (:meth:`~oftimg.synthetic.phantom.Phantom.material_from_window`).
Volumes are ``(z, y, x)`` uint8 on the labels' voxels
(:class:`~oftimg.synthetic.labels.LabelGrid`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .phantom import Phantom

TWIST_DEG = 20.0            # the textured phantom's tissue twist at the inlet (contracted)
BLOB_UM = 6.0               # the texture's grain (Gaussian sigma of its random field), um
LATTICE_UM = 3.0            # the texture's sampling in the tissue
DEPTH_LAYERS = 8            # the texture's samples across the myocardium
# mean intensity of each layer (0..1 before 8-bit scaling) and the texture's contrast
LEVEL = {"myocardium": 0.55, "jelly": 0.22, "lumen": 0.08, "background": 0.04}
CONTRAST = 0.35             # the texture's SD over the myocardium's mean
SPECKLE = 0.2               # SD of the multiplicative speckle, new in every frame
SPECKLE_VOXELS = 0.6        # its grain (Gaussian sigma, voxels)
ATTENUATION_MM = 1.5        # the beam's 1/e depth along y
NOISE = 0.015               # SD of the additive noise
DEPTH_SIGMA = 0.6           # the texture's correlation through the wall, in depth samples


@dataclass(frozen=True)
class TextureParams:
    """How the tissue looks and is imaged: the texture's grain (``blob_um``, Gaussian
    sigma), ``contrast`` (its SD over its mean), its correlation through the wall
    (``depth_sigma``, in :data:`DEPTH_LAYERS` samples across the myocardium: small, a
    texture that changes with depth), the ``speckle`` new in every frame (SD), the
    beam's 1/e depth ``attenuation_mm`` and the additive ``noise`` (SD, 1 = 255).
    The defaults are the textured phantom's."""

    blob_um: float = BLOB_UM
    contrast: float = CONTRAST
    depth_sigma: float = DEPTH_SIGMA
    speckle: float = SPECKLE
    attenuation_mm: float = ATTENUATION_MM
    noise: float = NOISE


class TissueTexture:
    """A random texture in the myocardium's material coordinates: ``(S, theta,
    depth)``, S the material position along the tube (mm), theta the material angle
    (rad, periodic), depth 0 at the outer wall and 1 at the inner wall. Values about
    1 on average (SD ``params.contrast``), blobs of ``params.blob_um``."""

    def __init__(self, phantom: Phantom, rng: np.random.Generator,
                 params: TextureParams = TextureParams()):
        p = phantom.p
        self.params = params
        r = max(p.radius_inlet_mm, p.radius_outlet_mm)
        step_mm = LATTICE_UM * 1e-3
        self.n_s = int(np.ceil(p.length_mm / step_mm)) + 1
        self.n_theta = int(np.ceil(2 * np.pi * r / step_mm))
        self.ds = p.length_mm / (self.n_s - 1)
        sigma = params.blob_um / LATTICE_UM
        self.values = random_texture((self.n_s, self.n_theta, DEPTH_LAYERS),
                                     (sigma, sigma, params.depth_sigma), rng,
                                     mode=("nearest", "wrap", "nearest"),
                                     contrast=params.contrast)

    def __call__(self, S: np.ndarray, theta: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """The texture at material points (broadcasting), linear between samples."""
        from scipy.ndimage import map_coordinates

        S, theta, depth = np.broadcast_arrays(S, theta, depth)
        i = np.clip(S / self.ds, 0, self.n_s - 1)
        j = np.mod(theta / (2 * np.pi) * self.n_theta, self.n_theta)
        k = np.clip(depth, 0, 1) * (DEPTH_LAYERS - 1)
        wrapped = np.concatenate([self.values, self.values[:, :1]], axis=1)   # theta's wrap
        return map_coordinates(wrapped, [i, j, k], order=1, mode="nearest")


def intensity_volume(grid, texture: TissueTexture, t_ms: float,
                     rng: np.random.Generator) -> np.ndarray:
    """The frame's intensity ``(z, y, x)`` uint8 at ``t_ms`` on ``grid`` (a
    :class:`~oftimg.synthetic.labels.LabelGrid`): each layer's level, the
    myocardium's times its texture at each voxel's material point, times a speckle
    new in this frame, attenuated along y, plus noise (scaled so that 1 is 255:
    :func:`imaged`)."""
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
    return imaged(out, rng, speckle=look.speckle, noise=look.noise)


def random_texture(shape: tuple, sigma, rng: np.random.Generator, mode="nearest",
                   contrast: float = CONTRAST) -> np.ndarray:
    """A smooth random field ``shape`` float32 about 1 (SD ``contrast``, at least
    0.2): white noise blurred by ``sigma`` (samples, per axis; ``mode`` at the edges)."""
    from scipy import ndimage

    field = ndimage.gaussian_filter(rng.standard_normal(shape).astype(np.float32), sigma,
                                    mode=mode)
    return np.clip(1.0 + contrast * field / field.std(), 0.2, None).astype(np.float32)


def imaged(volume: np.ndarray, rng: np.random.Generator, *, speckle: float = SPECKLE,
           noise: float = NOISE) -> np.ndarray:
    """A clean intensity ``volume`` (0..1) as an OCT frame: times a speckle new in this
    frame (SD ``speckle``, grain :data:`SPECKLE_VOXELS`), plus noise (SD ``noise``),
    as uint8 (1 is 255)."""
    from scipy import ndimage

    grain = ndimage.gaussian_filter(rng.standard_normal(volume.shape).astype(np.float32),
                                    SPECKLE_VOXELS)
    out = volume * np.clip(1.0 + speckle * grain / grain.std(), 0.0, None)
    out += rng.normal(0.0, noise, volume.shape).astype(np.float32)
    return np.clip(np.round(out * 255), 0, 255).astype(np.uint8)
