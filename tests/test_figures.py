"""Golden-image tests: every figure type drawn from a small fixed map.

Compared with a tolerance, never byte for byte. To accept intended changes:
``OFTIMG_REGEN_GOLDEN=1 python -m pytest tests/test_figures.py`` and look at
the new files in tests/golden/ before committing them.
"""

import os
from pathlib import Path

import imageio.v3 as iio
import numpy as np
from scipy import ndimage
import pytest

from oftimg.output import figures
from oftimg.analysis.maps import analyse_area_maps
from oftimg.image.gradient import gradient_hsv

GOLDEN = Path(__file__).parent / "golden"
REGEN = os.environ.get("OFTIMG_REGEN_GOLDEN") == "1"
# the golden images' text was drawn by matplotlib 3.11; 3.8-3.10 draw the same figures
# with text a pixel wider (mean difference 6-8 of 255), so they are compared only from 3.11
GOLDEN_MATPLOTLIB = (3, 11)


def fixed_map():
    n_v, n_t, period = 24, 40, 360.0
    s = np.linspace(0, 1.2, n_v)
    t = np.arange(n_t) * period / n_t
    arrival = 1e3 * s / 12.0
    phase = ((t[None, :] - arrival[:, None]) / period) % 1.0
    taper = 0.12 - 0.05 * s / 1.2
    outer = taper[:, None] * (0.6 + 0.4 * np.sin(np.pi * phase) ** 2)
    area = {"outer": outer, "inner": 0.7 * outer, "lumen": 0.4 * outer}
    arrays, summary = analyse_area_maps(area, s, period)
    arrays.update(s_mm=s, t_ms=t, area_outer_mm2=outer)
    return arrays, summary, period


def figure_cases(tmp):
    arrays, summary, period = fixed_map()
    s, t = arrays["s_mm"], arrays["t_ms"]
    vol = {
        "outer": 0.1 + 0.02 * np.sin(2 * np.pi * t / period),
        "myocardium": 0.03 + 0 * t,
        "jelly": 0.02 + 0.005 * np.sin(2 * np.pi * t / period),
    }
    return {
        "area_map": lambda p: figures.area_map(
            arrays["area_outer_mm2"],
            s,
            t,
            p,
            ridge_t_ms=arrays["ridge_t_ms"],
            crossings_75_ms=arrays["crossing_75_outer_ms"],
            sigma_ms=arrays["gaussian_sigma_outer_ms"],
            title="golden",
        ),
        "max_area_profile": lambda p: figures.max_area_profile(
            s, {w: arrays[f"max_area_{w}_mm2"] for w in ("outer", "inner", "lumen")}, p
        ),
        "time_expanded": lambda p: figures.time_expanded(
            s,
            {
                "75 %": arrays["expanded_fraction_75_outer"],
                "sigma": arrays["expanded_fraction_sigma_outer"],
            },
            p,
        ),
        "derivative_image": lambda p: figures.derivative_image(
            gradient_hsv(arrays["area_outer_mm2"]), s, t, p, rates=(1e-3, 2e-3)
        ),
        "ridge_plot": lambda p: figures.ridge_plot(
            s,
            arrays["ridge_t_ms"],
            p,
            knee=summary["wave_two_segment"],
            speed=arrays["local_speed_mm_s"],
        ),
        "volume_over_cycle": lambda p: figures.volume_over_cycle(t, vol, p),
        "trim_over_cycle": lambda p: figures.trim_over_cycle(
            t, 5 + 5 * np.sin(t / 50), vol["myocardium"], p
        ),
    }


@pytest.mark.parametrize(
    "name",
    [
        "area_map",
        "max_area_profile",
        "time_expanded",
        "derivative_image",
        "ridge_plot",
        "volume_over_cycle",
        "trim_over_cycle",
    ],
)
def test_figure_matches_golden(name, tmp_path):
    import matplotlib

    if tuple(int(x) for x in matplotlib.__version__.split(".")[:2]) < GOLDEN_MATPLOTLIB:
        pytest.skip(
            f"matplotlib {matplotlib.__version__} draws text unlike the golden images' 3.11"
        )
    path = tmp_path / f"{name}.png"
    figure_cases(tmp_path)[name](path)
    new = iio.imread(path).astype(float)
    golden = GOLDEN / f"{name}.png"
    if REGEN:
        GOLDEN.mkdir(exist_ok=True)
        golden.write_bytes(path.read_bytes())
        pytest.skip("golden image regenerated")
    old = iio.imread(golden).astype(float)
    assert new.shape == old.shape
    diff = np.abs(new - old)
    assert diff.mean() < 3.0, f"mean difference {diff.mean():.2f} of 255"
    assert (diff.max(axis=-1) > 60).mean() < 0.02


