"""EnMAP L1B and PRISMA L1 readers (geoboresight.io.products.enmap / .prisma) on products
written to their published layouts (tests/products_space.py), through the operations and the
command line."""

from __future__ import annotations

import os
import warnings
import zipfile

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from products_space import (
    ENMAP_NAME,
    ENMAP_SHIFT,
    PRISMA_NAME,
    write_enmap_l1b,
    write_prisma_l1,
)

import geoboresight
from geoboresight.cli import main
from geoboresight.errors import InputError
from geoboresight.io import open_dual
from geoboresight.io.products import enmap, prisma, recognise
from geoboresight.io.windows import read_masked

pytestmark = pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")


def _enmap(tmp_path, **kw):
    return write_enmap_l1b(tmp_path / "product", **kw)


def _prisma(tmp_path, **kw):
    return write_prisma_l1(tmp_path / PRISMA_NAME, **kw)


def _read_all(source):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(source) as src:
            vals, valid = zip(*(read_masked(src, b) for b in range(1, src.count + 1)), strict=True)
    return np.stack(vals), np.stack(valid)


# --- recognition ---------------------------------------------------------------------------------


def test_enmap_folder_zip_xml_and_image_are_one_product(tmp_path):
    w = _enmap(tmp_path / "f")
    wz = write_enmap_l1b(tmp_path / "z" / "product", zip=True)
    xml = os.path.join(w.path, f"{ENMAP_NAME}-METADATA.XML")
    tif = os.path.join(w.path, f"{ENMAP_NAME}-SPECTRAL_IMAGE_SWIR.TIF")
    for path in (w.path, wz.path, xml, tif):
        p = recognise(path)
        assert p is not None and p.kind == "EnMAP L1B", path
        v, s = p.image("VNIR"), p.image("SWIR")
        np.testing.assert_allclose(v.wavelengths, w.vnir_wl, atol=1e-3)
        np.testing.assert_allclose(s.wavelengths, w.swir_wl, atol=1e-3)
        np.testing.assert_allclose(v.fwhm, w.vnir_fwhm, atol=1e-3)
        np.testing.assert_allclose(s.fwhm, w.swir_fwhm, atol=1e-3)
        assert v.units == s.units == enmap.UNITS
        assert os.path.exists(v.source) and v.source.endswith(".vrt")
    # The gains and offsets travel as band metadata of the radiance VRT.
    with rasterio.open(recognise(wz.path).image("SWIR").source) as src:
        tags = src.tags(3)
    assert float(tags["dn_gain"]) == pytest.approx(w.extra["gains"][len(w.vnir_wl) + 2], rel=1e-6)
    assert float(tags["dn_offset"]) == pytest.approx(
        w.extra["offsets"][len(w.vnir_wl) + 2], rel=1e-6
    )
    assert float(tags["wavelength"]) == pytest.approx(w.swir_wl[2])


def test_enmap_radiance_and_pixel_mask(tmp_path):
    for w in (_enmap(tmp_path / "f"), write_enmap_l1b(tmp_path / "z" / "p", zip=True)):
        p = recognise(w.path)
        for name, rad, ok in (
            ("VNIR", w.vnir_radiance, w.vnir_valid),
            ("SWIR", w.swir_radiance, w.swir_valid),
        ):
            vals, valid = _read_all(p.image(name).source)
            assert vals.dtype == np.float32
            np.testing.assert_allclose(vals, rad, rtol=1e-6, atol=1e-6)
            # QL_PIXELMASK: nonzero = defective, per band (here a dead VNIR column too).
            np.testing.assert_array_equal(valid, ok)
    assert not w.vnir_valid.all() and not w.swir_valid.all()


