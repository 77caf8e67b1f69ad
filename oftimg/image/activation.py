"""Wave fronts on the wall, as optical mapping reads them from flat videos: each grid
node's activation time, the surface wave velocity from its gradient on the wall, and
the phase of each node's motion.

Functions of arrays: a wall's grid ``(n_u, n_v, n_t, 3)`` mm over one periodic cycle
(u around and periodic, v along from the inlet), times in ms. The marker is the
first harmonic of each node's motion along the wall's normal: its phase is read from
every frame at once, so it is sub-frame and robust to a node's frame-to-frame noise
(the time of the steepest outward motion of that harmonic is the activation time).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter

# Gaussian sigma (grid nodes) of the activation map's smoothing before its gradient:
# the gradient of a noisy map is noisier still; 2 nodes is 1/40 of the way round and
# 1/25 of the tube's length
VELOCITY_SMOOTHING_NODES = 2.0
# activation spread (5th to 95th percentile over the wall) below this many times its
# noise: the wall moves at once, and no propagation is reported
NO_PROPAGATION_SPREAD = 4.0
# a node moves when its first harmonic's amplitude is this many times its noise SD
# (sigma sqrt(2 / n_t)): below it the phase is the noise's, not the wall's
MOTION_SNR = 5.0
# the earliest node is sought among nodes moving at least this share of the median one
EARLIEST_AMPLITUDE = 0.5
# the noise is read from the harmonics from this one up: below it lies the beat's own
# shape (a hump is no cosine), which a residual about the first harmonic counts as
# noise (4 times the errors on the phantom)
NOISE_HARMONIC = 6


def normal_displacement(grid: np.ndarray) -> np.ndarray:
    """Each node's displacement (mm) from its place over the cycle along the wall's
    outward normal there: ``(n_u, n_v, n_t)`` of a grid ``(n_u, n_v, n_t, 3)`` (the
    normal of the cycle's mean shape, outward from the tube's axis). Tissue that
    slides within the wall (the twist round a wall that is not round, the slide along
    a tapered tube) moves along it, not across it, to first order; its distance from
    the ring's centre takes that slide for the wave (on the bench embryo as labels,
    twisted 20 degrees round a cornered wall: activation 5.3 ms RMS off and the speed
    on the wall 39 % low, against 1.0 ms and 1 % along the normal). No centre is taken
    either: a front that comes first on one side moves any ring's centre towards it.
    The price: a tube that swings sideways as a whole reads as a front that comes
    first on one side (:func:`ring_swing`)."""
    mean = grid.mean(axis=2)
    e_u = 0.5 * (np.roll(mean, -1, axis=0) - np.roll(mean, 1, axis=0))
    e_v = np.gradient(mean, axis=1)
    normal = np.cross(e_u, e_v)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    outward = mean - mean.mean(axis=0, keepdims=True)      # from each ring's centre
    if np.nansum(outward * normal) < 0:                     # u runs clockwise
        normal = -normal
    return ((grid - mean[:, :, None]) * normal[:, :, None]).sum(axis=-1)


def ring_swing(grid: np.ndarray) -> np.ndarray:
    """How far each ring's centre moves over the cycle (mm, the first harmonic's
    amplitude of its path, ``(n_v,)``): sideways swing of the tube, which
    :func:`normal_displacement` reads as a front that comes first on one side."""
    centres = grid.mean(axis=0)                                    # (n_v, n_t, 3)
    n_t = centres.shape[1]
    first = np.exp(-2j * np.pi * np.arange(n_t) / n_t)
    return np.linalg.norm(2.0 * np.abs(np.einsum("vtx,t->vx", centres, first)) / n_t, axis=-1)


@dataclass(frozen=True)
class Activation:
    """Each node's activation time ``time_ms`` ``(n_u, n_v)`` in [0, period), its noise
    SD ``sd_ms``, the first harmonic's amplitude ``amplitude`` (the marker's units)
    and ``moving`` (that amplitude :data:`MOTION_SNR` times its noise, else the time
    is the noise's); ``phase`` ``(n_u, n_v, n_t)`` the node's phase of its motion in
    radians, 0 at activation, in (-pi, pi]."""

    time_ms: np.ndarray
    sd_ms: np.ndarray
    amplitude: np.ndarray
    moving: np.ndarray
    phase: np.ndarray


def activation_times(marker: np.ndarray, period_ms: float) -> Activation:
    """Activation of each node from its ``marker`` ``(n_u, n_v, n_t)`` over one
    periodic cycle of ``n_t`` equal frames: the time at which the marker's first
    harmonic rises fastest. Noise: the frame-to-frame noise SD sigma
    (:func:`noise_sd`) gives the phase's SD sigma / (A sqrt(n_t / 2)) (a harmonic's
    least-squares fit), in ms."""
    n_t = marker.shape[-1]
    t = np.arange(n_t)
    first = np.exp(-2j * np.pi * t / n_t)
    coefficient = 2.0 * (marker @ first) / n_t                # A exp(i phi): A cos(wt + phi)
    amplitude = np.abs(coefficient)
    phi = np.angle(coefficient)
    # A cos(w t + phi) rises fastest where w t + phi = -pi / 2
    time_frames = np.mod((-np.pi / 2 - phi) * n_t / (2 * np.pi), n_t)
    residual_sd = noise_sd(marker)
    with np.errstate(divide="ignore", invalid="ignore"):
        phase_sd = residual_sd / (amplitude * np.sqrt(n_t / 2.0))
    frame_ms = period_ms / n_t
    phase = np.angle(np.exp(1j * (2 * np.pi * (t - time_frames[..., None]) / n_t)))
    moving = amplitude > MOTION_SNR * residual_sd * np.sqrt(2.0 / n_t)
    return Activation(time_frames * frame_ms, phase_sd * period_ms / (2 * np.pi), amplitude,
                      moving, phase)


def noise_sd(marker: np.ndarray) -> np.ndarray:
    """Each node's frame-to-frame noise SD from the harmonics of its marker from
    :data:`NOISE_HARMONIC` up to Nyquist (white noise of SD sigma puts n sigma^2 into
    each ``|F_k|^2``); with too few frames for that, from the residual about the first
    harmonic."""
    n_t = marker.shape[-1]
    spectrum = np.fft.rfft(marker, axis=-1)
    high = spectrum[..., NOISE_HARMONIC:(n_t - 1) // 2 + 1]
    if high.shape[-1] >= 3:
        return np.sqrt((np.abs(high) ** 2).mean(axis=-1) / n_t)
    first = spectrum[..., 1]
    t = np.arange(n_t)
    fitted = marker.mean(axis=-1, keepdims=True) + 2.0 / n_t * np.real(
        first[..., None] * np.exp(2j * np.pi * t / n_t))
    return np.sqrt(((marker - fitted) ** 2).sum(axis=-1) / max(n_t - 3, 1))


def unwrapped(time_ms: np.ndarray, period_ms: float) -> np.ndarray:
    """Activation times about their circular mean, in (-period/2, period/2]: a wave
    that crosses the cycle's start is not cut there."""
    angle = 2 * np.pi * time_ms / period_ms
    centre = np.angle(np.nanmean(np.exp(1j * angle)))
    return np.angle(np.exp(1j * (angle - centre))) * period_ms / (2 * np.pi)


