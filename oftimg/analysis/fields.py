"""The (u, v, t) shape fields of one dataset (paper section 6.1-6.2): the section contours'
radial curvature, the wall's and the jelly's thickness, the grids' strain energy and
principal stretches, each smoothed in time by what its noise asks, with each node's 95 %
band and the phase maps; and the thickness's summaries. Pure functions on arrays (mm,
1/mm, ms): the per-frame meshing leaves frame-to-frame noise that these fields, second
derivatives of the surface, carry several times over."""

from __future__ import annotations

import warnings

import numpy as np

from ..memory import release_freed
from ..image.kymograph import RIDGE_SMOOTHING_LADDER_MS, RIDGE_SMOOTHING_MS
from ..image.normalize import (
    STRAIN_NOISE_TARGET,
    phase_maps,
    smooth_field,
    smooth_field_in_time,
    smoothing_kernel,
    time_flattening,
)
from ..mesh.curvature import contour_curvature, count_corners
from ..mesh.grid import signed_thickness
from ..mesh.strain import grid_strain
from .radial_curvature import node_band_95, scale_chosen_curvature
from .tracking import follow
from .uncertainty import NODE_BAND_FACTORS, wide_band_share

# a shape field whose per-pixel variance over the cycle is more than this share of
# frame-to-frame noise (noise SD over half the field's) is named in a warning
NOISY_FIELD_SHARE = 0.25

# corners are counted on the radial curvature averaged over this many frames either side
# of each row's minimum area (segmentation roughness averages out; the corners stay put)
CORNER_FRAMES = 2


def smoothed_curvature(
    raw: np.ndarray, period_ms: float, smoothing_ms: float | str
) -> tuple[np.ndarray, dict]:
    """A curvature field ``(n_u, n_v, n_t)`` smoothed in time by ``smoothing_ms``
    (ms or "auto"; float32; each frame is segmented and meshed on its own, and a
    second derivative of its surface carries that noise several times over), and
    how much of it is noise with the sigma used
    (:func:`~oftimg.image.normalize.smooth_field`)."""
    smoothed, noise = smooth_field(raw, period_ms, smoothing_ms)
    return smoothed.astype(np.float32), noise


def _smoothed_grid(G: np.ndarray, period_ms: float, smoothing_ms: float) -> np.ndarray:
    """Grid nodes ``(n_u, n_v, n_t, 3)`` smoothed in time by ``smoothing_ms`` (0: G)."""
    if smoothing_ms == 0:
        return G
    return np.moveaxis(smooth_field_in_time(np.moveaxis(G, -1, 0), period_ms, smoothing_ms), 0, -1)