def cohort_results(folder, sizes: dict) -> list[dict]:
    """Results folders with the arrays the group figures read; their summaries."""
    rng = np.random.default_rng(0)
    summaries = []
    for group, n in sizes.items():
        for k in range(n):
            name = f"{group}{k}"
            s = np.linspace(0, 1.1 + 0.2 * rng.random(), 50)
            t = np.arange(20) * 18.0
            (folder / name).mkdir()
            np.savez(
                folder / name / "arrays.npz",
                s_mm=s,
                t_ms=t,
                max_area_outer_mm2=0.1 + 0.01 * k + 0 * s,
                ridge_t_ms=100 + 80 * s,
                expanded_fraction_sigma_outer=0.4 + 0 * s,
                volume_outer_mm3=1 + 0.2 * np.sin(2 * np.pi * t / 360),
            )
            summaries.append({"name": name, "group": group, "period_ms": 360.0})
    return summaries


def test_group_figures_of_more_embryos_than_open_files_allowed(tmp_path):
    import resource

    summaries = cohort_results(tmp_path, {"normal": 60, "banded": 60})
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    in_use = len(list(Path("/proc/self/fd").iterdir()))
    resource.setrlimit(resource.RLIMIT_NOFILE, (in_use + 40, hard))  # fewer than 120
    try:
        paths = figures.group_figures(tmp_path, summaries, tmp_path)
    finally:
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    assert len(paths) == 4


def test_group_figures_name_few_embryos_and_summarise_many(tmp_path, monkeypatch):
    """A group of 12 is its mean +- SD (one legend entry); a group of 3, named lines."""
    import warnings

    import matplotlib.axes

    summaries = cohort_results(tmp_path, {"normal": 12, "banded": 3})
    legends = []
    real_legend = matplotlib.axes.Axes.legend
    monkeypatch.setattr(
        matplotlib.axes.Axes,
        "legend",
        lambda ax, *a, **k: legends.append(
            [t.get_text() for t in real_legend(ax, *a, **k).get_texts()]
        ),
    )
    with warnings.catch_warnings():
        # matplotlib's own warnings, e.g. a legend too tall for tight_layout; not the
        # deprecations that matplotlib < 3.11 gets from pyparsing 3.3 (also UserWarnings)
        warnings.simplefilter("error", UserWarning)
        warnings.simplefilter("ignore", DeprecationWarning)
        paths = figures.group_figures(tmp_path, summaries, tmp_path)
    assert sorted(p.name for p in paths) == [
        "group_max_area.png",
        "group_ridge_time.png",
        "group_time_expanded.png",
        "group_volume.png",
    ]
    normal, banded = legends[0], legends[1]  # the maximum-area figure's two panels
    assert normal == ["mean ± SD (n = 12)"]
    assert banded == ["banded0", "banded1", "banded2"]
    assert legends[-1] == ["normal mean ± SD (n = 12)", "banded"]  # the volume figure


