"""Each field's 95 % band (issue 72, point 4): the run's own noise widened by the
accuracy zoo's calibration for its input kind (scripts/zoo_calibration.py)."""
import math

import pytest

from oftimg.analysis.uncertainty import BAND_FACTORS, FIELD_OF, input_kind, with_bands


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
    noise = {"wall_thickness_mm": {"noise_sd_smoothed": 0.002, "noise_share": 0.1},
             "mean_curvature_lumen_per_mm": {"noise_sd_smoothed": float("nan")},
             "strange_field": {"noise_sd_smoothed": 1.0}}
    out = with_bands(noise, kind)
    k = BAND_FACTORS[kind]["wall_thickness"]
    assert out["wall_thickness_mm"]["band_95"] == pytest.approx(1.96 * k * 0.002)
    assert out["wall_thickness_mm"]["band_factor"] == k
    assert out["wall_thickness_mm"]["noise_share"] == 0.1          # the rest kept
    assert out["mean_curvature_lumen_per_mm"]["band_95"] is None     # no noise measured
    assert out["strange_field"]["band_95"] is None                   # no factor
    assert not math.isnan(out["wall_thickness_mm"]["band_95"])
