"""The boresight band ratio (Eq. 3) from files: bands, interleaves, dtypes, nodata, geometry."""

import warnings

import numpy as np
import pytest
import rasterio
from synth import SWIR_WL, TRANSFORM, UTM, VNIR_WL, cube, write_envi, write_gtiff

from geoboresight.algorithms import get
from geoboresight.errors import InputError, OutputError, ParameterError
from geoboresight.io import open_dual
from geoboresight.ratio import boresight_ratio

RATIO = get("ratio")


def nearest(wl, target):
    return int(np.argmin(np.abs(np.asarray(wl) - target)))


def reference(vn, sw, num_nm=1010.0, den_nm=920.0, nodata=None):
    num = sw[nearest(SWIR_WL, num_nm)].astype("float64")
    den = vn[nearest(VNIR_WL, den_nm)].astype("float64")
    ok = den > 0
    if nodata is not None:
        ok &= (num != nodata) & (den != nodata)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ok, num / den, np.nan)


def read(path):
    with rasterio.open(path) as src:
        a = src.read(1, masked=True)
        return a.filled(np.nan).astype("float64"), src


@pytest.mark.parametrize("interleave", ["bsq", "bil", "bip"])
@pytest.mark.parametrize("dtype", ["int16", "uint16", "float32"])
def test_ratio_matches_numpy_for_every_interleave_and_dtype(tmp_path, interleave, dtype):
    vn, sw = cube(len(VNIR_WL), dtype=dtype, seed=1), cube(len(SWIR_WL), dtype=dtype, seed=2)
    v = write_envi(tmp_path / "v.img", vn, VNIR_WL, interleave=interleave)
    s = write_envi(tmp_path / "s.img", sw, SWIR_WL, interleave=interleave)
    out = tmp_path / "r.tif"
    res = RATIO(vnir=v, swir=s, output=out, block_rows=7)
    got, _ = read(out)
    np.testing.assert_allclose(got, reference(vn, sw), rtol=1e-6, equal_nan=True)
    assert res["swir_wavelength_nm"] == pytest.approx(SWIR_WL[nearest(SWIR_WL, 1010)], abs=1e-3)


def test_merged_cube_split_at_seam_equals_two_files(tmp_path):
    vn, sw = cube(len(VNIR_WL), seed=3), cube(len(SWIR_WL), seed=4)
    merged = write_envi(
        tmp_path / "m.img",
        np.concatenate([vn, sw]),
        np.concatenate([VNIR_WL, SWIR_WL]),
        interleave="bil",
    )
    RATIO(vnir=merged, output=tmp_path / "r.tif")
    got, _ = read(tmp_path / "r.tif")
    np.testing.assert_allclose(got, reference(vn, sw), rtol=1e-6, equal_nan=True)
    dual = open_dual(merged)
    assert (
        dual.merged
        and len(dual.vnir.bands) == len(VNIR_WL)
        and dual.swir.bands[0] == len(VNIR_WL) + 1
    )


def test_edges_mode_is_first_swir_over_last_vnir(tmp_path):
    vn, sw = cube(len(VNIR_WL), seed=5), cube(len(SWIR_WL), seed=6)
    v = write_envi(tmp_path / "v.img", vn, VNIR_WL)
    s = write_envi(tmp_path / "s.img", sw, SWIR_WL)
    RATIO(vnir=v, swir=s, band_mode="edges", output=tmp_path / "r.tif")
    got, _ = read(tmp_path / "r.tif")
    den = vn[-1].astype(float)
    with np.errstate(divide="ignore", invalid="ignore"):
        expected = np.where(den > 0, sw[0] / den, np.nan)
    np.testing.assert_allclose(got, expected, rtol=1e-6, equal_nan=True)