@pytest.mark.parametrize("layer", ["wall", "jelly"])
def test_group_figures_draw_a_layers_thickness_and_its_thickening_along_the_tube(
    tmp_path, monkeypatch, layer
):
    """Rows of 30-36 um beating by +-10 to 30 % (sin over whole cycles): each row's
    mean thickness and thickening (1 + a) / (1 - a) - 1 drawn as they are, for the
    myocardial wall and the cardiac jelly; a group without that layer is left empty."""
    summaries = cohort_results(tmp_path, {"normal": 2, "banded": 2})
    expected = {}
    for summ in summaries[:2]:
        path = tmp_path / summ["name"] / "arrays.npz"
        arrays = dict(np.load(path))
        s = arrays["s_mm"]
        base, amp = 0.030 + 0.006 * s / s[-1], 0.1 + 0.2 * s / s[-1]
        beat = np.sin(2 * np.pi * np.arange(20) / 20)
        arrays[f"{layer}_thickness_mm"] = np.broadcast_to(
            base[:, None] * (1 + amp[:, None] * beat), (8, len(s), 20)
        ).copy()
        np.savez(path, **arrays)
        expected[summ["name"]] = (base, 100 * (2 * amp / (1 - amp)))  # mm, %
    drawn = {}
    monkeypatch.setattr(
        figures, "save", lambda fig, path: drawn.setdefault(path.name, fig) and path
    )
    paths = figures.group_figures(tmp_path, summaries, tmp_path)
    files = (f"group_{layer}_thickness.png", f"group_{layer}_thickening.png")
    assert set(files) <= {p.name for p in paths}
    for fname, k in zip(files, (0, 1)):
        normal, banded = drawn[fname].axes
        assert [line.get_label() for line in normal.lines] == ["normal0", "normal1"]
        for line in normal.lines:
            assert line.get_ydata() == pytest.approx(expected[line.get_label()][k], rel=1e-9)
        assert not banded.lines


def _compared(maps: np.ndarray, groups, key: str = "area_outer_normalized") -> dict:
    """Cohort maps of one kind with the groups' differences, as cohort_maps makes them."""
    from oftimg.analysis.group_maps import group_differences

    compared = group_differences(maps, groups)
    out = {"groups": np.asarray(groups), key: maps, "comparisons": compared.pop("names")}
    out.update({f"{key}_{what}": value for what, value in compared.items()})
    return out


def test_group_area_maps_show_each_groups_mean_and_its_difference_from_normal(
    tmp_path, monkeypatch
):
    drawn = {}
    monkeypatch.setattr(figures, "save", lambda fig, path: drawn.setdefault("fig", fig) and path)
    groups = np.array(["KO", "normal", "banded", "normal"])
    level = {"normal": 0.5, "banded": 0.8, "KO": 0.2}
    normalized = np.stack([np.full((50, 100), level[g] + 0.01 * k) for k, g in enumerate(groups)])
    figures.group_maps_figure(_compared(normalized, groups), tmp_path / "m.png", value_range=(0, 1))
    images = [ax.images[0] for ax in drawn["fig"].axes if ax.images]
    titles = [ax.get_title() for ax in drawn["fig"].axes if ax.images]
    assert titles == [
        "normal mean (n = 2)",
        "KO mean (n = 1)",
        "banded mean (n = 1)",
        "KO - normal\ntoo few embryos to test",
        "banded - normal\ntoo few embryos to test",
    ]
    assert np.asarray(images[0].get_array()) == pytest.approx(0.52)
    assert np.asarray(images[4].get_array()) == pytest.approx(0.82 - 0.52)
    assert images[3].get_clim() == pytest.approx((-0.32, 0.32))  # symmetric, both fit


def test_group_area_maps_outline_where_the_groups_differ(tmp_path, monkeypatch):
    """4 + 4 embryos, the banded ones fuller in a block of rows and phases: that block
    outlined, as a cluster and as pixels (p = 2/70 there), the rest not."""
    drawn = {}
    monkeypatch.setattr(figures, "save", lambda fig, path: drawn.setdefault("fig", fig) and path)
    rng = np.random.default_rng(0)
    groups = np.array(["normal", "banded"] * 4)
    normalized = 0.6 + 0.02 * rng.standard_normal((8, 50, 100))
    normalized[groups == "banded", 20:30, 40:60] += 0.3
    maps = _compared(normalized, groups)
    assert maps["comparisons"] == ["banded - normal"]
    block = np.zeros((50, 100), bool)
    block[20:30, 40:60] = True
    near = ndimage.binary_dilation(block, iterations=2)
    for p, around in (
        (maps["area_outer_normalized_p_fwer"][0], block),
        (maps["area_outer_normalized_p_cluster"][0], near),
    ):  # + the fringe
        assert p[block] == pytest.approx(2 / 70)
        assert np.all(p[~around] > 0.05)
    figures.group_maps_figure(maps, tmp_path / "m.png", value_range=(0, 1))
    axes = [ax for ax in drawn["fig"].axes if ax.images]
    assert axes[-1].get_title() == (
        "banded - normal\nclusters p < 0.05 outlined, pixels p < 0.05 dashed"
    )
    assert len(axes[-1].collections) == 2  # the cluster, the pixels
    for c, pixels in zip(axes[-1].collections, (2, 0)):  # the cluster's fringe: 2 pixels
        outline = np.concatenate([path.vertices for path in c.get_paths()])
        # the contour runs round the block: rows 20-30 of 50, phases 40-60 of 100
        assert 0.4 - 0.01 * (pixels + 1) < outline[:, 0].min() < 0.41
        assert 0.59 < outline[:, 0].max() < 0.6 + 0.01 * (pixels + 1)
        assert 0.4 - 0.02 * (pixels + 1) < outline[:, 1].min() < 0.41
        assert 0.59 < outline[:, 1].max() < 0.6 + 0.02 * (pixels + 1)
    assert not axes[0].collections