def test_prisma_slots_descending_and_unused(tmp_path):
    for chunked in (False, True):
        w = write_prisma_l1(tmp_path / f"{chunked}-{PRISMA_NAME}", chunked=chunked)
        p = recognise(w.path)
        assert p.kind == "PRISMA L1"
        v, s = p.image("VNIR"), p.image("SWIR")
        # The product's own slot order (descending), unused slots (centre 0) marked bad.
        np.testing.assert_array_equal(v.wavelengths, w.vnir_wl)
        np.testing.assert_array_equal(s.wavelengths, w.swir_wl)
        assert np.all(np.diff(v.wavelengths[v.good]) < 0)
        np.testing.assert_array_equal(v.good, w.vnir_wl > 0)
        np.testing.assert_array_equal(s.good, w.swir_wl > 0)
        assert not v.good[:3].any() and not s.good[-2:].any()
        np.testing.assert_allclose(v.fwhm, w.vnir_fwhm)
        assert v.units == prisma.UNITS
        for im, rad in ((v, w.vnir_radiance), (s, w.swir_radiance)):
            vals, _ = _read_all(im.source)
            # radiance = DN / ScaleFactor - Offset (Offset 0.5 here: its sign is tested).
            np.testing.assert_allclose(vals, rad, rtol=1e-6, atol=1e-4)
        geo = p.geolocation
        assert geo.crs == "EPSG:4326"
        for src_path, want in ((geo.y, w.extra["lat"]), (geo.x, w.extra["lon"])):
            with rasterio.open(src_path) as src:
                np.testing.assert_array_equal(src.read(1), want)
        copied = any("copied once" in n for n in p.notes)
        assert copied == chunked
        dual = open_dual(w.path)
        assert 1 not in dual.vnir.bands and len(s.wavelengths) not in dual.swir.bands


def test_prisma_raw_vrt_points_into_the_hdf5_file(tmp_path):
    """Contiguous cube: no copy, the VRT reads the .he5 at the dataset's byte offset."""
    w = _prisma(tmp_path)
    p = recognise(w.path)
    with open(p.image("VNIR").source) as f:
        outer = f.read()
    inner = outer.split("<SourceFilename", 1)[1].split(">", 1)[1].split("<", 1)[0]
    with open(inner) as f:
        raw = f.read()
    assert os.path.abspath(w.path) in raw and "VRTRawRasterBand" in raw
    assert not any("copied once" in n for n in p.notes)


def test_not_these_products(tmp_path):
    """Other files are left to GDAL (None), quickly and without errors."""
    plain = tmp_path / "plain.tif"
    with rasterio.open(plain, "w", driver="GTiff", width=4, height=3, count=1, dtype="uint8") as d:
        d.write(np.zeros((1, 3, 4), "uint8"))
    other_zip = tmp_path / "other.zip"
    with zipfile.ZipFile(other_zip, "w") as z:
        z.writestr("a/readme.txt", "hello")
    not_zip = tmp_path / "fake.zip"
    not_zip.write_bytes(b"not a zip")
    import h5py

    other_h5 = tmp_path / "other.h5"
    with h5py.File(other_h5, "w") as f:
        f["x"] = np.zeros(3)
    not_h5 = tmp_path / "text.he5"
    not_h5.write_text("hello")
    desis = tmp_path / "desis"
    desis.mkdir()
    (desis / "DESIS-HSI-L1B-DT0483-METADATA.xml").write_text("<hsi_product><base/></hsi_product>")
    lone = tmp_path / "lone"
    lone.mkdir()
    os.link(plain, lone / f"{ENMAP_NAME}-SPECTRAL_IMAGE_VNIR.TIF")
    for path in (plain, other_zip, not_zip, other_h5, not_h5, desis, lone, tmp_path / "missing"):
        assert enmap.read(path) is None, path
        assert prisma.read(path) is None, path
    assert recognise(lone / f"{ENMAP_NAME}-SPECTRAL_IMAGE_VNIR.TIF") is None


# --- operations: the product alone, as --vnir ---------------------------------------------------


def _expected_ratio(w, vnir_good=None, swir_good=None):
    """numpy: SWIR band nearest 1010 nm over VNIR band nearest 920 nm, by the product's own
    wavelengths (unused slots excluded), invalid where masked or the denominator <= 0."""
    v_wl = np.where(w.vnir_wl > 0, w.vnir_wl, np.inf)
    s_wl = np.where(w.swir_wl > 0, w.swir_wl, np.inf)
    vb, sb = int(np.argmin(np.abs(v_wl - 920))), int(np.argmin(np.abs(s_wl - 1010)))
    num, den = w.swir_radiance[sb].astype("float32"), w.vnir_radiance[vb].astype("float32")
    ok = den > 0
    if w.vnir_valid is not None:
        ok &= w.vnir_valid[vb] & w.swir_valid[sb]
    return np.where(ok, num / np.where(ok, den, 1), -9999.0), ok, vb + 1, sb + 1