def smoothed_strain(
    G: np.ndarray, period_ms: float, smoothing_ms: float | str, *, noise_seed: int | None = 0
) -> tuple[np.ndarray, np.ndarray, dict, np.ndarray]:
    """Strain energy ``(n_u, n_v, n_t)`` and principal stretches ``(n_u, n_v, n_t, 2)``
    of a grid ``G (n_u, n_v, n_t, 3)`` (mm) against t = 0, from its node positions
    smoothed in time by ``smoothing_ms``, how far the nodes' noise moves the energy, and
    each node's noise SD in the energy ``(n_u, n_v)`` (NaN where not measured).

    The energy is a square of stretches, themselves not linear in the nodes' positions, so
    the nodes' noise moves its mean (up where the tissue is stretched; where it is
    compressed, noise lengthens its edges and may take it either way): that lift,
    measured node by node as the mean change the noise makes when added once more (below;
    over the frames, then a node either side), is taken off (``bias_removed``: its median
    over the median energy; not held at 0 or above, which would bias it), and the energy
    held at 0 or above.

    ``smoothing_ms``: a Gaussian sigma in ms (0: none), or "auto": up
    ``RIDGE_SMOOTHING_LADDER_MS`` from its first sigma, stopping at the first after which
    the noise moves the energy by at most ``STRAIN_NOISE_TARGET`` of its median
    (``error_share`` below), or at the last before the error it leaves, noise and
    flattening together, grows again (the largest when neither; the first when the noise
    cannot be measured). The flattening: time smoothing of the nodes lowers the energy's
    peaks (a square of their excursions); measured as the median change of the energy
    from the ladder's first sigma, less the change the noise's lift makes
    (:func:`_flattening_share`), and grown as the sigma's square. Chosen on the noise
    alone, a 40-frame beat of a rough mesh took 20 ms and its inner wall's energy came
    out 24 % low (its 90th-percentile node 154 % off; 7 ms: 71 %; zoo seed 682231).

    Each frame is meshed on its own, and its grid nodes move along the wall by several
    um from frame to frame: on the phantoms with 2 um of roughness the inner wall's
    strain energy came out 23 % off unsmoothed and 3.9 % with 5 ms, 130 % and 11 % with
    5 um (against the model at the nodes' 5 ms mean positions, which shares their slow
    sliding along the wall: against the same phantom analysed without roughness, 5 ms
    left 5-10 % and 24-52 %, "auto" 5-7 % and 9-16 %, taking 5-10 and 20 ms); without
    noise 0.7 % both; 7, 10, 14, 20 ms cost 0.7-1, 2-3, 5-7, 10-15 % there.

    The noise (the third result): each node's departure from its position smoothed
    over ``RIDGE_SMOOTHING_MS`` (or a frame, if longer), scaled to the white noise
    that leaves it, its frames shuffled in time (white noise with each frame's pattern
    over the grid kept), smoothed by the sigma and added once more to the
    smoothed grid. Its ``error_share`` is the median absolute change of the energy with it over
    the median absolute energy (every ``STRAIN_NOISE_EVERY``-th frame): the share by which
    the noise alone moves the field, its lift included (the sigma is chosen on it: on the
    zoo's label draws a sigma chosen without the lift left the fields 10-50 % further off);
    ``stretch_noise_median`` the median absolute change of the principal stretches. On the phantoms
    and a jittered cylinder it came out 0.85-1.2x the change the roughness made where
    that was under 0.4, and low above (about 0.5x for changes of 0.6-1.5). ``node_noise_mm`` is the
    noise's median length over nodes and frames; ``smoothing_ms`` the sigma taken;
    ``flattening_share`` the flattening it is estimated to leave (a share of the median
    energy; NaN when no second sigma was tried).
    NaN for under 10 frames or without ``noise_seed``.
    """
    n_t = G.shape[2]
    ladder = RIDGE_SMOOTHING_LADDER_MS if smoothing_ms == "auto" else (float(smoothing_ms),)
    noise = {
        "error_share": float("nan"),
        "node_noise_mm": float("nan"),
        "stretch_noise_median": float("nan"),
        "bias_removed": float("nan"),
        "flattening_share": float("nan"),
    }
    if n_t < 10 or noise_seed is None:
        smoothed = _smoothed_grid(G, period_ms, ladder[0])
        return (
            *grid_strain(smoothed),
            {**noise, "smoothing_ms": ladder[0]},
            np.full(G.shape[:2], np.nan),
        )
    apart_ms = max(RIDGE_SMOOTHING_MS, period_ms / n_t)  # at least a frame
    kernel = smoothing_kernel(n_t, period_ms, apart_ms)
    whole, whole_ms = _smoothed_grid(G, period_ms, apart_ms), apart_ms
    residual = G - whole
    residual /= np.sqrt(1.0 - 2.0 * kernel[0] + (kernel**2).sum())  # white noise's share
    noise["node_noise_mm"] = float(np.median(np.linalg.norm(residual, axis=-1)))
    residual = residual[:, :, np.random.default_rng(noise_seed).permutation(n_t)]  # shuffled
    frames = np.arange(0, n_t, STRAIN_NOISE_EVERY)  # frame 0, the reference, first
    first: dict = {}  # the first sigma's energy and noise change at the frames
    kept: tuple[float, np.ndarray, dict] | None = None  # the sigma climbed to, its grid
    for sigma in ladder:
        if sigma != whole_ms:  # (the usual first sigma: smoothed above)
            whole, whole_ms = _smoothed_grid(G, period_ms, sigma), sigma
        # the first sigma's fields whole (most often the ones kept), the others' at the frames
        if sigma == ladder[0]:
            fields = grid_strain(whole)
        energy, stretch = (
            (fields[0][:, :, frames], fields[1][:, :, frames])
            if sigma == ladder[0]
            else grid_strain(whole[:, :, frames])
        )
        again = _smoothed_grid(residual, period_ms, sigma)[:, :, frames] + whole[:, :, frames]
        energy_again, stretch_again = grid_strain(again)
        del again  # a grid's copies: ~7 MB each
        change = energy_again[:, :, 1:] - energy[:, :, 1:]  # the reference: 0 in both
        step = {
            "error_share": float(
                np.nanmedian(np.abs(change)) / np.nanmedian(np.abs(energy[:, :, 1:]))
            ),
            "stretch_noise_median": float(np.nanmedian(np.abs(stretch_again - stretch))),
            "flattening_share": float("nan"),
            "change": change,
        }
        if kept is None:
            first = {"energy": energy[:, :, 1:], "change": change}
        else:
            flattening = _flattening_share(
                first["energy"], first["change"], energy[:, :, 1:], change
            ) / (1.0 - (ladder[0] / sigma) ** 2)  # the first sigma's own: as its square
            before_sigma, _, before = kept
            before_flattening = flattening * (before_sigma / sigma) ** 2
            step["flattening_share"] = flattening
            if np.hypot(step["error_share"], flattening) >= np.hypot(
                before["error_share"], before_flattening
            ):  # more smoothing flattens more than it quiets: the sigma before
                before["flattening_share"] = before_flattening
                break
        kept = (sigma, whole, step)
        if not step["error_share"] > STRAIN_NOISE_TARGET:
            break
    assert kept is not None  # the ladder has a sigma
    sigma, whole, step = kept
    change = step.pop("change")
    noise.update(step)
    del residual, first, kept
    energy, stretch = fields if sigma == ladder[0] else grid_strain(whole)
    lift, node_sd = _noise_lift(change)  # the lift taken off (the sigma chosen with it)
    noise["bias_removed"] = float(np.nanmedian(lift) / np.nanmedian(np.abs(energy[:, :, 1:])))
    energy[:, :, 1:] = np.maximum(energy[:, :, 1:] - lift[:, :, None], 0.0)
    return energy, stretch, {**noise, "smoothing_ms": sigma}, node_sd