def test_group_maps_leave_out_embryos_without_the_map(tmp_path, monkeypatch):
    """Wall thickness maps: an embryo without an inner wall (all NaN) is not counted,
    and a group with none has no difference panel."""
    drawn = []
    monkeypatch.setattr(figures, "save", lambda fig, path: drawn.append(fig) or path)
    groups = np.array(["normal", "normal", "banded", "banded", "KO"])
    thickness = np.stack([np.full((50, 100), 0.03 + 0.01 * k) for k in range(5)])
    thickness[[3, 4]] = np.nan
    figures.group_maps_figure(
        _compared(thickness, groups, "wall_thickness_mm"),
        tmp_path / "w.png",
        key="wall_thickness_mm",
        title="wall",
        unit_label="wall thickness (µm)",
        times=1000.0,
    )
    axes = [ax for ax in drawn[0].axes if ax.images]
    assert [ax.get_title() for ax in axes] == [
        "normal mean (n = 2)",
        "banded mean (n = 1)",
        "banded - normal\ntoo few embryos to test",
    ]
    assert axes[0].images[0].get_clim() == pytest.approx((35, 50))  # the means' range, in µm
    assert np.asarray(axes[2].images[0].get_array()) == pytest.approx(50 - 35)
    bars = [ax.get_ylabel() or ax.get_xlabel() for ax in drawn[0].axes if not ax.images]
    assert any("wall thickness" in b and "(µm)" in b.replace("\n", " ") for b in bars), bars


def test_names_with_dollar_signs_are_drawn_as_they_are(tmp_path):
    """A "$" in a dataset's or group's name is not matplotlib mathtext: "$x^{$" stopped
    the run with a ParseSyntaxException."""
    import matplotlib.text

    summaries = cohort_results(tmp_path, {"normal": 2, "KO $x^{$": 2})
    drawn = []
    real_draw = matplotlib.text.Text.draw

    def record(text, renderer):
        drawn.append(text.get_text())
        return real_draw(text, renderer)

    matplotlib.text.Text.draw = record
    try:
        paths = figures.group_figures(tmp_path, summaries, tmp_path)
        arrays, _, period = fixed_map()
        figures.ridge_plot(
            arrays["s_mm"], arrays["ridge_t_ms"], tmp_path / "r.png", title="embryo $5 and $6"
        )
    finally:
        matplotlib.text.Text.draw = real_draw
    assert len(paths) == 4
    assert r"KO \$x^{\$" in drawn and r"KO \$x^{\$0" in drawn and r"embryo \$5 and \$6" in drawn


def test_ridge_plot_draws_the_noise_spread_and_keeps_unresolved_rows_off_its_scale(
    tmp_path, monkeypatch
):
    """A row whose speed the noise does not resolve (NaN spread, 900 mm/s) must not
    squash the resolved ones (about 10 mm/s) to the bottom of the axis."""
    drawn = {}
    monkeypatch.setattr(figures, "save", lambda fig, path: drawn.setdefault("fig", fig) and path)
    s = np.linspace(0, 1.2, 20)
    speed = np.full(20, 10.0)
    speed[7] = 900.0
    spread = np.full(20, 1.0)
    spread[7] = np.nan
    figures.ridge_plot(
        s,
        1e3 * s / 10.0,
        tmp_path / "r.png",
        speed=speed,
        ridge_sd_ms=np.full(20, 0.5),
        speed_sd=spread,
    )
    speed_axes = drawn["fig"].axes[1]
    low, high = speed_axes.get_ylim()
    assert low <= 0 and 11.0 <= high < 20.0
    assert "1 rows not resolved" in speed_axes.get_title()
    assert len(speed_axes.collections) >= 1  # the +- 1 SD band


