"""The relative DEM's meaningfulness test: a χ² test of "the relief is no larger than the
matching noise", checked against scipy's χ² law and on the independent scene model
(``validation/scene_model2.py``, no code shared with the simulator)."""

from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest
from scipy import stats

from geoboresight.dem.height import HeightFactor, height_precision
from geoboresight.errors import InputError

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "validation"))
from scene_model2 import simulate2  # noqa: E402

K = HeightFactor(0.05)  # px per metre


def test_statistic_and_p_value_are_the_chi2_test_of_the_variance():
    rng = np.random.default_rng(0)
    sigma_d = 0.1
    sigma_h = sigma_d / 0.05  # 2 m
    h = rng.normal(0, 3.0, 2000)
    p = height_precision(h, np.ones(h.size, bool), sigma_d, K, window=1)
    lo, hi = np.percentile(h, [0.5, 99.5])
    kept = h[(h >= lo) & (h <= hi)]
    s2 = kept.var(ddof=1)
    n = kept.size
    assert p.sigma_h_m == pytest.approx(sigma_h)
    assert p.dof == n - 1
    assert p.statistic == pytest.approx((n - 1) * s2 / (2 * sigma_h**2))
    assert p.p_value == pytest.approx(stats.chi2.sf(p.statistic, n - 1))
    # Relief, defined once: the spread of the heights with the noise removed.
    assert p.relief_m == pytest.approx(math.sqrt(s2 - sigma_h**2))
    assert p.snr == pytest.approx(p.relief_m / sigma_h)
    assert f"{p.relief_m:.2f} m" in p.message() and f"p = {p.p_value:.3g}" in p.message()


def test_window_sets_the_independent_heights():
    h = np.random.default_rng(1).normal(0, 3.0, (100, 100))
    p = height_precision(h, np.ones(h.shape, bool), 0.1, K, window=10)
    # 0.5 % of the heights at each end are left out as gross mismatches: 9,900 of 10,000.
    assert p.dof == round(9900 / 100) - 1
    p2 = height_precision(h[:10], np.ones((10, 100), bool), 0.1, K, window=10, n_pixels=9900)
    assert p2.dof == p.dof


@pytest.mark.parametrize("seed", range(5))
def test_noise_alone_is_refused_even_with_sigma_d_underestimated(seed):
    rng = np.random.default_rng(seed)
    sigma_d = 0.1  # σ_h = 2 m; the true noise is 1.3× larger (as at small squints)
    h = rng.normal(0, 1.3 * sigma_d / K.along, 400)
    p = height_precision(h, np.ones(h.size, bool), sigma_d, K)
    assert not p.meaningful and p.p_value > 0.05
    assert "no meaningful DEM" in p.message()


@pytest.mark.parametrize("seed", range(5))
def test_relief_above_the_noise_is_accepted(seed):
    rng = np.random.default_rng(seed)
    sigma_d = 0.1
    sigma_h = sigma_d / K.along
    relief = rng.normal(0, 1.4 * sigma_h, 400)  # relief/noise 1.4: the old rule refused
    h = relief + rng.normal(0, sigma_h, 400)
    p = height_precision(h, np.ones(h.size, bool), sigma_d, K)
    assert p.meaningful and p.p_value < 0.05


def _scene_dem(squint):
    from geoboresight.dem.relative import relative_dem

    sc = simulate2(
        rows=192,
        cols=160,
        seed=5,
        sun_zenith=40.0,
        relief_m=25.0,
        squint_deg=squint,
        buildings=0,
        trees=24,
    )
    v = sc.vnir[int(np.argmin(np.abs(sc.vnir_nm - 920)))].astype(float)
    s = sc.swir[int(np.argmin(np.abs(sc.swir_nm - 1010)))].astype(float)
    k = HeightFactor(sc.truth["disparity_px_per_m"])
    return sc, v, s, k, relative_dem


def test_independent_scene_3_degrees_is_accepted_and_good():
    sc, v, s, k, relative_dem = _scene_dem(3.0)
    r = relative_dem(v, s, factor=k, require_meaningful=True, validate=False)
    assert r.precision.meaningful
    ok = np.isfinite(r.dem)
    assert np.corrcoef(r.dem[ok], sc.dsm[ok])[0, 1] >= 0.9  # the goal (0.94 measured)


def test_independent_scene_tenth_of_a_degree_is_refused():
    sc, v, s, k, relative_dem = _scene_dem(0.1)
    with pytest.raises(InputError, match="no meaningful DEM"):
        relative_dem(v, s, factor=k, require_meaningful=True, validate=False)