@dataclass(frozen=True)
class SurfaceVelocity:
    """The wave's velocity on the wall at each node ``(n_u, n_v)``: ``speed_mm_s``
    (``1 / |grad t|`` on the wall), ``angle_deg`` of its direction to the tube's axis (0
    along from the inlet to the outlet, 90 around in the direction of u, 180 back
    towards the inlet), ``along_mm_s`` and ``around_mm_s`` its components (the
    velocity's, speed times the direction), and ``axial_slowness_ms_mm`` the time the
    front takes a mm along the axis (dt/ds, the quantity the paper's ridge speed is
    the inverse of)."""

    speed_mm_s: np.ndarray
    angle_deg: np.ndarray
    along_mm_s: np.ndarray
    around_mm_s: np.ndarray
    axial_slowness_ms_mm: np.ndarray


def surface_velocity(time_ms: np.ndarray, grid_mm: np.ndarray, period_ms: float, *,
                     smoothing_nodes: float = VELOCITY_SMOOTHING_NODES) -> SurfaceVelocity:
    """The wave velocity on the wall from activation times ``(n_u, n_v)`` and the
    wall's shape ``grid_mm`` ``(n_u, n_v, 3)`` (the cycle's mean: each node's metric in
    mm). The times are taken on the cycle's circle (a helical front's go once round
    it), smoothed there by a Gaussian of ``smoothing_nodes`` (periodic around), and
    differentiated on the grid (central differences of neighbours' times, each
    difference within half a period; periodic in u); the gradient on the surface is
    ``g^-1 (dt/du, dt/dv)`` in the grid's tangents, its length the slowness (ms/mm)."""
    phasor = np.exp(2j * np.pi * time_ms / period_ms)         # times on the cycle's circle
    if smoothing_nodes > 0:
        phasor = (gaussian_filter(phasor.real, smoothing_nodes, mode=("wrap", "nearest"))
                  + 1j * gaussian_filter(phasor.imag, smoothing_nodes, mode=("wrap", "nearest")))
    t = np.angle(phasor) * period_ms / (2 * np.pi)
    e_u = 0.5 * (np.roll(grid_mm, -1, axis=0) - np.roll(grid_mm, 1, axis=0))
    e_v = np.gradient(grid_mm, axis=1)
    t_u = 0.5 * _wrapped(np.roll(t, -1, axis=0) - np.roll(t, 1, axis=0), period_ms)
    t_v = np.empty_like(t)                               # np.gradient's, on the circle
    t_v[:, 1:-1] = 0.5 * _wrapped(t[:, 2:] - t[:, :-2], period_ms)
    t_v[:, 0] = _wrapped(t[:, 1] - t[:, 0], period_ms)
    t_v[:, -1] = _wrapped(t[:, -1] - t[:, -2], period_ms)
    g_uu = (e_u * e_u).sum(-1)
    g_uv = (e_u * e_v).sum(-1)
    g_vv = (e_v * e_v).sum(-1)
    det = g_uu * g_vv - g_uv ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        a_u = (g_vv * t_u - g_uv * t_v) / det              # contravariant gradient
        a_v = (g_uu * t_v - g_uv * t_u) / det
        gradient = a_u[..., None] * e_u + a_v[..., None] * e_v      # ms/mm, in 3-D
        slowness = np.linalg.norm(gradient, axis=-1)
        along = e_v / np.linalg.norm(e_v, axis=-1, keepdims=True)
        around = e_u - (e_u * along).sum(-1, keepdims=True) * along
        around /= np.linalg.norm(around, axis=-1, keepdims=True)
        g_along = (gradient * along).sum(-1)
        g_around = (gradient * around).sum(-1)
        speed = 1e3 / slowness
        angle = np.degrees(np.arctan2(g_around, g_along))
        # the velocity points along the gradient, its length 1 / |gradient|
        along_mm_s = 1e3 * g_along / slowness ** 2
        around_mm_s = 1e3 * g_around / slowness ** 2
        axial = t_v / np.linalg.norm(e_v, axis=-1)         # dt/ds along the grid's rows
    return SurfaceVelocity(speed, angle, along_mm_s, around_mm_s, axial)