def test_ridge_plot_rings_the_rows_bridged_for_the_speeds(tmp_path):
    """The rows that barely move (a neck) are ringed and named in the legend, so that a
    reader sees which ridge times the speeds did not take."""
    import matplotlib.pyplot as plt

    s = np.linspace(0, 1.2, 50)
    ridge = 1e3 * s / 10.0
    ridge[22:28] -= 12.0
    bridged = np.zeros(50, bool)
    bridged[22:28] = True
    captured = {}
    original = plt.Figure.savefig

    def keep(fig, *args, **kwargs):
        captured.setdefault("fig", fig)
        return original(fig, *args, **kwargs)

    plt.Figure.savefig = keep
    try:
        figures.ridge_plot(s, ridge, tmp_path / "r.png", speed=np.full(50, 10.0), bridged=bridged)
    finally:
        plt.Figure.savefig = original
    ax = captured["fig"].axes[0]
    labels = [t.get_text() for t in captured["fig"].legends[0].get_texts()]  # below both
    assert "rows that barely move" in labels
    assert "the line the speeds take across them" in labels
    rings = [line for line in ax.get_lines() if line.get_marker() == "o"]
    assert len(rings) == 1 and np.allclose(rings[0].get_xdata(), s[bridged])
    dashed = [line for line in ax.get_lines() if line.get_linestyle() == "--"]
    assert len(dashed) == 1  # from the last moving row to the next one
    assert np.allclose(dashed[0].get_xdata(), s[[21, 28]])
    assert np.allclose(dashed[0].get_ydata(), ridge[[21, 28]])
    assert dashed[0].get_zorder() > max(
        line.get_zorder() for line in ax.get_lines() if line is not dashed[0]
    )  # over the fit: seen


def test_a_maps_blank_cells_are_grey_and_named(tmp_path, monkeypatch):
    """Cells without a value (tissue slid out of view) are grey and in the legend: they
    were white, with no legend entry, beside docs saying they had the end row's values."""
    drawn = []
    monkeypatch.setattr(figures, "save", lambda fig, path: drawn.append(fig) or path)
    arrays, _, _ = fixed_map()
    thickness = np.full(arrays["area_outer_mm2"].shape, 30.0)
    thickness[-3:, 5:9] = np.nan
    figures.area_map(
        thickness,
        arrays["s_mm"],
        arrays["t_ms"],
        tmp_path / "t.png",
        label="wall thickness (µm)",
        blank="no value: tissue out of view",
    )
    figures.area_map(arrays["area_outer_mm2"], arrays["s_mm"], arrays["t_ms"], tmp_path / "a.png")
    labels = [
        [t.get_text() for t in fig.legends[0].get_texts()] if fig.legends else [] for fig in drawn
    ]
    assert "no value: tissue out of view" in labels[0]
    assert not any("no value" in text for text in labels[1])  # none blank: no entry
    image = drawn[0].axes[0].images[0]
    assert image.get_cmap().get_bad()[:3] == pytest.approx((0.82, 0.82, 0.82))


def test_the_activation_figure_draws_its_surface_in_whole_quads(tmp_path, monkeypatch):
    """matplotlib's plot_surface strides a grid of 50 rows into shorter polygons at its
    end, and Poly3DCollection pads polygons of unequal length with uninitialised memory
    that it then projects (matplotlib issue 32272): "overflow encountered in dot", in
    about one run in twelve, stopped whole runs. The figure's surface is whole quads."""
    from mpl_toolkits.mplot3d import art3d

    ragged = []
    original = art3d.Poly3DCollection._get_vector

    def recorded(self, segments3d):
        ragged.append(
            not isinstance(segments3d, np.ndarray) and len({len(s) for s in segments3d}) > 1
        )
        return original(self, segments3d)

    monkeypatch.setattr(art3d.Poly3DCollection, "_get_vector", recorded)
    n_u, n_v = 80, 50
    u = np.arange(n_u)[:, None] / n_u
    v = np.arange(n_v)[None, :] / (n_v - 1)
    angle = 2 * np.pi * u + 0 * v
    grid = np.stack(np.broadcast_arrays(0.2 * np.cos(angle), 0.2 * np.sin(angle), 1.2 * v), axis=-1)
    times = np.mod(60.0 * v + 0 * u, 360.0)
    velocity = np.stack([np.ones_like(times), np.zeros_like(times)], axis=-1)
    velocity[:, 20:22] = np.nan  # rows too still to time: grey
    with np.errstate(over="raise"):
        figures.activation_figure(times, velocity, grid, 360.0, tmp_path / "activation.png")
    assert ragged and not any(ragged)
    assert iio.imread(tmp_path / "activation.png").std() > 1