def _flattening_share(
    energy_first: np.ndarray,
    change_first: np.ndarray,
    energy: np.ndarray,
    change: np.ndarray,
) -> float:
    """How much a larger sigma flattens a strain energy beyond the ladder's first, a share
    of its median size: the median change of the energy ``(n_u, n_v, n_frames)`` from the
    first sigma's ``energy_first``, less what the noise's lift alone moves between the
    two (the mean over the frames of each node's ``change`` from noise added once more,
    :func:`_noise_lift`'s), made positive. Both at the same frames, the reference left out."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN nodes
        lift = np.nanmean(change, axis=-1, keepdims=True) - np.nanmean(
            change_first, axis=-1, keepdims=True
        )
        share = np.nanmedian(energy - energy_first - lift) / np.nanmedian(np.abs(energy_first))
    return abs(float(share)) if np.isfinite(share) else 0.0


def _noise_lift(change: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mean ``(n_u, n_v)`` of the change noise added once more makes to a strain
    energy at some frames ``change (n_u, n_v, n_frames)`` (the reference left out: 0
    there), averaged with a node either side (u round the tube), and its SD over
    the frames ``(n_u, n_v)``; NaN where a node has none."""
    from scipy.ndimage import gaussian_filter

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN nodes
        mean, sd = np.nanmean(change, axis=-1), np.nanstd(change, axis=-1)
    known = np.isfinite(mean)
    total = gaussian_filter(np.where(known, mean, 0.0), 1.0, mode=("wrap", "nearest"))
    weight = gaussian_filter(known.astype(float), 1.0, mode=("wrap", "nearest"))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(known, total / weight, np.nan), sd


# strain noise: frames the energy is compared on (every this many, from the reference)
STRAIN_NOISE_EVERY = 3
# a strain energy field whose noise alone moves it by more than this share of its median
# size (median over nodes and frames) is named in a warning
NOISY_STRAIN_SHARE = 0.25


