"""Analytic test shapes (meshes of cylinders, cones and elliptic tubes) and a
worker pool that runs each task at once."""
from __future__ import annotations

import concurrent.futures

import numpy as np

from oftimg.io.meshfile import write_ply


def tube_mesh(radius_in=0.2, radius_out=None, length=1.0, n_theta=48, n_s=30,
              ellipse=1.0, theta0=0.0):
    """Straight tube along +z from z=0 (inlet) to z=length, outward-oriented.

    Radius tapers linearly from ``radius_in`` to ``radius_out`` (a cone); the
    y semi-axis is scaled by ``ellipse``. Returns ``V (n, 3)``, ``F (m, 3)``.
    """
    radius_out = radius_in if radius_out is None else radius_out
    z = np.linspace(0, length, n_s)
    th = theta0 + np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    r = radius_in + (radius_out - radius_in) * z / length
    Z, T = np.meshgrid(z, th, indexing="ij")
    R = r[:, None] * np.ones_like(T)
    V = np.stack([R * np.cos(T), ellipse * R * np.sin(T), Z], axis=-1).reshape(-1, 3)
    idx = np.arange(n_s * n_theta).reshape(n_s, n_theta)
    a = idx[:-1]
    b = np.roll(idx, -1, axis=1)[:-1]
    c = np.roll(idx, -1, axis=1)[1:]
    d = idx[1:]
    F = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                        np.stack([a, c, d], -1).reshape(-1, 3)])
    return V, F.astype(np.int64)


def write_series(folder, meshes, surface="outer"):
    """Write meshes as frames f0.ply, f1.ply, ... of ``folder/surface``."""
    sub = folder / surface
    sub.mkdir(parents=True, exist_ok=True)
    for k, (V, F) in enumerate(meshes):
        write_ply(sub / f"f{k}.ply", V, F)
    return folder


class InPlace(concurrent.futures.Executor):
    """Runs each task when it is submitted (a worker pool whose tasks all start at once)."""

    def submit(self, fn, *args, **kwargs):
        fut = concurrent.futures.Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except Exception as exc:
            fut.set_exception(exc)
        return fut


def square_warning_on_odd(k: int) -> int:
    """k^2, with a warning for odd k (the same text for k = 1 and 3): for worker tests."""
    import warnings

    from oftimg.errors import OftimgWarning

    if k % 2:
        warnings.warn(f"odd {min(k, 3)}", OftimgWarning)
    return k * k


def retriangulated_tube(rng, *, radius_in=2.0, radius_out=None, length=10.0,
                        n_vertices=3000, jitter=0.3):
    """A straight tube (a cone if ``radius_out`` differs) along +z, meshed anew:
    a random start angle, vertices jittered along the surface by ``jitter`` of a
    step (the end rings' z kept), random quad diagonals, vertices and faces in a
    random order. Independent meshes of one rigid shape: the null test's frames.
    Returns ``V (n, 3)`` mm, ``F (m, 3)``, outward-oriented."""
    radius_out = radius_in if radius_out is None else radius_out
    n_th = max(12, int(round(np.sqrt(n_vertices * 2 * np.pi * radius_in / length))))
    n_s = max(4, n_vertices // n_th)
    z = np.linspace(0, length, n_s)[:, None] * np.ones((1, n_th))
    dz, dth = length / (n_s - 1), 2 * np.pi / n_th
    th = rng.uniform(0, 2 * np.pi) + dth * np.arange(n_th)[None, :] * np.ones((n_s, 1))
    jit = rng.uniform(-jitter, jitter, z.shape) * dz
    jit[[0, -1]] = 0.0
    z = z + jit
    th = th + rng.uniform(-jitter, jitter, th.shape) * dth
    r = radius_in + (radius_out - radius_in) * z / length
    V = np.stack([r * np.cos(th), r * np.sin(th), z], axis=-1).reshape(-1, 3)
    idx = np.arange(n_s * n_th).reshape(n_s, n_th)
    a, b = idx[:-1], np.roll(idx, -1, axis=1)[:-1]
    c, d = np.roll(idx, -1, axis=1)[1:], idx[1:]
    diag = rng.random(a.shape) < 0.5
    t1 = np.where(diag[..., None], np.stack([a, b, c], -1), np.stack([a, b, d], -1))
    t2 = np.where(diag[..., None], np.stack([a, c, d], -1), np.stack([b, c, d], -1))
    F = np.concatenate([t1.reshape(-1, 3), t2.reshape(-1, 3)])
    perm = rng.permutation(len(V))
    inv = np.argsort(perm)
    return V[perm], inv[F][rng.permutation(len(F))].astype(np.int64)


def label_phantom_area_errors(page, phantom_folder, n_frames: int, group: str = "normal",
                              seed: int = 0) -> dict:
    """|area / truth - 1| ``(n_v, n_t)`` per wall of a run's results ``page`` (its
    summary.json and arrays.npz) of a label phantom written with ``sample_params(group,
    seed, n_frames=n_frames)``, in the results' time order."""
    import json

    from oftimg.synthetic.labels import label_params
    from oftimg.synthetic.phantom import Phantom, sample_params

    summary = json.loads((page / "summary.json").read_text())
    arrays = np.load(page / "arrays.npz")
    truth = json.loads((phantom_folder / "truth.json").read_text())
    ph = Phantom(label_params(sample_params(group, seed, n_frames=n_frames)))
    t_ms = np.roll(np.array(truth["t_ms"]), -summary["t0_frame"])
    return {wall: np.abs(arrays[f"area_{wall}_mm2"]
                         / ph.area_mm2(wall, arrays["s_mm"][:, None], t_ms[None, :]) - 1)
            for wall in ("outer", "inner", "lumen")}
