"""SPSS-style descriptive statistics: against SciPy, the paper's Table 1, and streaming."""

import json
import math

import numpy as np
import pytest
import rasterio
from scipy import stats as st

from geoboresight.algorithms import get
from geoboresight.errors import InputError, ParameterError
from geoboresight.io import quiet_georef
from geoboresight.stats import Moments, describe, describe_blocks, se_kurtosis, se_skewness

STATS = get("stats")


def test_against_scipy():
    x = np.random.default_rng(0).gamma(0.7, 3.0, 5003)
    d = describe(x)
    assert d.n == x.size
    assert d.mean == pytest.approx(x.mean(), rel=1e-12)
    assert d.std == pytest.approx(x.std(ddof=1), rel=1e-12)
    assert d.variance == pytest.approx(x.var(ddof=1), rel=1e-12)
    assert d.se_mean == pytest.approx(st.sem(x), rel=1e-12)
    assert d.skewness == pytest.approx(st.skew(x, bias=False), rel=1e-10)
    assert d.kurtosis == pytest.approx(st.kurtosis(x, bias=False), rel=1e-10)
    for q in (1, 5, 25, 50, 75, 95, 99):
        assert d.percentiles[f"p{q}"] == np.percentile(x, q)
    z = d.skewness / d.se_skewness
    assert d.p_skewness == pytest.approx(2 * st.norm.sf(abs(z)))
    counts, edges = np.histogram(x, bins=50)
    assert d.histogram_counts == counts.tolist()
    np.testing.assert_allclose(d.histogram_edges, edges)
    assert d.n_outliers_3sd == int((np.abs(x - x.mean()) > 3 * x.std(ddof=1)).sum())


def test_table1_standard_errors_follow_from_n():
    # Table 1: N = 255, std 9,095.966 -> SE of the mean 569.6115; SE of skewness 0.153.
    assert 9095.966 / math.sqrt(255) == pytest.approx(569.6115, abs=1e-3)
    assert round(se_skewness(255), 3) == 0.153
    x = np.random.default_rng(1).lognormal(0, 1.2, 255)
    d = describe(x)
    assert d.se_mean == pytest.approx(d.std / math.sqrt(255))
    assert round(d.se_skewness, 3) == 0.153
    # SPSS SE of kurtosis for N = 255 (formula in Cramer 1997 / SPSS algorithms): 0.304
    assert round(se_kurtosis(255), 3) == 0.304


def test_streaming_equals_in_memory():
    x = np.random.default_rng(2).standard_t(3, 20011) * 50 + 1000
    d = describe(x)
    for n_blocks in (1, 3, 97):
        s = describe_blocks(lambda n=n_blocks: iter(np.array_split(x, n)))
        for f in ("n", "mean", "std", "variance", "skewness", "kurtosis", "n_outliers_3sd"):
            assert getattr(s, f) == pytest.approx(getattr(d, f), rel=1e-10), f
        assert s.percentiles == d.percentiles
        assert s.histogram_counts == d.histogram_counts


def test_moment_merge_is_order_free():
    rng = np.random.default_rng(3)
    parts = [rng.exponential(1.0, n) for n in (1, 5, 1000, 2)]
    a = Moments()
    for p in parts:
        a = a.merge(Moments.of(p))
    b = Moments.of(np.concatenate(parts))
    for f in ("n", "mean", "m2", "m3", "m4", "minimum", "maximum"):
        assert getattr(a, f) == pytest.approx(getattr(b, f), rel=1e-10)


def test_percentiles_with_ties_are_exact():
    x = np.repeat([1.0, 2.0, 2.0, 7.0], 1000)
    d = describe(x, percentiles=[0, 10, 50, 62.5, 99, 100])
    for q in (0, 10, 50, 62.5, 99, 100):
        assert d.percentiles[f"p{q:g}"] == np.percentile(x, q)


def _raster(path, data, nodata=None):
    profile = dict(
        driver="GTiff", width=data.shape[1], height=data.shape[0], count=1, dtype=str(data.dtype)
    )
    if nodata is not None:
        profile["nodata"] = nodata
    with quiet_georef(), rasterio.open(path, "w", **profile) as dst:
        dst.write(data, 1)
    return str(path)