def _wrapped(difference: np.ndarray, period_ms: float) -> np.ndarray:
    """A difference of two times on the cycle, in (-period/2, period/2]: a helical
    front's times go once round the cycle on the way round the tube."""
    return difference - period_ms * np.round(difference / period_ms)


def propagates(activation: Activation, period_ms: float) -> bool:
    """Whether most of the wall moves (:attr:`Activation.moving`) and its activation
    times spread over it by more than their noise (:data:`NO_PROPAGATION_SPREAD` times
    its median): a wall that moves at once, or not at all, has no wave to measure."""
    t = unwrapped(activation.time_ms, period_ms)
    sd_ms = activation.sd_ms
    finite = np.isfinite(t) & np.isfinite(sd_ms) & activation.moving
    if finite.sum() < max(3, activation.moving.size // 2):
        return False
    low, high = np.percentile(t[finite], [5, 95])
    return bool(high - low > NO_PROPAGATION_SPREAD * np.median(sd_ms[finite]))


def wave_summary(activation: Activation, velocity: SurfaceVelocity, s_mm: np.ndarray,
                 period_ms: float) -> dict:
    """The wave on one wall in numbers: ``propagates``; the median surface speed
    (mm/s); the axial speed (mm/s: the inverse of the median dt/ds, beside the paper's
    ridge speed); the helix angle's median and interquartile range (degrees, the
    velocity's angle to the axis folded into [-90, 90]: a front running back counts by
    its slant); the earliest node ``(i_u, i_v)`` among those moving at least
    :data:`EARLIEST_AMPLITUDE` of the median node, and its position ``s_mm``; the slowest
    band (the row whose median speed is least, its ``s_mm``, and that speed). Every
    number None where the wall does not propagate."""
    if not propagates(activation, period_ms):
        return {"propagates": False, "speed_mm_s": None, "axial_speed_mm_s": None,
                "helix_angle_deg": None, "helix_angle_iqr_deg": None, "earliest_node": None,
                "earliest_s_mm": None, "slowest_s_mm": None, "slowest_speed_mm_s": None}
    angle = np.mod(velocity.angle_deg + 90.0, 180.0) - 90.0           # its slant
    q1, median_angle, q3 = np.nanpercentile(angle, [25, 50, 75])
    slowness = np.nanmedian(velocity.axial_slowness_ms_mm)
    t = unwrapped(activation.time_ms, period_ms)
    # where the wave starts: among nodes moving at least half as much as the median one
    # (a band that barely moves takes its timing from its neighbours' pull, not the wave)
    strong = activation.moving & (activation.amplitude >= EARLIEST_AMPLITUDE
                                  * np.median(activation.amplitude[activation.moving]))
    earliest = np.unravel_index(np.nanargmin(np.where(strong, t, np.nan)), t.shape)
    rows = np.nanmedian(velocity.speed_mm_s, axis=0)
    slowest = int(np.nanargmin(rows[2:-2])) + 2 if rows.size > 4 else int(np.nanargmin(rows))
    return {"propagates": True, "speed_mm_s": float(np.nanmedian(velocity.speed_mm_s)),
            "axial_speed_mm_s": float(1e3 / slowness) if slowness > 0 else None,
            "helix_angle_deg": float(median_angle), "helix_angle_iqr_deg": float(q3 - q1),
            "earliest_node": [int(earliest[0]), int(earliest[1])],
            "earliest_s_mm": float(s_mm[earliest[1]]), "slowest_s_mm": float(s_mm[slowest]),
            "slowest_speed_mm_s": float(rows[slowest])}