@pytest.mark.parametrize("kind", ["enmap-folder", "enmap-zip", "prisma", "prisma-chunked"])
def test_ratio_of_the_product_alone_equals_numpy(tmp_path, kind):
    if kind == "enmap-folder":
        w = _enmap(tmp_path)
    elif kind == "enmap-zip":
        w = write_enmap_l1b(tmp_path / "unpacked", zip=True)
    else:
        w = _prisma(tmp_path, chunked=kind.endswith("chunked"))
    res = geoboresight.ratio_file(w.path, output=tmp_path / "ratio.tif")
    want, ok, vb, sb = _expected_ratio(w)
    assert (res["vnir_band"], res["swir_band"]) == (vb, sb)
    assert res["valid_pixels"] == int(ok.sum())
    with rasterio.open(tmp_path / "ratio.tif") as src:
        got = src.read(1)
    np.testing.assert_array_equal(got == -9999.0, ~ok)
    np.testing.assert_allclose(got[ok], want[ok], rtol=1e-5)


def test_prisma_edges_never_pick_unused_slots(tmp_path):
    w = _prisma(tmp_path)
    res = geoboresight.ratio_file(
        w.path, output=tmp_path / "r.tif", bands=geoboresight.BandChoice(band_mode="edges")
    )
    assert res["vnir_wavelength_nm"] == pytest.approx(w.vnir_wl.max())
    assert res["swir_wavelength_nm"] == pytest.approx(w.swir_wl[w.swir_wl > 0].min())
    assert w.vnir_wl[res["vnir_band"] - 1] > 0 and w.swir_wl[res["swir_band"] - 1] > 0


def test_offset_recovers_enmap_along_track_shift(tmp_path):
    w = _enmap(tmp_path)
    res = geoboresight.boresight_offset_file(w.path, output=tmp_path / "offset.json")
    assert res["along_px"] == pytest.approx(ENMAP_SHIFT, abs=0.2)
    assert res["across_px"] == pytest.approx(0.0, abs=0.2)


# --- command line ----------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["enmap-folder", "enmap-zip", "enmap-xml", "prisma"])
def test_cli_ratio_on_the_product(tmp_path, kind):
    if kind == "prisma":
        path = _prisma(tmp_path, chunked=True).path
    elif kind == "enmap-zip":
        path = write_enmap_l1b(tmp_path / "unpacked", zip=True).path
    else:
        path = _enmap(tmp_path).path
        if kind == "enmap-xml":
            path = os.path.join(path, f"{ENMAP_NAME}-METADATA.XML")
    out = tmp_path / "out.tif"
    r = CliRunner().invoke(main, ["ratio", "--vnir", str(path), "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert out.exists()


DAMAGED = [
    ("enmap", "no-wavelengths", "no wavelengthCenterOfBand"),
    ("enmap", "no-swir-image", "no *-SPECTRAL_IMAGE_SWIR image"),
    ("enmap", "band-mismatch", "SPECTRAL_IMAGE_SWIR.TIF has 61 bands but the XML lists 62"),
    ("prisma", "no-vnir-cube", "no VNIR_Cube"),
    ("prisma", "wavelength-count", "List_Cw_Vnir has 42 wavelengths but VNIR_Cube has 43"),
    ("prisma", "no-wavelengths", "no root attribute List_Cw_Swir"),
]


@pytest.mark.parametrize(("kind", "damage", "says"), DAMAGED)
def test_damaged_products_give_one_clear_line(tmp_path, kind, damage, says):
    w = (_enmap if kind == "enmap" else _prisma)(tmp_path, damage=damage)
    with pytest.raises(InputError) as err:
        recognise(w.path)
    assert says in str(err.value)
    assert os.path.basename(w.path) in str(err.value)
    r = CliRunner().invoke(main, ["ratio", "--vnir", w.path, "-o", str(tmp_path / "o.tif")])
    assert r.exit_code == 1
    assert "Traceback" not in r.output
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and says in lines[0]
    assert not (tmp_path / "o.tif").exists()


def test_enmap_other_levels_are_refused(tmp_path):
    w = _enmap(tmp_path)
    xml = os.path.join(w.path, f"{ENMAP_NAME}-METADATA.XML")
    with open(xml) as f:
        text = f.read()
    with open(xml, "w") as f:
        f.write(text.replace("<level>L1B</level>", "<level>L2A</level>"))
    with pytest.raises(InputError, match="only L1B"):
        recognise(w.path)


def test_prisma_level_2_is_refused(tmp_path):
    import h5py

    path = tmp_path / "PRS_L2D_STD_20200524101500_20200524101504_0001.he5"
    with h5py.File(path, "w") as f:
        f["HDFEOS/SWATHS/PRS_L2D_HCO/Data Fields/VNIR_Cube"] = np.zeros((2, 3, 4), "uint16")
    with pytest.raises(InputError, match="only L1 is read"):
        recognise(path)