def shape_fields(
    grid,
    contour,
    normals,
    area,
    mean_curvature_lumen,
    period_ms,
    smoothing_ms: float | str = "auto",
    lumen_smoothed_ms: float = 0.0,
    strain_smoothing_ms: float | str = "auto",
    jelly_thickness: np.ndarray | None = None,
    coords: np.ndarray | None = None,
    radial_curvature: dict | None = None,
    vertex_spacing: dict | None = None,
    kind: str = "meshes",
) -> dict:
    """(u, v, t) shape fields (paper section 6.1-6.2), float32, aligned time.

    Radial curvature of the outer and inner section contours and the myocardial
    wall's thickness, outer to inner grid node, and the cardiac jelly's,
    ``jelly_thickness (n_u, n_v, n_t)`` mm or None (each smoothed in time by
    ``smoothing_ms``: :func:`smoothed_curvature`; how much of each is noise, and
    the sigma taken, in ``field_noise``), strain energy and principal stretches of
    the outer and inner grids against t = 0 (:func:`smoothed_strain` by
    ``strain_smoothing_ms``, ms or "auto"; how far their nodes' noise moves the energy,
    and the sigma taken, in ``strain_noise``), the phase maps of these and of the
    lumen's mean curvature (``(n_u, n_v, n_t)`` on the lumen grid, already
    smoothed by ``lumen_smoothed_ms``, or None),
    and the corner count of the outer contours at each row's own maximum
    contraction (curvature averaged over the ``2 CORNER_FRAMES + 1`` frames
    around it). Phase maps are taken on each field smoothed in time by
    ``RIDGE_SMOOTHING_MS`` in all (or by its own sigma if more). ``coords (n_u, n_v,
    n_t, 2)``: the tracked grid's pathlines (:func:`~oftimg.analysis.tracking.track_grid`),
    along which the section contours' curvature is read before it is smoothed in
    time (the grids given are already tracked), or None. ``radial_curvature``: wall ->
    each contour's curvature ``(n_u, n_v, n_t)`` 1/mm measured on the section's own
    polygon (:func:`~oftimg.mesh.sections.sections_of_mesh`); where missing, from the
    contour's points (:func:`contour_curvature`), with ``vertex_spacing``: wall -> each
    section polygon's mean vertex spacing ``(n_v, n_t)`` mm; with it, each node's 95 % band beside
    each radial curvature (``radial_curvature_<wall>_band95_per_mm``), widened as
    calibrated for input ``kind`` ("meshes", "labels" or "probabilities").
    """
    arrays, noise, strain_noise, unsmoothed = {}, {}, {}, {}
    radial_curvature = radial_curvature or {}
    for w in ("outer", "inner"):
        if w in contour:
            name = f"radial_curvature_{w}_per_mm"
            if w in radial_curvature:  # each node at the scale its noise allows
                scales = radial_curvature[w]
                if coords is not None:
                    scales = np.stack([follow(k, coords) for k in scales])
                arrays[name], noise[name], node_sd, unresolved = scale_chosen_curvature(
                    scales, period_ms, smoothing_ms, vertex_spacing[w], contour[w]
                )
                band = node_band_95(
                    node_sd, unresolved, NODE_BAND_FACTORS[kind][f"radial_curvature_{w}"]
                )
                arrays[f"radial_curvature_{w}_band95_per_mm"] = band
                noise[name]["band95_wide_share"] = wide_band_share(band, arrays[name])
            else:
                unsmoothed[w] = contour_curvature(contour[w], normals[None])
                on_tissue = unsmoothed[w] if coords is None else follow(unsmoothed[w], coords)
                arrays[name], noise[name] = smoothed_curvature(on_tissue, period_ms, smoothing_ms)
            energy, stretch, strain_noise[f"strain_energy_{w}"], strain_sd = smoothed_strain(
                grid[w], period_ms, strain_smoothing_ms
            )
            band = node_band_95(
                np.broadcast_to(strain_sd[:, :, None], energy.shape),
                time_flattening(
                    energy, period_ms, strain_noise[f"strain_energy_{w}"]["smoothing_ms"]
                ),
                NODE_BAND_FACTORS[kind][f"strain_energy_{w}"],
            )
            arrays[f"strain_energy_{w}_band95"] = band
            strain_noise[f"strain_energy_{w}"]["band95_wide_share"] = wide_band_share(band, energy)
            arrays[f"strain_energy_{w}"] = energy.astype(np.float32)
            arrays[f"principal_stretch_{w}"] = stretch.astype(np.float32)
            release_freed()  # the noise's grid copies, before the next wall's
    if "inner" in grid:
        # each outer node to its inner node, carried towards the row's centre (negative
        # where they cross)
        thickness = signed_thickness(grid["outer"], grid["inner"], grid["outer"].mean(axis=0))
        thickness, noise["wall_thickness_mm"] = smooth_field(thickness, period_ms, smoothing_ms)
        arrays["wall_thickness_mm"] = thickness.astype(np.float32)
    if jelly_thickness is not None:
        jelly, noise["jelly_thickness_mm"] = smooth_field(jelly_thickness, period_ms, smoothing_ms)
        arrays["jelly_thickness_mm"] = jelly.astype(np.float32)
    if mean_curvature_lumen is not None:
        arrays["mean_curvature_lumen_per_mm"] = mean_curvature_lumen
    smoothed_ms = {name: noise[name]["smoothing_ms"] for name in noise}
    smoothed_ms["mean_curvature_lumen_per_mm"] = lumen_smoothed_ms
    smoothed_ms.update({name: n["smoothing_ms"] for name, n in strain_noise.items()})
    phased = ("radial", "strain", "mean_curv", "wall", "jelly")
    for name in [n for n in arrays if n.startswith(phased) and "_band95" not in n]:
        # Gaussians compose: sigma_1^2 + sigma_2^2 = RIDGE_SMOOTHING_MS^2
        rest_ms = np.sqrt(max(0.0, RIDGE_SMOOTHING_MS**2 - smoothed_ms.get(name, 0.0) ** 2))
        t_max, t_min = phase_maps(arrays[name], period_ms, smoothing_ms=rest_ms)
        arrays[f"phase_max_{name}_ms"] = t_max.astype(np.float32)
        arrays[f"phase_min_{name}_ms"] = t_min.astype(np.float32)
    # the corners' own average over frames, of the field as read (scale chosen, smoothed:
    # a fine scale's raw frames lifted the corners' noise floor over 3 broad corners), or
    # of the contour's raw curvature without a scale to choose
    k = (
        arrays["radial_curvature_outer_per_mm"]
        if "outer" in radial_curvature
        else unsmoothed["outer"]
    )
    a = np.where(np.isfinite(area["outer"]), area["outer"], np.inf)
    rows_min = np.argmin(a, axis=1)  # a row without any contour gives 0 corners
    n_t = k.shape[2]
    near = (rows_min[:, None] + np.arange(-CORNER_FRAMES, CORNER_FRAMES + 1)) % n_t  # (n_v, 5)
    with warnings.catch_warnings():  # a row without contours: NaN, and 0 corners
        warnings.simplefilter("ignore", RuntimeWarning)
        averaged = [np.nanmean(k[:, j, near[j]], axis=1) for j in range(k.shape[1])]
    counts = np.array([count_corners(a) for a in averaged])
    arrays["corner_count_per_row"] = counts
    # the rows' most common count, 0 too (a round tube's: its noise maxima counted as 7
    # corners when only rows with corners voted); rows without a contour do not vote
    voting = np.array([np.isfinite(a).all() for a in averaged])
    inner_rows = counts[1:-1][voting[1:-1]]
    corners = None
    if len(inner_rows):
        values, freq = np.unique(inner_rows, return_counts=True)
        corners = int(values[np.argmax(freq)])
    out = {
        "arrays": arrays,
        "corner_count": corners,
        "field_noise": noise,
        "strain_noise": strain_noise,
    }
    for layer in ("wall", "jelly"):
        if f"{layer}_thickness_mm" in arrays:
            out.update(thickness_summary(arrays[f"{layer}_thickness_mm"], layer))
    return out