def test_nodata_and_zero_denominator_propagate(tmp_path):
    vn, sw = cube(len(VNIR_WL), seed=7), cube(len(SWIR_WL), seed=8)
    d = nearest(VNIR_WL, 920)
    n = nearest(SWIR_WL, 1010)
    vn[d, 0, :5] = 0  # zero denominator
    vn[d, 1, :5] = -3  # negative denominator
    vn[d, 2, :5] = -999  # nodata in VNIR
    sw[n, 3, :5] = -999  # nodata in SWIR
    v = write_envi(tmp_path / "v.img", vn, VNIR_WL, nodata=-999)
    s = write_envi(tmp_path / "s.img", sw, SWIR_WL, nodata=-999)
    RATIO(vnir=v, swir=s, output=tmp_path / "r.tif")
    with rasterio.open(tmp_path / "r.tif") as src:
        assert src.nodata == -9999.0 and src.dtypes[0] == "float32"
        m = src.read_masks(1)
    assert (m[:4, :5] == 0).all()
    assert (m[4:, :] > 0).sum() > 0
    got, _ = read(tmp_path / "r.tif")
    np.testing.assert_allclose(got, reference(vn, sw, nodata=-999), rtol=1e-6, equal_nan=True)


def test_kernel_flags_non_finite_and_nonpositive():
    num = np.array([[1.0, np.nan, 2.0, 3.0]])
    den = np.array([[2.0, 1.0, 0.0, np.inf]])
    r, ok = boresight_ratio(num, den)
    assert ok.tolist() == [[True, False, False, False]] and r[0, 0] == 0.5


def test_micrometre_wavelengths_and_geotiff_descriptions(tmp_path):
    vn, sw = cube(len(VNIR_WL), seed=9), cube(len(SWIR_WL), seed=10)
    v = write_envi(tmp_path / "v.img", vn, VNIR_WL, units="Micrometers")
    s = write_gtiff(tmp_path / "s.tif", sw, SWIR_WL, how="description")
    dual = open_dual(v, s)
    np.testing.assert_allclose(dual.vnir.wavelengths, VNIR_WL, atol=1e-3)
    np.testing.assert_allclose(dual.swir.wavelengths, SWIR_WL, atol=1e-2)
    s2 = write_gtiff(tmp_path / "s2.tif", sw, SWIR_WL, how="tags")
    np.testing.assert_allclose(open_dual(v, s2).swir.wavelengths, SWIR_WL, atol=1e-2)


def test_wavelength_out_of_tolerance_names_file_and_range(tmp_path):
    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL)), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL)), SWIR_WL)
    with pytest.raises(InputError, match=r"s\.img.*980\.0–2450\.0 nm"):
        RATIO(vnir=v, swir=s, swir_nm=1300, tolerance_nm=5, output=tmp_path / "r.tif")
    assert not (tmp_path / "r.tif").exists()


def test_former_band_names_are_aliases(tmp_path):
    """numerator_nm/denominator_nm (0.1) still reach swir_nm/vnir_nm, and not beside them."""
    from geoboresight.errors import ParameterError

    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL)), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL)), SWIR_WL)
    old = RATIO(vnir=v, swir=s, numerator_nm=1100, denominator_nm=866, output=tmp_path / "a.tif")
    new = RATIO(vnir=v, swir=s, swir_nm=1100, vnir_nm=866, output=tmp_path / "b.tif")
    assert (old["swir_band"], old["vnir_band"]) == (new["swir_band"], new["vnir_band"])
    assert old["swir_wavelength_nm"] == pytest.approx(SWIR_WL[nearest(SWIR_WL, 1100)], abs=1e-3)
    with pytest.raises(ParameterError, match="numerator_nm.*swir_nm"):
        RATIO(vnir=v, swir=s, numerator_nm=1100, swir_nm=1010, output=tmp_path / "c.tif")


def test_missing_wavelengths_can_be_given_by_hand(tmp_path):
    vn, sw = cube(len(VNIR_WL)), cube(len(SWIR_WL))
    v = write_envi(tmp_path / "v.img", vn, None)
    s = write_envi(tmp_path / "s.img", sw, SWIR_WL)
    with pytest.raises(InputError, match=r"v\.img has no wavelength metadata"):
        RATIO(vnir=v, swir=s, output=tmp_path / "r.tif")
    RATIO(vnir=v, swir=s, vnir_wavelengths=",".join(map(str, VNIR_WL)), output=tmp_path / "r.tif")
    got, _ = read(tmp_path / "r.tif")
    np.testing.assert_allclose(got, reference(vn, sw), rtol=1e-6, equal_nan=True)
    with pytest.raises(InputError, match="has 12 bands but 3 wavelengths"):
        RATIO(vnir=v, swir=s, vnir_wavelengths="400,500,600", output=tmp_path / "r2.tif")


