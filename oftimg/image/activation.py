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

import warnings

from dataclasses import dataclass

import numpy as np

# Gaussian sigma (grid nodes) of the weights of the plane fitted to the times about each
# node, when given: 2 nodes is 1/40 of the way round and 1/25 of the tube's length
VELOCITY_SMOOTHING_NODES = 2.0
# the sigma chosen for a wall (:func:`auto_smoothing`): the smallest of this ladder at
# which the times' scatter over the gradient per node, over sigma^2, is at most
# AUTO_GRADIENT_NOISE (the widest where none is). A noisy gradient is a long one: the
# speed comes out low (on 10 zoo mesh draws whose fronts are cross-sections, fast: 1-18 %
# low at 2 nodes; at the chosen sigma 0.3-6 %), and more smoothing rounds a front that
# comes first on one side (+8 % at 6 nodes where 2 gave +1 % and 4 gave +3 %)
VELOCITY_SMOOTHING_LADDER = (2.0, 3.0, 4.0)
AUTO_GRADIENT_NOISE = 0.03
# ... and no wider than where the gradient's median length is still this share of its
# length at the ladder's first: a plane fitted over more nodes than the fronts are
# straight rounds them (on the midgut animated with a two-start helix, whose grid folds
# with the gut, the speed came out +7 % at 2 nodes, +30 % at 3 and +66 % at 4, the
# gradient 0.84 and 0.69 as long; noise shortened it to 0.92 at most on the zoo)
AUTO_GRADIENT_KEPT = 0.9
# activation spread (5th to 95th percentile over the wall) below this many times its
# noise: the wall moves at once, and no propagation is reported
NO_PROPAGATION_SPREAD = 4.0
# a node moves when its first harmonic's amplitude is this many times its noise SD
# (sigma sqrt(2 / n_t)): below it the phase is the noise's, not the wall's
MOTION_SNR = 5.0
# a node whose first harmonic is under this share of the median moving node's is weak:
# a band that barely moves takes its timing from its neighbours' pull, not the wave (on
# a zoo draw whose band blocked its motion, rows moving 1/15 as much as the rest were up
# to half a period off); weak nodes give no velocity, no summary and no earliest place
STRONG_AMPLITUDE = 0.5
# the activation time's SD is at least this share of the period: the errors a run cannot
# see in its own data (where the grid lies round and along the tube, which a steep
# front turns into time, smooth from node to node). On 30 zoo mesh draws with helical
# and one-sided fronts the nodes within 1.96 SD went from a median 92 % (10th
# percentile 71 %) without it to 96 % (87 %) with it; checked on other draws in
# docs/accuracy.md
ACTIVATION_FLOOR_SHARE = 0.002
# the noise is read from the harmonics from this one up: below it lies the beat's own
# shape (a hump is no cosine), which a residual about the first harmonic counts as
# noise (4 times the errors on the phantom)
NOISE_HARMONIC = 6


def grid_tangents(grid_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The grid's tangents ``(e_u, e_v)`` (mm per node, ``(n_u, n_v, 3)`` each) of a
    wall's shape ``(n_u, n_v, 3)``: central differences, periodic round the tube,
    one-sided at its ends."""
    return (
        0.5 * (np.roll(grid_mm, -1, axis=0) - np.roll(grid_mm, 1, axis=0)),
        np.gradient(grid_mm, axis=1),
    )


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
    normal = np.cross(*grid_tangents(mean))
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    outward = mean - mean.mean(axis=0, keepdims=True)  # from each ring's centre
    if np.nansum(outward * normal) < 0:  # u runs clockwise
        normal = -normal
    return (
        np.einsum("uvtx,uvx->uvt", grid, normal)
        - np.einsum("uvx,uvx->uv", mean, normal)[:, :, None]
    )


def ring_swing(grid: np.ndarray) -> np.ndarray:
    """How far each ring's centre moves over the cycle (mm, the first harmonic's
    amplitude of its path, ``(n_v,)``): sideways swing of the tube, which
    :func:`normal_displacement` reads as a front that comes first on one side."""
    centres = grid.mean(axis=0)  # (n_v, n_t, 3)
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


def strong(activation: Activation) -> np.ndarray:
    """The nodes ``(n_u, n_v)`` whose time reads the wave: moving, their first
    harmonic at least :data:`STRONG_AMPLITUDE` of the median moving node's."""
    moving = activation.moving
    if not moving.any():
        return moving
    return moving & (
        activation.amplitude >= STRONG_AMPLITUDE * np.median(activation.amplitude[moving])
    )