def mean_around_tube(field: np.ndarray) -> np.ndarray:
    """A field's mean around the tube, ``(n_v, n_t)``, of ``field (n_u, n_v, n_t)``
    (say the wall thickness, mm; NaN left out; NaN where a row has no value)."""
    with warnings.catch_warnings():  # rows without a value: NaN, left out
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmean(field, axis=0)


def thickness_by_row(thickness: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each row's mean thickness (mm) of a layer (the myocardial wall, the cardiac
    jelly) over the tube's circumference and the cycle, and its thickening over the
    beat: the largest over the smallest of its mean thickness around the tube,
    less 1 (``thickness (n_u, n_v, n_t)``; two ``(n_v,)`` arrays, NaN left out, NaN
    for a row without a value; thickening NaN for a row whose mean thickness around
    the tube reaches 0 or below, where the walls cross). Each pixel's own largest over smallest takes its
    noise's extremes for thickening: on the phantoms 11 % and 25 % high with 2 and
    5 um of roughness where the rows' means were within 2 %."""
    ring = mean_around_tube(thickness)  # (n_v, n_t)
    with warnings.catch_warnings():  # rows without a value: NaN, left out
        warnings.simplefilter("ignore", RuntimeWarning)
        thinnest = np.nanmin(ring, axis=-1)
        return (
            np.nanmean(ring, axis=-1),
            np.where(thinnest > 0, np.nanmax(ring, axis=-1) / thinnest - 1.0, np.nan),
        )


def thickness_summary(thickness: np.ndarray, layer: str = "wall") -> dict:
    """A layer's median thickness (mm) over the (u, v) pixels and the cycle, and its
    thickening over the beat, the median over the rows of :func:`thickness_by_row`'s
    (``{layer}_thickness_median_mm``, ``{layer}_thickening``; ``layer`` "wall" for
    the myocardium, "jelly" for the cardiac jelly)."""
    return {
        f"{layer}_thickness_median_mm": float(np.nanmedian(thickness)),
        f"{layer}_thickening": float(np.nanmedian(thickness_by_row(thickness)[1])),
    }
