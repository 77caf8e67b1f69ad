"""Synthetic beating outflow tracts with analytic ground truth.

The model (lengths in mm, times in ms):

* **Centreline**: a circular arc of radius ``bend_radius_mm`` (the "C"), arc
  length ``s`` in [0, ``length_mm``] inside the segmentation window; the two
  window planes are perpendicular to the arc at s = 0 (inlet, ventricular end)
  and s = L (outlet). A wall point is ``c(s) + rho (cos(theta) N + sin(theta) B)``
  with N pointing to the centre of the bend, so theta = 0 is the inside of the
  bend, where the shortest inlet-outlet geodesic runs.
* **Peristaltic wave**: it reaches position s at ``t*(s) = integral ds / c(s)``,
  with a local speed c(s) that rises from ``speed_proximal_mm_s`` to
  ``speed_distal_mm_s`` around ``speed_knee_mm``. The local phase is
  ``phi = ((t - t*(s)) / period) mod 1``; a section expands (raised cosine)
  during the first ``expand_fraction`` of its cycle and contracts during the rest
  (a share that can change linearly along the tube, to ``expand_fraction_outlet``
  at the outlet: the beat's peak, the ridge, then travels at its own speed,
  ``1 / (1 / c(s) + period * df/ds)``, given in the truth as ``ridge_speed_mm_s``).
* **Outer wall**: ``rho = R0(s) * m * (1 + a_k cos(k theta) + a_e cos(2 theta))``
  with the tapered radius R0 (``radius_inlet_mm`` to ``radius_outlet_mm``), the
  contraction factor ``m = 1 - contraction (1 - h(phi))`` and ``k`` =
  ``corners`` rounded corners, sharper (and a slight ellipse) when contracted;
  ``corner_sharpness`` kappa != 0 replaces cos(k theta) by a von Mises profile of the
  same mean (0) and peak (1), :func:`corner_profile`: kappa > 0 sharpens the corners
  with flatter sides between, kappa < 0 cuts sharp concave notches between bulging
  sides (the peak's curvature grows about as kappa / (1 - exp(-2 kappa)) times the
  cosine's).
* **Inner wall**: the outer contour scaled so that the myocardial area
  ``myocardial_fraction * pi R0(s)^2 / lambda(t)`` is kept over the beat
  (thicker when contracted).
* **Longitudinal motion**: the tissue stretches by ``lambda(t) = 1 + stretch *
  (1 - h(phi_inlet))`` with the outlet end fixed, so tissue slides through the
  inlet plane; a point at window position s has material position
  ``S = L - (L - s) / lambda(t)``, and the myocardial volume in the window
  changes by about ``stretch``. The tissue may also turn about the axis beneath
  the walls (``twist_deg``, largest at the inlet, the outlet or mid-tube, lagging
  the slide by ``twist_phase`` of a cycle): only a texture fixed in it shows that.
* **Lumen**: inside the inner wall (``lumen_fraction`` of its radius, the cardiac
  jelly between) with ``folds`` longitudinal folds that deepen on contraction.
* **Band** (group ``banded``): a Gaussian neck of depth ``band_depth`` and
  width ``band_width_mm`` at ``band_position_mm`` that also blocks
  ``band_motion_block`` of the contraction there.

Each frame of each wall is meshed independently (random resolution, random
start angle, jitter, shuffled vertex and face order, radial noise), so no two
frames share a parameterization. All truth is computed from the analytic model.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError

WALLS = ("outer", "inner", "lumen")
# the twist's share along the tube (x = s / L), by where it is largest
# values evaluated at once by the analytic truth's integrals (a chunk's arrays ~8 MB)
TRUTH_CHUNK = 1 << 20
TWIST_PROFILES = {
    "inlet": lambda x: 1.0 - x,
    "outlet": lambda x: x,
    "middle": lambda x: np.sin(np.pi * x),
}


@dataclass(frozen=True)
class PhantomParams:
    """Every number of the phantom model (mm, ms, mm/s)."""

    group: str = "normal"
    n_frames: int = 195
    period_ms: float = 360.0
    length_mm: float = 1.2
    bend_radius_mm: float = 0.6
    radius_inlet_mm: float = 0.2
    radius_outlet_mm: float = 0.12
    contraction: float = 0.3
    expand_fraction: float = 0.4
    expand_fraction_outlet: float | None = None  # None: expand_fraction all along
    speed_proximal_mm_s: float = 8.0
    speed_distal_mm_s: float = 20.0
    speed_knee_mm: float = 0.5
    speed_knee_width_mm: float = 0.06
    corners: int = 4
    corner_contracted: float = 0.08
    corner_expanded: float = 0.03
    corner_sharpness: float = 0.0  # kappa of corner_profile: > 0 corners, < 0 notches
    ellipse_contracted: float = 0.03
    myocardial_fraction: float = 0.3
    stretch: float = 0.17
    twist_deg: float = 0.0  # the tissue's largest turn about the axis, contracted
    twist_profile: str = "inlet"  # where the turn is largest: inlet, outlet or middle
    twist_phase: float = 0.0  # the turn's lag behind the slide, a share of the cycle
    helix_starts: int = 0  # the wave's front winds this many times round the tube
    side_lag_ms: float = 0.0  # the wave reaches the side opposite side_deg this late
    side_deg: float = 0.0  # where round the tube (theta) the wave comes first
    lumen_fraction: float = 0.75
    folds: int = 5
    fold_contracted: float = 0.3
    fold_expanded: float = 0.05
    # the endocardial cushions (issue 85): the lumen's section an ellipse (times the
    # folds) whose minor over major axis falls from cushion_aspect_expanded to
    # cushion_aspect_contracted as the wall contracts, fully between cushion_from_mm and
    # cushion_to_mm and tapering to none over cushion_taper_mm outside; at or below 0 the
    # cushions appose and the lumen is closed (area 0). Its major axis at theta cushion_deg.
    cushion_aspect_expanded: float = 1.0
    cushion_aspect_contracted: float = 1.0
    cushion_deg: float = 0.0
    cushion_from_mm: float = 0.0
    cushion_to_mm: float | None = None  # None: the window's end
    cushion_taper_mm: float = 0.1
    # > 0: the lumen's frames meshed as a lab meshes a segmentation (filled into voxels of
    # this side, marching cubes, cut at the window's planes): where the cushions close it,
    # in pieces that end blind (the analytic mesh would flatten to a sheet there)
    lumen_voxel_mm: float = 0.0
    band_position_mm: float | None = None
    band_depth: float = 0.35
    band_width_mm: float = 0.06
    band_motion_block: float = 0.9
    vertices_min: int = 4000
    vertices_max: int = 8000
    jitter: float = 0.3
    noise_mm: float = 0.0
    seed: int = 0

    def __post_init__(self):
        if self.group not in ("normal", "banded"):
            raise InputError(f"group must be 'normal' or 'banded', found {self.group!r}")
        if self.n_frames < 3:
            raise InputError(f"n_frames must be at least 3, found {self.n_frames}")
        if not 0 < self.expand_fraction < 1:
            raise InputError(f"expand_fraction must be in (0, 1), found {self.expand_fraction}")
        if self.expand_fraction_outlet is not None and not 0 < self.expand_fraction_outlet < 1:
            raise InputError(
                "expand_fraction_outlet must be in (0, 1) or None, found "
                f"{self.expand_fraction_outlet}"
            )
        if self.radius_inlet_mm * 1.3 >= self.bend_radius_mm:
            raise InputError("bend_radius_mm too small: the tube would intersect itself")
        if not 100 <= self.vertices_min <= self.vertices_max:
            raise InputError("need 100 <= vertices_min <= vertices_max")
        if not (np.isfinite(self.noise_mm) and self.noise_mm >= 0):
            raise InputError(f"noise_mm must be >= 0, found {self.noise_mm}")
        if not 0 < self.cushion_aspect_expanded <= 1 or self.cushion_aspect_contracted > 1:
            raise InputError(
                "cushion aspects must be <= 1 (expanded > 0), found "
                f"{self.cushion_aspect_expanded}, {self.cushion_aspect_contracted}"
            )
        if self.twist_profile not in TWIST_PROFILES:
            raise InputError(
                f"twist_profile must be one of {', '.join(TWIST_PROFILES)}, "
                f"found {self.twist_profile!r}"
            )


def sample_params(
    group: str = "normal", seed: int = 0, *, expand_change: float = 0.0, **overrides
) -> PhantomParams:
    """Realistic per-embryo parameters drawn with ``seed`` (paper's ranges).

    Period 330-380 ms, expansion 36-47 % of the cycle, proximal speed 5-10 and
    distal 14-24 mm/s, 3-5 corners; banded embryos get a band at 40-65 % of
    the length. ``expand_change``: how much the expansion share grows from inlet
    to outlet (0.2: by 20 percentage points). Keyword ``overrides`` replace any
    drawn value.
    """
    rng = np.random.default_rng([seed, 0 if group == "normal" else 1])
    length = rng.uniform(1.1, 1.35)
    p = dict(
        group=group,
        seed=seed,
        length_mm=length,
        period_ms=float(rng.uniform(330, 380)),
        expand_fraction=float(rng.uniform(0.36, 0.47)),
        radius_inlet_mm=float(rng.uniform(0.18, 0.22)),
        radius_outlet_mm=float(rng.uniform(0.11, 0.13)),
        speed_proximal_mm_s=float(rng.uniform(5, 10)),
        speed_distal_mm_s=float(rng.uniform(14, 24)),
        speed_knee_mm=float(rng.uniform(0.35, 0.5) * length),
        corners=int(rng.integers(3, 6)),
    )
    if group == "banded":
        p["band_position_mm"] = float(rng.uniform(0.4, 0.65) * length)
    if expand_change:
        p["expand_fraction_outlet"] = p["expand_fraction"] + expand_change
    p.update(overrides)
    return PhantomParams(**p)


# --------------------------------------------------------------------------- model
def corner_profile(phase, sharpness: float = 0.0):
    """The corners' shape round the section at ``phase`` = k theta (rad, broadcasting):
    cos(phase) for ``sharpness`` 0; else a von Mises bump exp(kappa (cos - 1)) moved and
    scaled to mean 0 and peak 1 (kappa the absolute sharpness), peaked at phase 0 (corners) for
    sharpness > 0 and turned into a notch at phase pi for sharpness < 0. Tends to
    cos(phase) as sharpness -> 0 from either side."""
    kappa = abs(float(sharpness))
    if kappa < 1e-3:
        return np.cos(phase)
    sign = 1.0 if sharpness > 0 else -1.0
    shifted = phase if sign > 0 else np.asarray(phase) + np.pi
    mean = np.exp(-kappa) * np.i0(kappa)  # the bump's mean over a period
    bump = np.exp(kappa * (np.cos(shifted) - 1.0))
    return sign * (bump - mean) / (1.0 - mean)


def profile_power(sharpness: float = 0.0) -> float:
    """The mean of :func:`corner_profile` squared over a period (1/2 for the cosine)."""
    kappa = abs(float(sharpness))
    if kappa < 1e-3:
        return 0.5
    mean = np.exp(-kappa) * np.i0(kappa)
    mean_sq = np.exp(-2 * kappa) * np.i0(2 * kappa)
    return float((mean_sq - mean**2) / (1.0 - mean) ** 2)


def _hump(phi, expand_fraction):
    """Expansion state h(phi) in [0, 1]: 0 contracted (phi = 0), 1 at phi = f_e."""
    phi = np.mod(phi, 1.0)
    f = expand_fraction
    rising = 0.5 * (1 - np.cos(np.pi * phi / f))
    falling = 0.5 * (1 + np.cos(np.pi * (phi - f) / (1 - f)))
    return np.where(phi < f, rising, falling)


def front_lag_ms(
    theta, period_ms: float, helix_starts: int = 0, side_lag_ms: float = 0.0, side_deg: float = 0.0
):
    """How much later than at angle 0 round its ring a wave's front reaches angle
    ``theta`` (rad, broadcasting; ms): a helical front winds ``helix_starts`` times round
    the tube (a whole period each time round, so that it joins itself; negative: the
    other hand), and a front that comes first at ``side_deg`` reaches the opposite side
    ``side_lag_ms`` later (half a cosine round the ring)."""
    theta = np.asarray(theta, float)
    return helix_starts * period_ms * np.mod(theta, 2 * np.pi) / (2 * np.pi) + side_lag_ms * 0.5 * (
        1 - np.cos(theta - np.radians(side_deg))
    )


class Phantom:
    """The analytic model for one parameter set; all methods are vectorised."""

    def __init__(self, params: PhantomParams):
        self.p = params
        p = params
        self.s_fine = np.linspace(0.0, p.length_mm, 2001)
        c = self.speed_mm_s(self.s_fine)
        inv = 1.0 / c
        t_star = np.concatenate(
            [[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(self.s_fine))]
        )
        self._t_star_ms = t_star * 1e3
        self.alpha0 = -p.length_mm / (2 * p.bend_radius_mm)

    # -- scalar profiles ----------------------------------------------------
    def speed_mm_s(self, s):
        """Local wave speed c(s), mm/s."""
        p = self.p
        z = (np.asarray(s) - p.speed_knee_mm) / p.speed_knee_width_mm
        return p.speed_proximal_mm_s + (p.speed_distal_mm_s - p.speed_proximal_mm_s) / (
            1 + np.exp(-z)
        )

    def arrival_ms(self, s):
        """Wave arrival time t*(s), ms (t* = 0 at the inlet); beyond the window's ends
        (where a volume cut obliquely holds some of the tube) at the end's speed."""
        s = np.asarray(s, dtype=float)
        t = np.interp(s, self.s_fine, self._t_star_ms)
        L = self.p.length_mm
        if np.all((s >= 0) & (s <= L)):
            return t
        return np.where(
            s < 0,
            1e3 * s / self.speed_mm_s(0.0),
            np.where(s > L, t + 1e3 * (s - L) / self.speed_mm_s(L), t),
        )

    def band(self, s):
        p = self.p
        if p.band_position_mm is None:
            return np.zeros_like(np.asarray(s, dtype=float))
        return np.exp(-0.5 * ((np.asarray(s) - p.band_position_mm) / p.band_width_mm) ** 2)

    def base_radius(self, s):
        """Expanded outer radius R0(s) before shape factors, mm."""
        p = self.p
        s = np.asarray(s, dtype=float)
        taper = p.radius_inlet_mm + (p.radius_outlet_mm - p.radius_inlet_mm) * s / p.length_mm
        return taper * (1 - p.band_depth * self.band(s))

    def expand_fraction(self, s):
        """Share of the cycle a section spends expanding at position s (mm)."""
        p = self.p
        f_out = p.expand_fraction if p.expand_fraction_outlet is None else p.expand_fraction_outlet
        return p.expand_fraction + (f_out - p.expand_fraction) * np.asarray(s, float) / p.length_mm

    def ridge_speed_mm_s(self, s):
        """Speed (mm/s) of the area's maximum along the tube: c(s) where the
        expansion share is the same all along."""
        return self.ridge_speed_from(self.speed_mm_s(s))

    def ridge_speed_from(self, onset_mm_s):
        """The ridge's speed (mm/s) where the wave's onset runs at ``onset_mm_s``:
        ``1 / (1 / c + period * df/ds)``, the onset speed itself (unchanged) where
        the expansion share is the same all along."""
        p = self.p
        if p.expand_fraction_outlet is None or p.expand_fraction_outlet == p.expand_fraction:
            return onset_mm_s
        df_ds = (p.expand_fraction_outlet - p.expand_fraction) / p.length_mm
        return 1.0 / (1.0 / np.asarray(onset_mm_s) + 1e-3 * p.period_ms * df_ds)

    def front_lag_ms(self, theta):
        """How much later than at its ring's first point the wave arrives at angle
        ``theta`` (ms): a helical front winds ``helix_starts`` times round the tube
        (a whole cycle each time round, so it joins itself), and a front that comes
        first at ``side_deg`` reaches the opposite side ``side_lag_ms`` later."""
        p = self.p
        return front_lag_ms(theta, p.period_ms, p.helix_starts, p.side_lag_ms, p.side_deg)

    def onset_ms(self, s, theta):
        """When the wall at (s, theta) starts to expand (ms, in [0, period)): the wave's
        arrival there and its front's lag round the ring."""
        return np.mod(self.arrival_ms(s) + self.front_lag_ms(theta), self.p.period_ms)

    def activation_ms(self, s, theta, samples: int = 256):
        """The activation time at (s, theta) as oftimg defines it (ms, in [0, period)):
        the steepest rise of the first harmonic of the wall's expansion there over the
        cycle (its radius is linear in it), from ``samples`` instants. It follows the
        onset (:meth:`onset_ms`) by one constant where the expansion share is the same
        all along; where that share changes along the tube, by an amount that changes
        with it (as the area's ridge does: a share from 0.38 to 0.28 over the tube moved
        the times by as much as the wave took to cross it)."""
        s, theta = np.broadcast_arrays(np.asarray(s, float), np.asarray(theta, float))
        t = np.arange(samples) * self.p.period_ms / samples
        return self.activation_along(s[..., None], theta[..., None], t)

    def activation_along(self, s, theta, t_ms):
        """The activation time (ms, in [0, period)) of points that move: at window
        positions ``s`` and angles ``theta`` ``(..., n_t)`` at the instants ``t_ms``
        ``(n_t,)``, equally spaced over one cycle (a node's path, which twists with its
        tissue): the steepest rise of the first harmonic of the expansion met along
        the way. Where the front runs round the tube (a helix), a node turned by the
        twist meets it earlier or later; at its mean place it would be off by the turn
        times the times' gradient round the tube."""
        t_ms = np.asarray(t_ms, float)
        h = self.expansion(s, t_ms, theta)
        phase = 2 * np.pi * (t_ms - t_ms[0]) / self.p.period_ms
        first = (h * np.exp(-1j * phase)).sum(axis=-1)
        # h ~ cos(w (t - t0) + phi), phi = angle(first): rising fastest at w (t - t0) + phi = -pi/2
        return np.mod(
            t_ms[0] + (-np.pi / 2 - np.angle(first)) * self.p.period_ms / (2 * np.pi),
            self.p.period_ms,
        )

    def expansion(self, s, t_ms, theta=0.0):
        """Expansion state h(s, theta, t) in [0, 1] (broadcasting; theta matters for a
        helical or one-sided wave only)."""
        arrival = self.arrival_ms(s) + self.front_lag_ms(theta)
        return _hump((np.asarray(t_ms) - arrival) / self.p.period_ms, self.expand_fraction(s))

    def stretch(self, t_ms):
        """Longitudinal stretch lambda(t) >= 1 (tissue slides through the inlet)."""
        h0 = self.expansion(0.0, t_ms)
        return 1.0 + self.p.stretch * (1.0 - h0)

    # -- wall radii -----------------------------------------------------------
    def radius(self, wall: str, s, theta, t_ms):
        """Radial distance rho of ``wall`` from the centreline, mm (broadcasting)."""
        p = self.p
        s = np.asarray(s, dtype=float)
        h = self.expansion(s, t_ms, theta)
        m = 1.0 - p.contraction * (1.0 - self.band(s) * p.band_motion_block) * (1.0 - h)
        a_k = p.corner_contracted + (p.corner_expanded - p.corner_contracted) * h
        a_e = p.ellipse_contracted * (1.0 - h)
        shape = (
            1.0
            + a_k * corner_profile(p.corners * theta, p.corner_sharpness)
            + a_e * np.cos(2 * theta)
        )
        rho = self.base_radius(s) * m * shape
        if wall == "outer":
            return rho
        q = self._inner_scale(s, t_ms, h, m, a_k, a_e)
        if wall == "inner":
            return rho * q
        if wall == "lumen":
            depth = p.fold_contracted + (p.fold_expanded - p.fold_contracted) * h
            fold = 1.0 - depth * (0.5 + 0.5 * np.cos(p.folds * theta + np.pi)) ** 2
            return rho * q * p.lumen_fraction * fold * self._cushion_scale(s, theta, h)
        raise InputError(f"wall must be one of {WALLS}, found {wall!r}")

    def cushion_aspect(self, s, t_ms):
        """The cushions' ellipse's minor over major axis at (s, t) (broadcasting), 0 where
        they appose and the lumen is closed (the model's aspect before the folds)."""
        return self._cushion_aspect(np.asarray(s, float), self.expansion(s, t_ms))

    def _cushion_aspect(self, s, h):
        p = self.p
        if p.cushion_aspect_expanded == 1.0 and p.cushion_aspect_contracted == 1.0:
            return np.ones_like(s * h)
        to = p.length_mm if p.cushion_to_mm is None else p.cushion_to_mm
        outside = np.maximum(np.maximum(p.cushion_from_mm - s, s - to), 0.0)
        width = np.maximum(p.cushion_taper_mm, 1e-9)
        along = np.where(outside < width, 0.5 + 0.5 * np.cos(np.pi * outside / width), 0.0)
        drop = (p.cushion_aspect_expanded - p.cushion_aspect_contracted) * (1.0 - h) * along
        return np.clip(p.cushion_aspect_expanded - drop, 0.0, 1.0)

    def _cushion_scale(self, s, theta, h):
        """The lumen's radius scale from the cushions: an ellipse of semi-axes 1 and the
        aspect, its major axis at ``cushion_deg`` (0 everywhere once closed)."""
        p = self.p
        if p.cushion_aspect_expanded == 1.0 and p.cushion_aspect_contracted == 1.0:
            return 1.0  # no cushions: a round lumen
        a = self._cushion_aspect(s, h)
        d = np.asarray(theta) - np.radians(self.p.cushion_deg)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = a / np.sqrt((a * np.cos(d)) ** 2 + np.sin(d) ** 2)
        return np.where(a > 0, np.nan_to_num(r, nan=1.0), 0.0)

    def section_ellipse(self, wall, s, t_ms, n_theta: int = 720):
        """Aspect ratio (minor over major) and major-axis direction (theta, degrees in
        [0, 180)) of ``wall``'s sections at (s, t) (broadcasting) from the area's second
        moments (oftimg measures the same), NaN where the section has no area."""
        th = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
        s_, t_ = np.broadcast_arrays(np.asarray(s, float), np.asarray(t_ms, float))
        rho = self.radius(wall, s_[..., None], th, t_[..., None])
        m = lambda k, f: ((rho**k) * f).mean(axis=-1) * 2 * np.pi  # noqa: E731
        area = m(2, 1.0) / 2
        with np.errstate(invalid="ignore", divide="ignore"):
            mx, my = m(3, np.cos(th)) / 3 / area, m(3, np.sin(th)) / 3 / area
            ixx = m(4, np.cos(th) ** 2) / 4 / area - mx**2
            iyy = m(4, np.sin(th) ** 2) / 4 / area - my**2
            ixy = m(4, np.cos(th) * np.sin(th)) / 4 / area - mx * my
            half_diff, mid = np.hypot((ixx - iyy) / 2, ixy), (ixx + iyy) / 2
            aspect = np.sqrt(np.clip((mid - half_diff) / (mid + half_diff), 0, 1))
            major = np.degrees(0.5 * np.arctan2(2 * ixy, ixx - iyy)) % 180.0
        closed = ~(area > 1e-12)
        return np.where(closed, np.nan, aspect), np.where(closed, np.nan, major)

    def _inner_scale(self, s, t_ms, h, m, a_k, a_e):
        """Scale of the inner contour relative to the outer one (keeps myocardial area)."""
        p = self.p
        R0 = self.base_radius(s)
        # (1/2pi) int shape^2 (corners >= 3: the profile and cos 2 theta are orthogonal)
        shape_area = 1.0 + profile_power(p.corner_sharpness) * a_k**2 + 0.5 * a_e**2
        area_out = np.pi * (R0 * m) ** 2 * shape_area
        area_myo = p.myocardial_fraction * np.pi * R0**2 / self.stretch(t_ms)
        return np.sqrt(np.clip(1.0 - area_myo / area_out, 0.01, None))

    def wall_thickness(self, s, theta, t_ms):
        """Radial outer-minus-inner distance at (s, theta, t), mm."""
        return self.radius("outer", s, theta, t_ms) - self.radius("inner", s, theta, t_ms)

    def jelly_thickness(self, s, theta, t_ms):
        """Radial inner-minus-lumen distance (the cardiac jelly) at (s, theta, t), mm."""
        return self.radius("inner", s, theta, t_ms) - self.radius("lumen", s, theta, t_ms)

    # -- geometry -----------------------------------------------------------
    def frame_axes(self, s):
        """Centreline point c, inside normal N and binormal B at s, each ``(..., 3)``."""
        R = self.p.bend_radius_mm
        a = self.alpha0 + np.asarray(s, dtype=float) / R
        radial = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=-1)
        B = np.broadcast_to(np.array([0.0, 0.0, 1.0]), radial.shape)
        return R * radial, -radial, B

    def point(self, wall, s, theta, t_ms):
        """3-D points (mm) of ``wall`` at window position s and angle theta."""
        c, N, B = self.frame_axes(s)
        rho = self.radius(wall, s, theta, t_ms)[..., None]
        th = np.asarray(theta)[..., None]
        return c + rho * (np.cos(th) * N + np.sin(th) * B)

    def window_coordinates(self, X):
        """(s, theta) of 3-D points ``X (..., 3)``: window arc length (mm), angle (rad).

        theta in (-pi, pi], 0 on the inside of the bend.
        """
        X = np.asarray(X, dtype=float)
        a = np.arctan2(X[..., 1], X[..., 0])
        s = self.p.bend_radius_mm * (a - self.alpha0)
        c, N, B = self.frame_axes(s)
        d = X - c
        theta = np.arctan2(np.einsum("...i,...i", d, B), np.einsum("...i,...i", d, N))
        return s, theta

    def twist(self, s, t_ms):
        """The tissue's turn about the axis (rad) at window position s, time t:
        ``twist_deg`` when fully contracted where :data:`TWIST_PROFILES` puts the most
        (the inlet by default, none at the outlet), following the inlet's beat
        ``twist_phase`` of a cycle later than the slide does. The walls' shapes do not
        show it: only a texture fixed in the tissue does."""
        p = self.p
        h0 = self.expansion(0.0, np.asarray(t_ms, float) - p.twist_phase * p.period_ms)
        along = TWIST_PROFILES[p.twist_profile](np.asarray(s, float) / p.length_mm)
        return np.radians(p.twist_deg) * (1.0 - h0) * along

    def material_from_window(self, s, theta, t_ms):
        """(S, theta) material coordinates at window position s (mm), angle theta
        (rad), time t (ms): S follows the tissue as it slides through the inlet plane
        (``S = L - (L - s) / lambda(t)``), and the tissue's angle is the window angle
        less its :meth:`twist` (none by default: material points then move radially)."""
        L = self.p.length_mm
        return L - (L - np.asarray(s, float)) / self.stretch(t_ms), theta - self.twist(s, t_ms)

    def material_coordinates(self, X, t_ms):
        """(S, theta) material coordinates of points ``X (..., 3)`` at time t (ms)
        (:meth:`material_from_window`)."""
        s, theta = self.window_coordinates(X)
        return self.material_from_window(s, theta, t_ms)

    # -- analytic areas and volumes -----------------------------------------
    def section_moments(self, wall, s, t_ms, n_theta: int = 128):
        """Area (mm^2) and first moment toward the bend centre (mm^3) of sections.

        ``s`` and ``t_ms`` broadcast; the trapezoid rule on a periodic integrand
        is spectrally accurate.
        """
        th = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
        s_, t_ = np.broadcast_arrays(np.asarray(s, float), np.asarray(t_ms, float))
        shape = s_.shape
        s_, t_ = s_.reshape(-1), t_.reshape(-1)
        area, moment = np.empty(len(s_)), np.empty(len(s_))
        # in pieces of ~1M values: arrays of 100s of MB cost more in page faults than sums
        step = max(1, TRUTH_CHUNK // n_theta)
        for a in range(0, len(s_), step):
            rho = self.radius(wall, s_[a : a + step, None], th, t_[a : a + step, None])
            area[a : a + step] = 0.5 * (rho**2).mean(axis=-1) * 2 * np.pi
            moment[a : a + step] = ((rho**3 / 3.0) * np.cos(th)).mean(axis=-1) * 2 * np.pi
        return area.reshape(shape), moment.reshape(shape)

    def area_mm2(self, wall, s, t_ms):
        return self.section_moments(wall, s, t_ms)[0]

    def volume_mm3(self, wall, t_ms, n_s: int = 241, s_range=None):
        """Volume inside ``wall`` in the window (or between ``s_range`` ``(s_a, s_b)``
        mm) at times ``t_ms (n,)``.

        Exact for the curved tube: the tube-coordinate Jacobian (1 - rho cos(theta) / R_bend)
        is integrated, not only the areas.
        """
        s = np.linspace(*(s_range or (0, self.p.length_mm)), n_s)
        t = np.atleast_1d(np.asarray(t_ms, float))
        area, moment = self.section_moments(wall, s[:, None], t[None, :])
        integrand = area - moment / self.p.bend_radius_mm
        # the trapezoid rule along s (np.trapezoid is NumPy >= 2 only)
        return 0.5 * (np.diff(s)[:, None] * (integrand[1:] + integrand[:-1])).sum(axis=0)

    # -- analytic curvatures (the truth for the shape fields) ---------------
    def section_curvature(self, wall, s, theta, t_ms, h: float = 1e-3):
        """Curvature (1/mm, positive where convex) of ``wall``'s cross-section, the
        polar curve rho(theta), at (s, theta, t) (broadcasting); derivatives by
        central differences of step ``h`` rad."""
        r0, r1, r2 = (self.radius(wall, s, np.asarray(theta) + d, t_ms) for d in (0.0, h, -h))
        d1, d2 = (r1 - r2) / (2 * h), (r1 - 2 * r0 + r2) / h**2
        return (r0**2 + 2 * d1**2 - r0 * d2) / (r0**2 + d1**2) ** 1.5

    def mean_curvature(self, wall, s, theta, t_ms, hs: float = 2e-3, ht: float = 1e-3):
        """Mean curvature (1/mm, positive for a cylinder) of ``wall`` at (s, theta, t)
        (broadcasting), from central differences of its fundamental forms; ``hs``
        (mm) spans several of the steps at which the wave's arrival is tabulated."""
        s, theta = np.asarray(s, float), np.asarray(theta, float)

        points = {
            (i, j): self.point(wall, s + i * hs, theta + j * ht, t_ms)
            for i in (-1, 0, 1)
            for j in (-1, 0, 1)
        }  # each point once
        at = lambda i, j: points[i, j]  # noqa: E731
        X = at(0, 0)
        Xs, Xt = (at(1, 0) - at(-1, 0)) / (2 * hs), (at(0, 1) - at(0, -1)) / (2 * ht)
        Xss = (at(1, 0) - 2 * X + at(-1, 0)) / hs**2
        Xtt = (at(0, 1) - 2 * X + at(0, -1)) / ht**2
        Xst = (at(1, 1) - at(1, -1) - at(-1, 1) + at(-1, -1)) / (4 * hs * ht)
        n = np.cross(Xs, Xt)
        n *= np.sign(np.einsum("...k,...k", n, X - self.frame_axes(s)[0]))[..., None]  # outward
        with np.errstate(invalid="ignore"):  # a closed lumen has no normal: NaN there
            n /= np.linalg.norm(n, axis=-1, keepdims=True)
        E, F, G = (np.einsum("...k,...k", a, b) for a, b in ((Xs, Xs), (Xs, Xt), (Xt, Xt)))
        L, M, N = (np.einsum("...k,...k", a, n) for a in (Xss, Xst, Xtt))
        return -(E * N - 2 * F * M + G * L) / (2 * (E * G - F * F))

    # -- meshing ------------------------------------------------------------
    def mesh(self, wall: str, t_ms: float, rng: np.random.Generator):
        """An independent triangle mesh of ``wall`` at time ``t_ms``.

        Returns ``V (n_vert, 3) float64`` mm, ``F (n_face, 3) int64`` with
        outward normals, vertices and faces in random order.
        """
        p = self.p
        n_target = int(rng.integers(p.vertices_min, p.vertices_max + 1))
        mean_circ = np.pi * (p.radius_inlet_mm + p.radius_outlet_mm)
        # the folded lumen gets twice the density around (its folds need it)
        aspect = mean_circ / p.length_mm * (2.0 if wall == "lumen" else 1.0)
        n_th = max(12, int(round(np.sqrt(n_target * aspect))))
        n_s = max(4, n_target // n_th)
        ds = p.length_mm / (n_s - 1)
        dth = 2 * np.pi / n_th
        s = np.linspace(0, p.length_mm, n_s)[:, None] * np.ones((1, n_th))
        th = rng.uniform(0, 2 * np.pi) + dth * np.arange(n_th)[None, :] * np.ones((n_s, 1))
        jit_s = rng.uniform(-p.jitter, p.jitter, s.shape) * ds
        jit_s[[0, -1]] = 0.0
        s = s + jit_s
        th = th + rng.uniform(-p.jitter, p.jitter, th.shape) * dth
        V = self.point(wall, s, th, t_ms)
        if p.noise_mm > 0:
            c, _, _ = self.frame_axes(s)
            radial = V - c
            radial /= np.linalg.norm(radial, axis=-1, keepdims=True)
            noise = rng.normal(0, p.noise_mm, s.shape)
            noise[[0, -1]] = 0.0  # keep the window planes exact
            V = V + noise[..., None] * radial
        V = V.reshape(-1, 3)
        idx = np.arange(n_s * n_th).reshape(n_s, n_th)
        a = idx[:-1, :]
        b = np.roll(idx, -1, axis=1)[:-1, :]
        c_ = np.roll(idx, -1, axis=1)[1:, :]
        d = idx[1:, :]
        diag = rng.random(a.shape) < 0.5
        t1 = np.where(diag[..., None], np.stack([a, b, c_], -1), np.stack([a, b, d], -1))
        t2 = np.where(diag[..., None], np.stack([a, c_, d], -1), np.stack([b, c_, d], -1))
        F = np.concatenate([t1.reshape(-1, 3), t2.reshape(-1, 3)])
        # (a, b, c): theta increases a->b, s increases b->c; with N pointing inwards
        # d/dtheta x d/ds points outwards, so (a, b, c) is outward-oriented.
        perm = rng.permutation(len(V))
        inv = np.empty_like(perm)
        inv[perm] = np.arange(len(V))
        V = V[perm]
        F = inv[F][rng.permutation(len(F))]
        F = np.roll(F, int(rng.integers(3)), axis=1)
        return V, F.astype(np.int64)

    def voxel_mesh(self, wall: str, t_ms: float, side_mm: float) -> tuple[np.ndarray, np.ndarray]:
        """``wall`` at ``t_ms`` as a segmentation's mesh: the model filled into voxels of
        ``side_mm`` (each voxel centre inside the wall's radius), blurred by a voxel's
        sigma, marching cubes at its level 0.5, cut at the window's planes s = 0 and
        s = L (the model continued past them as its end sections). ``V`` mm, ``F``
        outward; in pieces where the cushions close the lumen."""
        from scipy import ndimage
        from skimage.measure import marching_cubes

        from ..mesh.ends import cut_by_plane

        p = self.p
        s = np.linspace(-0.1, 1.1, 121) * p.length_mm
        theta = np.linspace(0, 2 * np.pi, 72, endpoint=False)
        c, N, B = self.frame_axes(s[:, None])
        rho = 1.5 * self.base_radius(np.clip(s, 0, p.length_mm))[:, None, None]
        X = (c + rho * (np.cos(theta)[:, None] * N + np.sin(theta)[:, None] * B)).reshape(-1, 3)
        low = X.min(axis=0) - 3 * side_mm
        shape = np.ceil((X.max(axis=0) + 3 * side_mm - low) / side_mm).astype(int) + 1
        axes = [low[k] + side_mm * np.arange(shape[k]) for k in range(3)]
        inside = np.zeros(shape, np.float32)  # (x, y, z)
        for i, x in enumerate(axes[0]):  # a plane at a time
            P = np.stack(np.broadcast_arrays(x, axes[1][:, None], axes[2][None, :]), -1)
            s_p, th_p = self.window_coordinates(P)
            s_p = np.clip(s_p, 0.0, p.length_mm)
            c_p, _, _ = self.frame_axes(s_p)
            inside[i] = np.linalg.norm(P - c_p, axis=-1) <= self.radius(wall, s_p, th_p, t_ms)
        field = ndimage.gaussian_filter(inside, 1.0)
        V, F, _, _ = marching_cubes(field, 0.5, spacing=(side_mm,) * 3)
        V = V + low
        F = F[:, ::-1].astype(np.int64)  # outward
        for s_end, sign in ((0.0, 1.0), (p.length_mm, -1.0)):
            c_e, N_e, B_e = self.frame_axes(s_end)
            V, F = cut_by_plane(V, F, c_e, sign * np.cross(N_e, B_e))  # into the tube
        return V, F

    # -- truth --------------------------------------------------------------
    def frame_times_ms(self):
        return np.arange(self.p.n_frames) * self.p.period_ms / self.p.n_frames

    def truth(self, n_s: int = 121, n_t_fine: int = 720, s_range=None) -> dict:
        """Ground truth from the analytic model (JSON-ready): of the window, or of the
        part between ``s_range`` ``(s_a, s_b)`` mm (a tube whose ends were cut square
        inside it), its positions still the window's."""
        p = self.p
        s_range = s_range or (0.0, p.length_mm)
        s = np.linspace(*s_range, n_s)
        t = self.frame_times_ms()
        t_fine = np.linspace(0, p.period_ms, n_t_fine, endpoint=False)
        areas = {w: self.area_mm2(w, s[:, None], t[None, :]) for w in WALLS}
        vol = {w: self.volume_mm3(w, t, s_range=s_range) for w in WALLS}
        vol_fine = self.volume_mm3("outer", t_fine, s_range=s_range)
        t_min = t_fine[np.argmin(vol_fine)]
        t_max = t_fine[np.argmax(vol_fine)]
        expand = ((t_max - t_min) % p.period_ms) / p.period_ms
        myo = vol["outer"] - vol["inner"]
        myo_fine = vol_fine - self.volume_mm3("inner", t_fine, s_range=s_range)
        area_fine = self.area_mm2("outer", s[:, None], t_fine[None, :])
        frac75 = (area_fine >= 0.75 * area_fine.max(axis=1, keepdims=True)).mean(axis=1)
        max_area = {
            w: (area_fine if w == "outer" else self.area_mm2(w, s[:, None], t_fine[None, :])).max(
                axis=1
            )
            for w in WALLS
        }
        arrival = self.arrival_ms(s)
        ridge = arrival + self.expand_fraction(s) * p.period_ms
        c = self.ridge_speed_mm_s(s)
        return {
            "params": asdict(p),
            "s_mm": s.tolist(),
            "t_ms": t.tolist(),
            "speed_mm_s": self.speed_mm_s(s).tolist(),
            "ridge_speed_mm_s": c.tolist(),
            "arrival_ms": arrival.tolist(),
            "ridge_t_ms": ridge.tolist(),
            "wave_speed_mm_s": {  # of the ridge, as oftimg measures them
                "min": float(c.min()),
                "max": float(c.max()),
                "mean": float(c.mean()),
                "cycle": float((s[-1] - s[0]) / (ridge[-1] - ridge[0]) * 1e3),
            },
            "area_mm2": {w: areas[w].tolist() for w in WALLS},
            "max_area_mm2": {w: max_area[w].tolist() for w in WALLS},
            "volume_mm3": {w: vol[w].tolist() for w in WALLS},
            "myocardial_volume_mm3": myo.tolist(),
            "myocardial_volume_change": float((myo_fine.max() - myo_fine.min()) / myo_fine.min()),
            "t_min_volume_ms": float(t_min),
            "t_max_volume_ms": float(t_max),
            "expand_fraction": float(expand),
            "contract_fraction": float(1 - expand),
            "expand_ms": float(expand * p.period_ms),
            "contract_ms": float((1 - expand) * p.period_ms),
            "expanded_fraction_75": frac75.tolist(),
            "tube_length_mm": float(s[-1] - s[0]),
            "band_position_mm": p.band_position_mm,
            "corner_count": p.corners,
        }


# --------------------------------------------------------------------------- writing
def write_phantom(
    out: str | Path, params: PhantomParams, *, name: str | None = None, walls=WALLS, progress=None
) -> Path:
    """Write a phantom dataset folder (meta.json, outer/ inner/ lumen/, truth.json).

    ``out`` must not exist or be empty; ``name`` defaults to its folder name.
    ``progress`` is called with the number of frames done. Returns the folder.
    """
    from ..io.meshfile import write_ply

    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise FileExistsError(f"{out}: exists and is not empty")
    ph = Phantom(params)
    rng = np.random.default_rng([params.seed, 7])
    for w in walls:
        (out / w).mkdir(parents=True, exist_ok=True)
    width = len(str(params.n_frames - 1))
    for k, t in enumerate(ph.frame_times_ms()):
        for w in walls:
            V, F = (
                ph.voxel_mesh(w, t, params.lumen_voxel_mm)
                if w == "lumen" and params.lumen_voxel_mm > 0
                else ph.mesh(w, t, rng)
            )
            write_ply(out / w / f"f{k:0{width}d}.ply", V, F)
        if progress is not None:
            progress(k + 1)
    c, _, _ = ph.frame_axes(0.0)
    meta = {
        "name": name or out.name,
        "group": params.group,
        "period_ms": params.period_ms,
        "length_unit": "mm",
        "inlet": [float(x) for x in c],
    }
    (out / "meta.json").write_text(json.dumps(meta, indent=2))
    (out / "truth.json").write_text(json.dumps(ph.truth(), indent=1))
    return out


def read_truth(dataset: str | Path) -> tuple[Phantom, dict]:
    """The model and the truth.json of a phantom dataset folder."""
    truth = json.loads((Path(dataset) / "truth.json").read_text())
    return Phantom(PhantomParams(**truth["params"])), truth