def activation_times(marker: np.ndarray, period_ms: float) -> Activation:
    """Activation of each node from its ``marker`` ``(n_u, n_v, n_t)`` over one
    periodic cycle of ``n_t`` equal frames: the time at which the marker's first
    harmonic rises fastest. Noise: the frame-to-frame noise SD sigma
    (:func:`noise_sd`) gives the phase's SD sigma / (A sqrt(n_t / 2)) (a harmonic's
    least-squares fit), in ms."""
    n_t = marker.shape[-1]
    t = np.arange(n_t)
    first = np.exp(-2j * np.pi * t / n_t)
    coefficient = 2.0 * (marker @ first) / n_t  # A exp(i phi): A cos(wt + phi)
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
    return Activation(
        time_frames * frame_ms, phase_sd * period_ms / (2 * np.pi), amplitude, moving, phase
    )


def noise_sd(marker: np.ndarray) -> np.ndarray:
    """Each node's frame-to-frame noise SD from the harmonics of its marker from
    :data:`NOISE_HARMONIC` up to Nyquist (white noise of SD sigma puts n sigma^2 into
    each ``|F_k|^2``); with too few frames for that, from the residual about the first
    harmonic."""
    n_t = marker.shape[-1]
    spectrum = np.fft.rfft(marker, axis=-1)
    high = spectrum[..., NOISE_HARMONIC : (n_t - 1) // 2 + 1]
    if high.shape[-1] >= 3:
        return np.sqrt((np.abs(high) ** 2).mean(axis=-1) / n_t)
    first = spectrum[..., 1]
    t = np.arange(n_t)
    fitted = marker.mean(axis=-1, keepdims=True) + 2.0 / n_t * np.real(
        first[..., None] * np.exp(2j * np.pi * t / n_t)
    )
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
    the inverse of); ``scatter_ms`` the times' scatter about the plane fitted at each
    node (:func:`time_gradient`)."""

    speed_mm_s: np.ndarray
    angle_deg: np.ndarray
    along_mm_s: np.ndarray
    around_mm_s: np.ndarray
    axial_slowness_ms_mm: np.ndarray
    scatter_ms: np.ndarray


def surface_velocity(
    time_ms: np.ndarray,
    grid_mm: np.ndarray,
    period_ms: float,
    *,
    smoothing_nodes: float = VELOCITY_SMOOTHING_NODES,
    use: np.ndarray | None = None,
) -> SurfaceVelocity:
    """The wave velocity on the wall from activation times ``(n_u, n_v)`` and the
    wall's shape ``grid_mm`` ``(n_u, n_v, 3)`` (the cycle's mean: each node's metric in
    mm). The times' gradient on the grid is a local plane fitted to them about each
    node (:func:`time_gradient`: weighted by a Gaussian of ``smoothing_nodes``, over the
    nodes ``use``, bool ``(n_u, n_v)``, default all), as optical mapping fits its
    activation maps; on the surface it is ``g^-1 (dt/du, dt/dv)`` in the grid's
    tangents, its length the slowness (ms/mm). Every number is NaN at nodes outside
    ``use`` and where too few of them lie near."""
    use = np.ones(time_ms.shape, bool) if use is None else use
    t_u, t_v, scatter = time_gradient(time_ms, period_ms, smoothing_nodes, use)
    e_u, e_v = grid_tangents(grid_mm)
    g_uu = (e_u * e_u).sum(-1)
    g_uv = (e_u * e_v).sum(-1)
    g_vv = (e_v * e_v).sum(-1)
    det = g_uu * g_vv - g_uv**2
    with np.errstate(divide="ignore", invalid="ignore"):
        a_u = (g_vv * t_u - g_uv * t_v) / det  # contravariant gradient
        a_v = (g_uu * t_v - g_uv * t_u) / det
        gradient = a_u[..., None] * e_u + a_v[..., None] * e_v  # ms/mm, in 3-D
        slowness = np.linalg.norm(gradient, axis=-1)
        along = e_v / np.linalg.norm(e_v, axis=-1, keepdims=True)
        around = e_u - (e_u * along).sum(-1, keepdims=True) * along
        around /= np.linalg.norm(around, axis=-1, keepdims=True)
        g_along = (gradient * along).sum(-1)
        g_around = (gradient * around).sum(-1)
        speed = 1e3 / slowness
        angle = np.degrees(np.arctan2(g_around, g_along))
        # the velocity points along the gradient, its length 1 / |gradient|
        along_mm_s = 1e3 * g_along / slowness**2
        around_mm_s = 1e3 * g_around / slowness**2
        axial = t_v / np.linalg.norm(e_v, axis=-1)  # dt/ds along the grid's rows
    return SurfaceVelocity(
        *(np.where(use, x, np.nan) for x in (speed, angle, along_mm_s, around_mm_s, axial, scatter))
    )


def auto_smoothing(
    time_ms: np.ndarray,
    period_ms: float,
    use: np.ndarray,
    *,
    ladder=VELOCITY_SMOOTHING_LADDER,
    target: float = AUTO_GRADIENT_NOISE,
) -> float:
    """The sigma (grid nodes) of the plane fits for a wall's activation times ``(n_u,
    n_v)`` over the nodes ``use``: the smallest of ``ladder`` at which x / sigma^2 is
    at most ``target``, x the times' median scatter about planes fitted over 1 node
    (:func:`time_gradient`) over the median length of their gradient per node (fitted
    over the ladder's widest: the signal, little touched by the noise). The
    gradient's noise falls as 1 / sigma^2 where the times' errors are alike from node
    to node; a mesh's facets and a lattice's voxels make them alike over a few nodes,
    so the target was set on the zoo (:data:`AUTO_GRADIENT_NOISE`). Never as wide as
    where the gradient is shorter than :data:`AUTO_GRADIENT_KEPT` of its length at the
    ladder's first (fronts rounded). The first of the ladder where nothing can be
    measured."""
    if use.sum() < 10:
        return float(ladder[0])
    with warnings.catch_warnings():  # no plane fits anywhere (a still tube): NaN, below
        warnings.simplefilter("ignore", RuntimeWarning)
        scatter = np.nanmedian(time_gradient(time_ms, period_ms, 1.0, use)[2])
        length = {
            sigma: np.nanmedian(np.hypot(*time_gradient(time_ms, period_ms, sigma, use)[:2]))
            for sigma in ladder
        }
    gradient = length[ladder[-1]]
    if not (np.isfinite(scatter) and np.isfinite(gradient) and gradient > 0):
        return float(ladder[0])
    chosen = ladder[0]
    for sigma in ladder:
        if length[sigma] < AUTO_GRADIENT_KEPT * length[ladder[0]]:
            break  # rounding the fronts
        chosen = sigma
        if scatter / gradient / sigma**2 <= target:
            break
    return float(chosen)


def time_gradient(
    time_ms: np.ndarray, period_ms: float, smoothing_nodes: float, use: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(dt/du, dt/dv, scatter)`` (ms per node and ms, ``(n_u, n_v)`` each) of
    activation times: at each node the plane ``t0 + a du + b dv`` fitted by least
    squares to the times of
    the nodes ``use`` within ``ceil(2 sigma)`` nodes (periodic in u, cut at the tube's
    ends), weighted by a Gaussian of sigma = ``smoothing_nodes`` (0: the four nearest
    nodes). Each neighbour's time is taken relative to the node's on the cycle's
    circle (a helical front's times go once round it). Why a fitted plane rather than
    the gradient of smoothed times: it is exact for a front of constant velocity
    whatever the neighbours it has, next to the tube's ends or to nodes left out (a
    smoothed map there leans towards the side that has them: 20-60 % off beside a band
    left out, on an analytic tube). ``scatter``: the times' weighted RMS about the
    plane, for the 3 numbers fitted (over the effective count of nodes, sum(w)^2 /
    sum(w^2)): a node's error where the errors are not alike from node to node, which
    the noise of a node's own motion misses (a mesh's vertices, a lattice's voxels).
    NaN where the fit has too few nodes."""
    n_u, n_v = time_ms.shape
    reach = max(1, int(np.ceil(2 * smoothing_nodes)))
    phasor = np.where(use, np.exp(2j * np.pi * time_ms / period_ms), 0)
    sums = {
        key: np.zeros((n_u, n_v))
        for key in ("w", "ww", "a", "b", "aa", "ab", "bb", "d", "ad", "bd", "dd")
    }
    for db in range(-reach, reach + 1):
        lo, hi = max(0, -db), min(n_v, n_v - db)  # nodes whose neighbour db exists
        for da in range(-reach, reach + 1):
            if smoothing_nodes > 0:
                w = np.exp(-(da * da + db * db) / (2 * smoothing_nodes**2))
            else:
                w = float(abs(da) + abs(db) <= 1)
            if w < 1e-6:
                continue
            other = np.roll(phasor, -da, axis=0)[:, lo + db : hi + db]
            here = phasor[:, lo:hi]
            weight = w * (np.abs(other) > 0) * (np.abs(here) > 0)
            d = np.angle(other * np.conj(here)) * period_ms / (2 * np.pi)
            for key, value in (
                ("w", 1.0),
                ("a", da),
                ("b", db),
                ("aa", da * da),
                ("ab", da * db),
                ("bb", db * db),
            ):
                sums[key][:, lo:hi] += weight * value
            sums["ww"][:, lo:hi] += weight**2
            sums["d"][:, lo:hi] += weight * d
            sums["ad"][:, lo:hi] += weight * da * d
            sums["bd"][:, lo:hi] += weight * db * d
            sums["dd"][:, lo:hi] += weight * d * d
    normal = np.stack(
        [
            np.stack([sums["w"], sums["a"], sums["b"]], -1),
            np.stack([sums["a"], sums["aa"], sums["ab"]], -1),
            np.stack([sums["b"], sums["ab"], sums["bb"]], -1),
        ],
        -2,
    )
    right = np.stack([sums["d"], sums["ad"], sums["bd"]], -1)
    solvable = np.abs(np.linalg.det(normal)) > 1e-9 * np.maximum(sums["w"], 1e-300) ** 3
    normal[~solvable] = np.eye(3)
    fitted = np.linalg.solve(normal, right[..., None])[..., 0]
    fitted[~(solvable & use)] = np.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        residual = np.maximum(sums["dd"] - (fitted * right).sum(-1), 0.0) / sums["w"]
        count = sums["w"] ** 2 / sums["ww"]
        scatter = np.sqrt(residual * count / (count - 3.0))
    scatter[~(np.isfinite(scatter) & (count > 3.0))] = np.nan
    return fitted[..., 1], fitted[..., 2], scatter


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


def helix_angle(velocity: SurfaceVelocity) -> float:
    """The wall's helix angle (degrees in [-90, 90], 0 along the tube, positive
    winding towards +u): the direction of the mean slowness vector (the gradient of the
    times, in its along and around parts) over the nodes that have one. Not the
    median of the nodes' angles: where a front comes first on one side it runs round
    both ways, the nodes' angles fall in two groups (say -55 to -80 and +50 to +80
    degrees), and their median jumps between them (18.7 degrees off on a zoo draw
    whose percentiles agreed within 1 degree); the mean vector's around parts cancel,
    and a helix's add up."""
    radians = np.radians(velocity.angle_deg)
    slowness = 1.0 / velocity.speed_mm_s
    along = np.nanmean(slowness * np.cos(radians))
    around = np.nanmean(slowness * np.sin(radians))
    return float(np.mod(np.degrees(np.arctan2(around, along)) + 90.0, 180.0) - 90.0)


def wave_summary(
    activation: Activation, velocity: SurfaceVelocity, s_mm: np.ndarray, period_ms: float
) -> dict:
    """The wave on one wall in numbers: ``propagates``; the median surface speed
    (mm/s); the axial speed (mm/s: the inverse of the median dt/ds, beside the paper's
    ridge speed); the helix angle (:func:`helix_angle`), the interquartile range of
    the nodes' angles about it and the median of their size, ``obliquity_deg`` (degrees, each
    velocity's angle to the axis folded into [-90, 90]: a front running back counts by
    its slant); the earliest node ``(i_u, i_v)`` and its position ``s_mm``; the slowest
    band (the row whose median speed is least, its ``s_mm``, and that speed). All over
    the :func:`strong` nodes (``velocity`` NaN elsewhere, as :func:`surface_velocity`
    gives it with ``use``). Every number None where the wall does not propagate."""
    if not propagates(activation, period_ms):
        return {
            "propagates": False,
            "speed_mm_s": None,
            "axial_speed_mm_s": None,
            "helix_angle_deg": None,
            "helix_angle_iqr_deg": None,
            "obliquity_deg": None,
            "earliest_node": None,
            "earliest_s_mm": None,
            "slowest_s_mm": None,
            "slowest_speed_mm_s": None,
        }
    angle = np.mod(velocity.angle_deg + 90.0, 180.0) - 90.0  # its slant
    helix = helix_angle(velocity)
    # the nodes' spread about the helix angle, on the half circle (a helix near 90
    # degrees has nodes at -89 and +89: 2 degrees apart, not 178)
    q1, q3 = np.nanpercentile(np.mod(angle - helix + 90.0, 180.0) - 90.0, [25, 75])
    slowness = np.nanmedian(velocity.axial_slowness_ms_mm)
    t = unwrapped(activation.time_ms, period_ms)
    earliest = np.unravel_index(np.nanargmin(np.where(strong(activation), t, np.nan)), t.shape)
    speed = velocity.speed_mm_s
    rows = np.full(speed.shape[1], np.nan)  # rows at least half of whose nodes read
    full = np.isfinite(speed).sum(axis=0) >= speed.shape[0] / 2
    rows[full] = np.nanmedian(speed[:, full], axis=0)
    inner = rows[2:-2] if rows.size > 4 and np.isfinite(rows[2:-2]).any() else rows
    slowest = int(np.nanargmin(inner)) + (2 if inner.size < rows.size else 0)
    return {
        "propagates": True,
        "speed_mm_s": float(np.nanmedian(velocity.speed_mm_s)),
        "axial_speed_mm_s": float(1e3 / slowness) if slowness > 0 else None,
        "helix_angle_deg": helix,
        "helix_angle_iqr_deg": float(q3 - q1),
        "obliquity_deg": float(np.nanmedian(np.abs(angle))),
        "earliest_node": [int(earliest[0]), int(earliest[1])],
        "earliest_s_mm": float(s_mm[earliest[1]]),
        "slowest_s_mm": float(s_mm[slowest]),
        "slowest_speed_mm_s": float(rows[slowest]),
    }