def test_crs_and_transform_carried_through(tmp_path):
    v = write_gtiff(tmp_path / "v.tif", cube(len(VNIR_WL)), VNIR_WL, crs=UTM, transform=TRANSFORM)
    s = write_gtiff(tmp_path / "s.tif", cube(len(SWIR_WL)), SWIR_WL, crs=UTM, transform=TRANSFORM)
    RATIO(vnir=v, swir=s, output=tmp_path / "r.tif")
    with rasterio.open(tmp_path / "r.tif") as src:
        assert src.crs.to_string() == UTM and src.transform == TRANSFORM
        assert src.tags()["NUMERATOR_BAND"] and src.profile["tiled"] and src.compression is not None


def test_raw_geometry_stays_raw_without_warnings(tmp_path):
    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL)), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL)), SWIR_WL)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        RATIO(vnir=v, swir=s, output=tmp_path / "r.tif")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(tmp_path / "r.tif") as src:
            assert src.crs is None and src.transform == rasterio.Affine.identity()
            assert not src.gcps[0]


def test_different_crs_is_an_error(tmp_path):
    v = write_gtiff(tmp_path / "v.tif", cube(len(VNIR_WL)), VNIR_WL, crs=UTM, transform=TRANSFORM)
    s = write_gtiff(
        tmp_path / "s.tif", cube(len(SWIR_WL)), SWIR_WL, crs="EPSG:4326", transform=TRANSFORM
    )
    with pytest.raises(InputError, match="EPSG:32636.*EPSG:4326"):
        RATIO(vnir=v, swir=s, output=tmp_path / "r.tif")


def test_different_sizes_are_named(tmp_path):
    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL), rows=40, cols=30), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL), rows=41, cols=30), SWIR_WL)
    with pytest.raises(InputError, match=r"30 × 40 .* 30 × 41"):
        RATIO(vnir=v, swir=s, output=tmp_path / "r.tif")


def test_missing_file_and_header_path(tmp_path):
    with pytest.raises(InputError, match=r"nope\.img does not exist"):
        RATIO(vnir=tmp_path / "nope.img", output=tmp_path / "r.tif")
    vn, sw = cube(len(VNIR_WL)), cube(len(SWIR_WL))
    write_envi(tmp_path / "v.img", vn, VNIR_WL)
    write_envi(tmp_path / "s.img", sw, SWIR_WL)
    RATIO(vnir=tmp_path / "v.hdr", swir=tmp_path / "s.hdr", output=tmp_path / "r.tif")
    got, _ = read(tmp_path / "r.tif")
    np.testing.assert_allclose(got, reference(vn, sw), rtol=1e-6, equal_nan=True)


def test_output_equal_to_input_refused_and_input_untouched(tmp_path):
    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL)), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL)), SWIR_WL)
    before = (tmp_path / "v.img").read_bytes()
    for target in ("v.img", "v.hdr"):
        # Refused before anything is opened: not a GeoTIFF name, and an input besides.
        with pytest.raises((OutputError, ParameterError), match="input|does not end in .tif"):
            RATIO(vnir=v, swir=s, output=tmp_path / target, overwrite=True)
    assert (tmp_path / "v.img").read_bytes() == before


def test_existing_output_needs_overwrite(tmp_path):
    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL)), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL)), SWIR_WL)
    out = tmp_path / "r.tif"
    out.write_bytes(b"keep me")
    with pytest.raises(OutputError, match="already exists.*overwrite=True"):
        RATIO(vnir=v, swir=s, output=out)
    assert out.read_bytes() == b"keep me"
    RATIO(vnir=v, swir=s, output=out, overwrite=True)
    assert out.read_bytes()[:2] in (b"II", b"MM")


def test_cancelled_run_leaves_no_file(tmp_path):
    from geoboresight.errors import Cancelled
    from geoboresight.progress import Progress

    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL)), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL)), SWIR_WL)
    before = sorted(p.name for p in tmp_path.iterdir())
    calls = []

    def cancel_after_first():
        calls.append(1)
        return len(calls) > 1

    with pytest.raises(Cancelled):
        RATIO(
            vnir=v,
            swir=s,
            output=tmp_path / "r.tif",
            block_rows=5,
            progress=Progress(is_cancelled=cancel_after_first),
        )
    assert sorted(p.name for p in tmp_path.iterdir()) == before
