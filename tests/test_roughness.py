"""A mesh rough at its own vertices is smoothed before it is measured (issue 72: the
zoo's mesh draws with 0-5 um of roughness had curvatures 27 % off in the median); a
smooth one is left as it is."""

import numpy as np
import pytest

from oftimg.mesh.curvature import ROUGH_STEPS, smoothing_steps, vertex_roughness


def open_cylinder(radius=0.2, length=1.0, n_around=60, n_along=49, noise=0.0, seed=0):
    """An open cylinder's mesh (mm): ``(V, F)``, each vertex moved along its radius by
    a normal noise of SD ``noise`` mm."""
    th = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    z = np.linspace(0, length, n_along)
    T, Z = np.meshgrid(th, z, indexing="ij")
    r = radius + np.random.default_rng(seed).normal(0, noise, T.shape)
    V = np.stack([r * np.cos(T), r * np.sin(T), Z], -1).reshape(-1, 3)
    idx = np.arange(n_around * n_along).reshape(n_around, n_along)
    a, b = idx[:, :-1], np.roll(idx, -1, axis=0)[:, :-1]
    c, d = np.roll(idx, -1, axis=0)[:, 1:], idx[:, 1:]
    F = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    return V, F


@pytest.mark.parametrize("noise_um", [1.0, 2.0, 5.0])
def test_the_roughness_is_the_vertex_noise(noise_um):
    V, F = open_cylinder(noise=noise_um * 1e-3)
    sigma, edge = vertex_roughness(V, F)
    assert sigma == pytest.approx(1.3 * noise_um * 1e-3, rel=0.2)
    assert edge == pytest.approx(2 * np.pi * 0.2 / 60, rel=0.1)


def test_a_smooth_curved_mesh_is_not_rough_and_is_left_alone():
    V, F = open_cylinder(radius=0.05, n_around=20)  # coarse and strongly curved
    sigma, edge = vertex_roughness(V, F)
    assert sigma < 0.01 * edge
    assert smoothing_steps(V, F, "auto") == 0
    rough = open_cylinder(noise=2e-3)
    assert smoothing_steps(*rough, "auto") == ROUGH_STEPS
    assert smoothing_steps(*rough, 0) == 0 and smoothing_steps(V, F, 12) == 12


def test_a_rough_phantoms_meshes_are_smoothed_and_its_fields_come_closer_to_the_truth(tmp_path):
    """The phantom of tests/test_fields.py's rough case (5 um at every vertex, 20
    frames): every wall of every frame is found rough and smoothed, and the radial
    curvature's median error against the model falls to well under half its error on
    the meshes left rough (measured: 25 % and 7.5 % of the truth's median size)."""
    from oftimg.analysis.pipeline import PipelineOptions, analyse_dataset
    from oftimg.io.dataset import load_dataset
    from oftimg.synthetic.phantom import read_truth, sample_params, write_phantom

    path = write_phantom(
        tmp_path / "rough",
        sample_params(
            "normal", 0, n_frames=20, vertices_min=2500, vertices_max=3500, noise_mm=0.005
        ),
    )
    ph, truth = read_truth(path)
    errors = {}
    for steps in (0, "auto"):
        result = analyse_dataset(
            load_dataset(path),
            PipelineOptions(tracking="none", rough_mesh_smoothing=steps),
            quiet=True,
        )
        smoothed = result["summary"]["frames_smoothed_as_rough"]
        assert smoothed == (
            {w: 0 for w in smoothed} if steps == 0 else {"outer": 20, "inner": 20, "lumen": 20}
        )
        t_ms = np.roll(np.asarray(truth["t_ms"]), -result["summary"]["t0_frame"])[None, None]
        s, theta = ph.window_coordinates(result["arrays"]["contour_outer_mm"][:, 2:-2])
        true = ph.section_curvature("outer", s, theta, t_ms)
        errors[steps] = np.median(
            np.abs(result["arrays"]["radial_curvature_outer_per_mm"][:, 2:-2] - true)
        ) / np.median(np.abs(true))
    assert errors["auto"] < 0.5 * errors[0]
