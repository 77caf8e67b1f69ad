"""Each field's 95 % band (issue 72, point 4): the run's own noise widened by the
accuracy zoo's calibration for its input kind (scripts/zoo_calibration.py); the cycle wave
speed's band, shown in Table 1 and on the pages."""

import math

import pytest

from oftimg.analysis.uncertainty import (
    BAND_FACTORS,
    FIELD_OF,
    SPEED_SYSTEMATIC_SHARE,
    input_kind,
    speed_band_95,
    with_bands,
)


def test_the_input_kind_is_what_the_walls_were_made_from():
    assert input_kind({"meshes": {}, "intensity": []}) == "meshes"
    assert input_kind({"labels": [], "intensity": []}) == "labels"
    assert input_kind({"probabilities": []}) == "probabilities"


def test_every_kind_has_a_factor_for_every_field():
    for kind, factors in BAND_FACTORS.items():
        assert set(factors) == set(FIELD_OF.values()), kind
        assert all(0.5 < k < 20 for k in factors.values()), kind


@pytest.mark.parametrize("kind", sorted(BAND_FACTORS))
def test_the_band_is_the_noise_widened_by_the_kinds_factor(kind):
    noise = {
        "wall_thickness_mm": {"noise_sd_smoothed": 0.002, "noise_share": 0.1},
        "mean_curvature_lumen_per_mm": {"noise_sd_smoothed": float("nan")},
        "strange_field": {"noise_sd_smoothed": 1.0},
    }
    out = with_bands(noise, kind)
    k = BAND_FACTORS[kind]["wall_thickness"]
    assert out["wall_thickness_mm"]["band_95"] == pytest.approx(1.96 * k * 0.002)
    assert out["wall_thickness_mm"]["band_factor"] == k
    assert out["wall_thickness_mm"]["noise_share"] == 0.1  # the rest kept
    assert out["mean_curvature_lumen_per_mm"]["band_95"] is None  # no noise measured
    assert out["strange_field"]["band_95"] is None  # no factor
    assert not math.isnan(out["wall_thickness_mm"]["band_95"])


def test_the_cycle_speeds_band_adds_the_zoos_share_to_its_noise():
    """1.96 x sqrt(noise SD^2 + (share x speed)^2): a speed without noise keeps the
    share the zoo found; no speed or no spread, no band."""
    share = SPEED_SYSTEMATIC_SHARE
    assert speed_band_95(10.0, 0.0) == pytest.approx(1.96 * share * 10.0)
    assert speed_band_95(10.0, 0.3) == pytest.approx(1.96 * math.hypot(0.3, share * 10.0))
    assert speed_band_95(10.0, 5.0) == pytest.approx(1.96 * math.hypot(5.0, share * 10.0))
    for speed, sd in ((None, 0.1), (float("nan"), 0.1), (10.0, None), (10.0, float("inf"))):
        assert speed_band_95(speed, sd) is None


def test_table1_shows_the_cycle_speeds_band():
    """Table 1's cycle speed cell: the value and its band in brackets, to the band's 2
    digits, and the note says so (± is a group's SD alone); without a band the value
    alone."""
    from oftimg.output.report import table1_markdown

    summary = {
        "name": "A",
        "group": "normal",
        "expand_fraction": 0.38,
        "contract_fraction": 0.62,
        "expand_contract_ratio": 0.62,
        "period_ms": 372.2,
        "expand_ms": 142.5,
        "contract_ms": 229.7,
        "wave_speed_mm_s": {"min": 3.36, "max": 18.5, "mean": 8.96, "std": 3.42, "cycle": 6.814912},
        "wave_speed_band_95_mm_s": {"cycle": 0.7134},
        "myocardial_volume_change": 0.1675,
        "clipped_myocardial_volume_mm3": 0.0241,
    }
    text = table1_markdown([summary])
    assert "| 8.96 | 3.42 | 6.81 (6.10–7.53) | 16.8 |" in text, text
    assert "followed by its 95 % band in brackets" in text and "± is a group's SD" in text
    plain = table1_markdown([{**summary, "wave_speed_band_95_mm_s": {"cycle": None}}])
    assert "| 3.42 | 6.81 | 16.8 |" in plain and "95 % band" not in plain, plain
