"""Property-based tests of the kernels (hypothesis): invariances and constraints that must hold
for any input, not only for the scenes we thought of.

- the ratio (Eq. 3) is invariant to a gain common to both bands, and invalid pixels never
  become valid (nodata propagates);
- the shadow class (Table 2) is monotone in the ratio: more ratio, never less shadow;
- global RX is invariant to any invertible affine map of the spectra (Mahalanobis distance);
- FCLS abundances are non-negative and sum to one; NNLS satisfies the KKT optimality
  conditions and matches SciPy's NNLS residual;
- merged moments (Pébay) equal the whole array's for any split;
- the one block loop equals the whole-array result for any block size and halo.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage, optimize

from geoboresight import io
from geoboresight.anomaly.rx import rx
from geoboresight.anomaly.unmix import unmix
from geoboresight.ratio import boresight_ratio
from geoboresight.shadow.classes import NO_SHADOW, NODATA_CLASS, default_table, scale_table
from geoboresight.stats import Moments

FAST = settings(max_examples=40, deadline=None)
seeds = st.integers(0, 2**31 - 1)


def _bands(seed: int, shape=(13, 11)):
    rng = np.random.default_rng(seed)
    num = rng.uniform(1.0, 4000.0, shape).astype("float32")
    den = rng.uniform(1.0, 4000.0, shape).astype("float32")
    # Plant every kind of bad pixel: NaN, inf, zero and negative denominators.
    bad = rng.random(shape)
    num[bad < 0.05] = np.nan
    den[(bad >= 0.05) & (bad < 0.1)] = 0.0
    den[(bad >= 0.1) & (bad < 0.12)] = -5.0
    num[(bad >= 0.12) & (bad < 0.14)] = np.inf
    return num, den, rng.random(shape) > 0.1


@FAST
@given(seed=seeds, gain=st.floats(1e-3, 1e3))
def test_ratio_is_invariant_to_a_common_gain(seed, gain):
    num, den, valid = _bands(seed)
    r1, ok1 = boresight_ratio(num, den, valid)
    r2, ok2 = boresight_ratio(num * np.float32(gain), den * np.float32(gain), valid)
    np.testing.assert_array_equal(ok1, ok2)
    np.testing.assert_allclose(r2[ok2], r1[ok1], rtol=2e-6)


@FAST
@given(seed=seeds)
def test_ratio_propagates_nodata(seed):
    num, den, valid = _bands(seed)
    r, ok = boresight_ratio(num, den, valid)
    bad = ~valid | ~np.isfinite(num) | ~np.isfinite(den) | (den <= 0)
    assert not ok[bad].any()  # an invalid input pixel is never a valid output
    assert np.isnan(r[~ok]).all()
    assert np.isfinite(r[ok]).all()
    np.testing.assert_array_equal(ok, ~bad)  # and every good pixel is kept


def _fraction(table, classes):
    """Lower shadow fraction of each class value (0 for no shadow)."""
    lookup = {NO_SHADOW: 0.0, **{c.id: c.fraction_min for c in table.classes}}
    return np.vectorize(lookup.__getitem__)(classes)


@FAST
@given(
    ratios=st.lists(st.floats(0.0, 10.0), min_size=2, max_size=60),
    factor=st.floats(0.2, 5.0),
)
def test_shadow_class_is_monotone_in_the_ratio(ratios, factor):
    """Table 2: a higher ratio is never less shadow; scaling the table by a scene's sunlit
    ratio and the ratios by the same factor gives the same classes."""
    table = default_table()
    r = np.sort(np.asarray(ratios))
    classes = table.classify(r)
    assert NODATA_CLASS not in classes
    assert np.all(np.diff(_fraction(table, classes)) >= 0)
    scaled = scale_table(table, factor)
    inside = np.array([any(np.isclose(x, [c.min, c.max]).any() for c in table.classes) for x in r])
    np.testing.assert_array_equal(scaled.classify(r * factor)[~inside], classes[~inside])


@FAST
@given(seed=seeds, k=st.integers(2, 6), shift=st.floats(-100, 100))
def test_rx_is_invariant_to_invertible_affine_maps(seed, k, shift):
    rng = np.random.default_rng(seed)
    cube = rng.normal(size=(k, 17, 13)) * rng.uniform(0.5, 3.0, (k, 1, 1))
    valid = rng.random((17, 13)) > 0.1
    # A well-conditioned invertible map: orthogonal times a diagonal in [0.5, 2].
    q, _ = np.linalg.qr(rng.normal(size=(k, k)))
    a = q @ np.diag(rng.uniform(0.5, 2.0, k))
    b = rng.normal(size=k) * shift
    mapped = np.einsum("ij,jrc->irc", a, cube) + b[:, None, None]
    s1 = rx(cube, valid)
    s2 = rx(mapped, valid)
    np.testing.assert_array_equal(np.isnan(s1), ~valid)
    np.testing.assert_allclose(s2[valid], s1[valid], rtol=1e-6, atol=1e-8)


def _endmembers(seed, n_end, k):
    rng = np.random.default_rng(seed)
    e = rng.uniform(0.05, 0.9, (n_end, k))
    pixels = rng.uniform(0.0, 1.0, (k, 25))
    return e, pixels


@FAST
@given(seed=seeds, n_end=st.integers(2, 5), k=st.integers(6, 20))
def test_fcls_abundances_are_nonnegative_and_sum_to_one(seed, n_end, k):
    e, x = _endmembers(seed, n_end, k)
    f, res = unmix(x, e, method="fcls")
    assert f.shape == (n_end, x.shape[1])
    assert (f >= -1e-10).all()
    np.testing.assert_allclose(f.sum(axis=0), 1.0, atol=1e-9)
    np.testing.assert_allclose(res, np.sqrt(((x - e.T @ f) ** 2).mean(axis=0)), rtol=1e-9)


@FAST
@given(seed=seeds, n_end=st.integers(2, 5), k=st.integers(6, 20))
def test_nnls_is_optimal(seed, n_end, k):
    """KKT: f ≥ 0, gradient ≥ 0 and complementary; the same residual as SciPy's NNLS."""
    e, x = _endmembers(seed, n_end, k)
    f, _ = unmix(x, e, method="nnls")
    assert (f >= -1e-10).all()
    grad = e @ (e.T @ f - x)  # gradient of ½‖Eᵀf − x‖²
    scale = np.abs(e @ x).max()
    assert (grad >= -1e-8 * scale).all()
    np.testing.assert_allclose(grad * f, 0.0, atol=1e-8 * scale)
    for j in range(x.shape[1]):
        _, rnorm = optimize.nnls(e.T, x[:, j])
        assert np.linalg.norm(e.T @ f[:, j] - x[:, j]) <= rnorm * (1 + 1e-9) + 1e-12