def test_stats_spec_streams_a_raster_and_ignores_nodata(tmp_path):
    x = np.random.default_rng(4).lognormal(0, 1, (90, 33)).astype("float32")
    x[0, :10] = -9999
    p = _raster(tmp_path / "r.tif", x, nodata=-9999)
    res = STATS(
        input=p,
        output=tmp_path / "s.json",
        html=tmp_path / "s.html",
        histogram=tmp_path / "h.png",
        block_rows=7,
    )
    data = json.loads((tmp_path / "s.json").read_text())
    v = x[x != -9999].astype("float64")
    assert data["n"] == v.size == res["n"]
    assert data["skewness"] == pytest.approx(st.skew(v, bias=False), rel=1e-6)
    assert data["percentiles"]["p50"] == pytest.approx(np.median(v))
    html = (tmp_path / "s.html").read_text()
    assert "Std. Error" in html and "data:image/png;base64" in html
    assert (tmp_path / "h.png").read_bytes()[:4] == b"\x89PNG"


def test_band_out_of_range_and_all_nodata(tmp_path):
    p = _raster(tmp_path / "r.tif", np.ones((5, 5), "float32"))
    with pytest.raises(
        ParameterError, match=r"band 3 does not exist in .*r\.tif, which has 1 band"
    ):
        STATS(input=p, band=3, output=tmp_path / "s.json")
    q = _raster(tmp_path / "n.tif", np.full((5, 5), -1, "float32"), nodata=-1)
    with pytest.raises(InputError, match="no valid pixels"):
        STATS(input=q, output=tmp_path / "s.json")
    assert not (tmp_path / "s.json").exists()
    with pytest.raises(ParameterError, match="percentiles"):
        STATS(input=p, percentiles="5,150", output=tmp_path / "s.json")


# --- exact order statistics in bounded memory (memory flat in line length) ------------------


def _stream(x, n_blocks):
    return lambda: iter(np.array_split(x, n_blocks))


@pytest.mark.parametrize(
    "kind", ["normal", "ties", "outliers", "two_values", "constant", "tiny_range"]
)
@pytest.mark.parametrize("max_held", [3, 50, 1 << 20])
def test_order_statistics_equal_numpy_sort(kind, max_held):
    from geoboresight.stats import order_statistics

    rng = np.random.default_rng(7)
    x = {
        "normal": rng.normal(2.1, 0.3, 20_001),
        # Many exact ties: a crowded bin whose members are all one value.
        "ties": np.repeat(rng.normal(size=40), 500),
        # A few huge outliers stretch [lo, hi]: nearly everything falls in one fine bin.
        "outliers": np.concatenate([rng.normal(2.0, 0.01, 20_000), [1e12, -1e9, 3e15]]),
        "two_values": np.repeat([0.5, np.nextafter(0.5, 1)], 9_000),
        "constant": np.full(1_000, 3.25),
        "tiny_range": 1.0 + rng.integers(0, 5, 10_000) * np.finfo(float).eps,
    }[kind]
    rng.shuffle(x)
    ranks = sorted({0, len(x) // 3, (len(x) - 1) // 2, len(x) // 2, len(x) - 1})
    got = order_statistics(
        _stream(x, 7), ranks, lo=float(x.min()), hi=float(x.max()), max_held=max_held
    )
    ref = np.sort(x)
    assert got == {k: float(ref[k]) for k in ranks}


def test_order_statistics_holds_at_most_max_held(monkeypatch):
    # The largest array it concatenates is bounded by max_held (plus nothing of the stream).
    from geoboresight import stats

    sizes = []
    real = np.concatenate
    monkeypatch.setattr(
        stats.np,
        "concatenate",
        lambda a, *k, **kw: sizes.append(sum(len(p) for p in a)) or real(a, *k, **kw),
    )
    x = np.random.default_rng(1).normal(size=200_000)
    got = stats.order_statistics(_stream(x, 20), [100_000], lo=x.min(), hi=x.max(), max_held=64)
    assert got[100_000] == np.sort(x)[100_000]
    assert sizes and max(sizes) <= 64


def test_median_blocks_and_percentiles_with_outliers():
    from geoboresight.stats import median_blocks

    x = np.concatenate([np.random.default_rng(3).normal(5, 1, 10_000), [1e15]])
    assert median_blocks(_stream(x, 3), n=x.size, lo=x.min(), hi=x.max()) == np.median(x)
    even = x[:-1]
    assert median_blocks(_stream(even, 4), n=even.size, lo=even.min(), hi=even.max()) == (
        np.median(even)
    )
    d = describe_blocks(_stream(x, 5))
    for q in (1, 5, 25, 50, 75, 95, 99):
        assert d.percentiles[f"p{q:g}"] == pytest.approx(np.percentile(x, q), rel=1e-12, abs=0)


def test_order_statistics_refuses_ranks_out_of_range():
    from geoboresight.stats import order_statistics

    x = np.arange(10.0)
    with pytest.raises(ValueError, match="ranks"):
        order_statistics(_stream(x, 2), [10], lo=0.0, hi=9.0)