def test_a_helical_wave_s_times_are_averaged_round_the_cycle_on_the_3d_wall():
    """A helical wave's activation times wrap from the period to 0 along a line round
    the wall: a quad with corners at 355 and 5 ms is coloured as 0 ms on the cyclic map,
    not as 180 ms (a strip of the cycle's far colour along the wrap: issue 83, point 6);
    a wave along the tube (a sequential map) keeps the plain mean."""
    import matplotlib.pyplot as plt

    ring = np.zeros((3, 3, 3))
    ring[..., 0], ring[..., 1] = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
    values = np.array([[355.0, 5.0, 5.0], [355.0, 5.0, 5.0], [355.0, 5.0, 5.0]])
    cyclic = {"cmap": "twilight", "vmin": 0.0, "vmax": 360.0}
    _, colours = figures._surface_quads(ring, values, cyclic, every=2, cyclic=True)
    np.testing.assert_allclose(colours[0], plt.get_cmap("twilight")(0.0), atol=0.02)
    _, plain = figures._surface_quads(ring, values, dict(cyclic, cmap="viridis"), every=2)
    np.testing.assert_allclose(plain[0], plt.get_cmap("viridis")(0.5), atol=1e-6)


def test_a_field_against_t0_is_not_drawn_at_t0(monkeypatch, tmp_path):
    """Issue 87: strain against t = 0 is 0 there by definition; its pair of frames shows
    half-way to maximum expansion and maximum expansion, not an empty first panel."""
    drawn = {}
    monkeypatch.setattr(figures, "save", lambda fig, path: drawn.setdefault("fig", fig) and path)
    t = np.arange(16)
    area = np.broadcast_to(1 + np.sin(np.pi * t / 16)[None, :], (12, 16))  # largest at 8
    field = np.broadcast_to((t / 15.0)[None, None, :], (10, 12, 16)).copy()
    figures.field_pair(
        field, area, tmp_path / "f.png", label="strain energy (dimensionless)", against_t0=True
    )
    titles = [ax.get_title() for ax in drawn["fig"].axes[:2]]
    assert titles == ["half-way to maximum expansion (frame 4)", "maximum expansion (frame 8)"]


def test_isochrones_are_whole_fronts_round_the_seam_without_fragments():
    """The activation figure's isochrones (issue 87): a front across the tube is one
    line over the whole turn (periodic: not cut or doubled at the seam), a speck of
    scattered times (a band's edge) draws no fragment, and v is a share of the length."""
    n_u, n_v = 80, 50
    u = np.arange(n_u)[:, None] / n_u
    v = np.arange(n_v)[None, :] / (n_v - 1)
    times = 100.0 * v + 0 * u
    times[40:43, 24:27] += 9.0  # a speck: a closed loop 3 nodes across
    lines = figures.isochrones(times, 10.0)
    levels = [round(float(np.interp(line[:, 1].mean(), [0, 1], [0, 100]))) for line in lines]
    assert sorted(levels) == list(range(10, 91, 10))  # one line a level, no speck
    for line in lines:
        assert line[:, 0].min() < 0.02 and line[:, 0].max() > 0.97  # the whole turn
        assert np.all((line[:, 0] >= 0) & (line[:, 0] <= 1))
    helix = np.mod(360.0 * u + 60.0 * v, 360.0)  # fronts winding round the tube
    from oftimg.output.figures import _isochrone_field

    pieces = figures.isochrones(_isochrone_field(helix, 360.0), 30.0)
    assert len(pieces) >= 12 and all(np.ptp(p[:, 1]) > 0.49 for p in pieces)  # cut at the seam only