@FAST
@given(
    values=st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=0, max_size=80),
    cuts=st.lists(st.integers(0, 80), max_size=4),
)
def test_merged_moments_equal_whole_array_moments_for_any_split(values, cuts):
    v = np.asarray(values, dtype="float64")
    edges = sorted({0, len(v), *(c for c in cuts if c <= len(v))})
    merged = Moments()
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        merged = merged.merge(Moments.of(v[a:b]))
    whole = Moments.of(v)
    assert merged.n == whole.n
    if whole.n:
        scale = max(1.0, float(np.abs(v).max()))
        assert merged.minimum == whole.minimum and merged.maximum == whole.maximum
        np.testing.assert_allclose(merged.mean, whole.mean, rtol=1e-9, atol=1e-12 * scale)
        for m in ("m2", "m3", "m4"):
            p = int(m[1])
            np.testing.assert_allclose(
                getattr(merged, m), getattr(whole, m), rtol=1e-7, atol=1e-9 * scale**p * len(v)
            )


@FAST
@given(
    seed=seeds,
    rows=st.integers(1, 60),
    block_rows=st.integers(1, 70),
    size=st.sampled_from([1, 3, 5, 9]),
    extra=st.integers(0, 3),
    workers=st.sampled_from([1, 2]),
)
def test_map_windows_equals_whole_array_for_any_block_and_halo(
    seed, rows, block_rows, size, extra, workers
):
    """A neighbourhood filter needs size // 2 lines of halo; any larger halo gives the same."""
    band = np.random.default_rng(seed).normal(size=(rows, 9))
    whole = ndimage.uniform_filter(band, size, mode="reflect")
    h = size // 2 + extra
    got = np.full_like(whole, np.nan)
    for win, part in io.map_windows(
        lambda r0, r1: band[r0:r1],
        lambda x: ndimage.uniform_filter(x, size, mode="reflect"),
        height=rows,
        width=9,
        block_rows=block_rows,
        halo=(h, h),
        workers=workers,
    ):
        got[win.row_off : win.row_off + win.height] = part
    np.testing.assert_allclose(got, whole, rtol=1e-12, atol=1e-12)
