"""The relative DEM's meaningfulness test: a χ² test of "the relief between blocks of 2 × 2
matching windows is no larger than the noise of a block's mean", checked against scipy's χ² law
(statistic, p-value, and the rate at which it rejects a true H0) and on the independent scene
model (``validation/scene_model2.py``, no code shared with the simulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from geoboresight.dem.height import (
    HeightFactor,
    height_precision,
    not_gross,
    relief_test,
    window_centres,
)
from geoboresight.errors import InputError
from validation.scene_model2 import simulate2

K = HeightFactor(0.05)  # px per metre
SIGMA_D = 0.1  # px: σ_h = 2 m


def lattice(n_rows, n_cols):
    r, c = np.meshgrid(np.arange(n_rows), np.arange(n_cols), indexing="ij")
    return r.ravel(), c.ravel()


def block_field(rng, n_rows, n_cols, tau, block=2):
    """One relief value per block of ``block × block`` windows (sd ``tau``), on every window."""
    r, c = lattice(n_rows, n_cols)
    per_block = rng.normal(0, tau, (n_rows // block + 1, n_cols // block + 1))
    return r, c, per_block[r // block, c // block]


def test_statistic_and_p_value_are_the_chi2_test_of_the_block_means():
    rng = np.random.default_rng(0)
    sigma_h = SIGMA_D / K.along
    r, c, relief = block_field(rng, 30, 40, 3.0)
    h = relief + rng.normal(0, sigma_h, r.size)
    p = relief_test(h, r, c, SIGMA_D, K, window=21)
    h[:3] = [500.0, -400.0, 900.0]  # gross mismatches
    p = relief_test(h, r, c, SIGMA_D, K, window=21)
    # Independently: gross mismatches out (10 robust σ), then the block means.
    keep = np.abs(h - np.median(h)) <= 10 * stats.median_abs_deviation(h, scale="normal")
    assert keep.sum() == h.size - 3
    groups: dict = {}
    for hi_, ri, ci in zip(h[keep], r[keep], c[keep], strict=True):
        groups.setdefault((ri // 2, ci // 2), []).append(hi_)
    groups = {k: v for k, v in groups.items() if len(v) >= 2}
    m = np.array([np.mean(v) for v in groups.values()])
    n = np.array([len(v) for v in groups.values()])
    var = sigma_h**2 / 4 + sigma_h**2 / n
    mbar = np.sum(m / var) / np.sum(1 / var)
    chi2 = np.sum((m - mbar) ** 2 / var)
    assert p.sigma_h_m == pytest.approx(sigma_h)
    assert p.blocks == m.size and p.dof == m.size - 1 and p.windows == n.sum()
    assert p.statistic == pytest.approx(chi2)
    assert p.p_value == pytest.approx(stats.chi2.sf(chi2, m.size - 1))
    # With full blocks only, it is the textbook test of a variance: (g − 1) s² / σ0².
    r2, c2 = lattice(30, 40)
    h2 = rng.normal(0, 3.0, r2.size)
    p2 = relief_test(h2, r2, c2, SIGMA_D, K)
    m2 = h2.reshape(15, 2, 20, 2).mean(axis=(1, 3)).ravel()
    want = (m2.size - 1) * np.var(m2, ddof=1) / (2 * sigma_h**2 / 4)
    assert p2.statistic == pytest.approx(want) and p2.dof == 299
    # Relief, defined once: the spread of the block means with their noise removed.
    assert p.relief_m == pytest.approx(math.sqrt(np.var(m, ddof=1) - np.mean(sigma_h**2 / n)))
    assert p.noise_m == pytest.approx(sigma_h / 2)
    assert p.snr == pytest.approx(p.relief_m / p.noise_m)
    assert p.meaningful
    assert f"{p.relief_m:.2f} m" in p.message() and f"p = {p.p_value:.3g}" in p.message()
    assert "42 × 42 px" in p.message()


def test_gross_mismatches_are_scipys_robust_rule_value_for_value():
    """10 normal-consistent MADs of scipy.stats around the median, on heavy tails; an empty
    sample keeps nothing and says nothing."""
    h = np.random.default_rng(3).standard_t(1.5, size=20_001)
    want = np.abs(h - np.median(h)) <= 10 * stats.median_abs_deviation(h, scale="normal")
    assert 0 < (~want).sum() < h.size // 10
    np.testing.assert_array_equal(not_gross(h), want)
    assert not_gross(np.full(7, 2.5)).all()  # no spread: nothing is gross
    assert not_gross(np.empty(0)).shape == (0,)


def test_a_true_null_hypothesis_is_rejected_at_the_nominal_rate():
    """At the boundary of H0 (relief between blocks = the noise of a block's mean, σ_h / 2),
    the test rejects in about ``alpha`` of the cases: the χ² law holds."""
    rng = np.random.default_rng(7)
    sigma_h = SIGMA_D / K.along
    rejected = 0
    trials = 1500
    for _ in range(trials):
        r, c, relief = block_field(rng, 16, 16, sigma_h / 2)
        h = relief + rng.normal(0, sigma_h, r.size)
        rejected += relief_test(h, r, c, SIGMA_D, K).meaningful
    # 0.05 nominal; binomial sd of the rate over 1,500 trials 0.0056
    assert 0.035 <= rejected / trials <= 0.065


def test_window_centres_are_one_height_per_window_on_the_lines_lattice():
    rng = np.random.default_rng(1)
    h = rng.normal(0, 3.0, (100, 90))
    ok = rng.random(h.shape) > 0.1
    r, c, v = window_centres(h, ok, (10, 9))
    want = np.zeros(h.shape, bool)
    want[5::10, 4::9] = True
    want &= ok
    assert v.size == want.sum()
    np.testing.assert_array_equal(v, h[want])
    np.testing.assert_array_equal(r * 10 + 5, np.nonzero(want)[0])
    np.testing.assert_array_equal(c * 9 + 4, np.nonzero(want)[1])
    # Strips of the line (any cut) give the lattice of the whole line.
    parts = [
        window_centres(h[a:b], ok[a:b], (10, 9), first_line=a) for a, b in ((0, 37), (37, 100))
    ]
    for i in range(3):
        np.testing.assert_array_equal(np.concatenate([p[i] for p in parts]), (r, c, v)[i])
    p = height_precision(h, ok, SIGMA_D, K, window=(10, 9))
    assert p.windows <= v.size and p.window == (10, 9)


@pytest.mark.parametrize("seed", range(5))
def test_noise_alone_is_refused_even_with_sigma_d_underestimated(seed):
    rng = np.random.default_rng(seed)
    r, c = lattice(20, 20)
    h = rng.normal(0, 1.3 * SIGMA_D / K.along, r.size)  # true noise 1.3× σ_h (small squints)
    p = relief_test(h, r, c, SIGMA_D, K)
    assert not p.meaningful and p.p_value > 0.05
    assert "no meaningful DEM" in p.message()


@pytest.mark.parametrize("seed", range(5))
def test_coherent_relief_below_one_windows_noise_is_accepted(seed):
    """Relief of 0.9 σ_h per window, smooth over several windows: a kriged DEM of it is good
    (the per-window test refused it), and this test accepts it."""
    rng = np.random.default_rng(seed)
    sigma_h = SIGMA_D / K.along
    r, c = lattice(20, 20)
    yy, xx = r / 20.0, c / 20.0
    relief = np.sin(2 * np.pi * (yy + rng.random())) + np.cos(2 * np.pi * (xx + rng.random()))
    relief *= 0.9 * sigma_h / relief.std()
    h = relief + rng.normal(0, sigma_h, r.size)
    p = relief_test(h, r, c, SIGMA_D, K)
    assert p.meaningful and p.p_value < 0.05


def test_too_few_blocks_say_so():
    p = relief_test(np.array([1.0, 2.0, 3.0]), np.array([0, 0, 1]), np.array([0, 1, 0]), SIGMA_D, K)
    assert not p.meaningful and p.blocks == 1
    assert "needs 2 or more" in p.message()


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


def test_independent_scene_2_degrees_is_accepted_where_its_forced_dem_is_good():
    """The goal's case: at 2° the forced DEM reaches r ≥ 0.9, which the per-window test
    refused."""
    sc, v, s, k, relative_dem = _scene_dem(2.0)
    r = relative_dem(v, s, factor=k, require_meaningful=False, validate=False)
    ok = np.isfinite(r.dem)
    assert np.corrcoef(r.dem[ok], sc.dsm[ok])[0, 1] >= 0.9
    assert r.precision.meaningful


def test_independent_scene_tenth_of_a_degree_is_refused():
    sc, v, s, k, relative_dem = _scene_dem(0.1)
    with pytest.raises(InputError, match="no meaningful DEM"):
        relative_dem(v, s, factor=k, require_meaningful=True, validate=False)
