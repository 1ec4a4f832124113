"""Radiance from raw DN through the vendor's calibration, against the formulas computed here
with NumPy from the bytes written: L = (DN − dark) · gain / tint[ms] (NERC-ARF APL
``src/calibration.cpp``: dark frames averaged within 3σ, per-detector tint of an AisaFENIX,
Eagle frame-transfer smear, binned gains, ``.bad`` cells, saturation) and HyPro's HySpex gain
(``hypro/Radiometry.py``). Fixtures follow the published layouts (``tests/products.py``)."""

from __future__ import annotations

import os

import numpy as np
import pytest
import rasterio
from scipy import constants

import geoboresight as gb
from geoboresight.errors import GeoboresightError
from tests.products import write_bad, write_calibration, write_hyspex, write_specim_raw

LINES, DARK_LINES, SAMPLES = 64, 24, 32


def _refined_dark(frames: np.ndarray) -> np.ndarray:
    """APL's AverageRefinedDarkFrames, written out: per cell, the mean of the dark values
    within 3 standard deviations (ddof 1) of their mean."""
    f = frames.astype(np.float64)
    mean = f.mean(axis=0)
    std = f.std(axis=0, ddof=1)
    keep = np.abs(f - mean) <= 3 * std
    return np.where(keep, f, 0).sum(axis=0) / keep.sum(axis=0)


def _read(path):
    with rasterio.open(path) as src:
        data = src.read()  # (bands, lines, samples)
        return data.transpose(1, 0, 2), src.nodata, src.tags(), src.tags(1)


def _compare(got, want, nodata, expect_nodata):
    """Median and 99th percentile relative error where the output is radiance, and the
    nodata cells exactly those expected."""
    is_nd = got == nodata
    np.testing.assert_array_equal(is_nd, expect_nodata)
    rel = np.abs(got[~is_nd] - want[~is_nd]) / np.abs(want[~is_nd])
    return float(np.median(rel)), float(np.percentile(rel, 99))


def _scene(rng, bands, lines=LINES, samples=SAMPLES, low=300.0, high=1500.0):
    return rng.uniform(low, high, (bands, lines, samples))


# ---------------------------------------------------------------------------- AisaFENIX
FENIX_WL = np.r_[np.arange(880.0, 971.0, 10.0), np.arange(980.0, 1071.0, 10.0)]
N_VNIR = 10


def _fenix(tmp_path, *, tint1=28.0, tint2=8.0, seed=1, **cal_kwargs):
    rng = np.random.default_rng(seed)
    nb = FENIX_WL.size
    gain = rng.uniform(0.5, 1.5, (nb, SAMPLES))
    dark = np.where(np.arange(nb)[:, None] < N_VNIR, 150.0, 1500.0) + rng.uniform(
        0, 50, (nb, SAMPLES)
    )
    tints = np.where(np.arange(nb) < N_VNIR, tint1, tint2)
    radiance = _scene(rng, nb) / 100.0
    dn = np.rint(radiance * tints[:, None, None] / gain[:, None] + dark[:, None])
    dn[3, 5, 7] = 4095  # saturated VNIR (4095 × spatial binning 1)
    dn[15, 9, 11] = 65535  # saturated SWIR
    hdr, _, cube = write_specim_raw(
        tmp_path,
        "fenix",
        dn,
        FENIX_WL,
        fwhm=np.full(nb, 3.0),
        dark=dark,
        dark_lines=DARK_LINES,
        sensorid="350005",
        extra_keys={
            "tint1": f"{tint1}",
            "tint2": f"{tint2}",
            "vimg1": "{1, 10}",
            "vimg2": "{11, 20}",
            "binning": "{1, 1}",
        },
        drop_keys=("tint",),
    )
    cal = write_calibration(
        tmp_path,
        "fenix_cal",
        gain,
        FENIX_WL,
        sensorid=cal_kwargs.pop("sensorid", "350005"),
        binning=cal_kwargs.pop("binning", (1, 1)),
        # A calpack's own tints, which APL ignores: the capture's are used.
        extra_keys={"tint1": "99.0", "tint2": "99.0", "vimg1": "{1, 10}"},
        **cal_kwargs,
    )
    return hdr, cal, cube, gain, tints


def _fenix_expected(cube, gain, tints):
    dark = _refined_dark(cube[LINES:])
    dn = cube[:LINES].astype(np.float64)
    want = (dn - dark) * gain / tints[:, None]
    nodata = np.zeros(dn.shape, bool)
    nodata[:, 0, :2] = True  # frame counter and zero pixel
    nodata[5, 3, 7] = nodata[9, 15, 11] = True  # (line, band, sample) saturated
    return want, nodata


def test_fenix_two_tints_against_formula(tmp_path):
    hdr, cal, cube, gain, tints = _fenix(tmp_path)
    out = str(tmp_path / "radiance.tif")
    result = gb.radiance_file(hdr, cal, output=out)
    got, nodata, tags, band1 = _read(out)
    want, expect_nd = _fenix_expected(cube, gain, tints)
    med, p99 = _compare(got, want, nodata, expect_nd)
    assert med <= 1e-4 and p99 <= 1e-3, (med, p99)
    assert result["bands"] == FENIX_WL.size and result["lines"] == LINES
    assert tags["UNITS"] == "uW cm-2 sr-1 nm-1" and band1["units"] == tags["UNITS"]
    assert float(band1["wavelength"]) == pytest.approx(880.0)
    assert float(band1["fwhm"]) == pytest.approx(3.0)
    assert "tint1 = 28 ms (bands 1–10), tint2 = 8 ms (bands 11–20)" in tags["INTEGRATION_TIME"]
    assert tags["CALIBRATION_FILE"] == os.path.abspath(cal)
    # One tint for both detectors (the calpack's 99 ms, or tint1 everywhere) is wrong by the
    # tint ratio in the SWIR: the test would see it.
    wrong = (cube[:LINES] - _refined_dark(cube[LINES:])) * gain / tints[0]
    assert not np.allclose(
        got[:, N_VNIR:][~expect_nd[:, N_VNIR:]], wrong[:, N_VNIR:][~expect_nd[:, N_VNIR:]], rtol=0.1
    )


def test_ratio_on_radiance_is_numpy_ratio(tmp_path):
    hdr, cal, cube, gain, tints = _fenix(tmp_path, seed=3)
    rad = str(tmp_path / "radiance.tif")
    gb.radiance_file(hdr, cal, output=rad)
    out = str(tmp_path / "ratio.tif")
    r = gb.ratio_file(rad, output=out)
    assert r["swir_wavelength_nm"] == pytest.approx(1010.0)
    assert r["vnir_wavelength_nm"] == pytest.approx(920.0)
    want, nd = _fenix_expected(cube, gain, tints)
    i1010, i920 = int(np.flatnonzero(FENIX_WL == 1010)[0]), int(np.flatnonzero(FENIX_WL == 920)[0])
    expect = want[:, i1010] / want[:, i920]
    with rasterio.open(out) as src:
        ratio = src.read(1)
    ok = ~(nd[:, i1010] | nd[:, i920])
    np.testing.assert_allclose(ratio[ok], expect[ok], rtol=1e-4)
    # In DN the same ratio carries each detector's tint and gain: tint2 / tint1 = 8 / 28.
    dn = cube[:LINES].astype(float) - _refined_dark(cube[LINES:])
    factor = np.broadcast_to(8.0 / 28.0 * gain[i920] / gain[i1010], ok.shape)
    np.testing.assert_allclose((dn[:, i1010] / dn[:, i920])[ok] / ratio[ok], factor[ok], rtol=1e-4)


# ------------------------------------------------------------------------ Eagle and Hawk
EAGLE_WL = np.arange(500.0, 620.0, 10.0)  # 12 bands, binned 2× spectrally


def _smear(signal: np.ndarray, fsc: float) -> np.ndarray:
    """APL's SmearCorrect as its loop reads: band b loses fsc × the sum of the corrected
    bands before it, sample by sample."""
    out = signal.copy()
    lines, bands, samples = out.shape
    for line in range(lines):
        for s in range(samples):
            total = 0.0
            for b in range(1, bands):
                prev = out[line, b - 1, s]
                total += prev if np.isfinite(prev) else 0.0
                out[line, b, s] -= fsc * total
    return out


def test_eagle_smear_bad_pixels_and_binning(tmp_path):
    rng = np.random.default_rng(5)
    nb, ns = EAGLE_WL.size, SAMPLES
    # Calibration at binning 1×1: twice the bands (centres ±1 nm around the binned centre),
    # twice the samples; the capture is binned {2, 2}.
    cal_wl = np.repeat(EAGLE_WL, 2) + np.tile([-1.0, 1.0], nb)
    cal_gain = rng.uniform(2.0, 6.0, (2 * nb, 2 * ns))
    binned = np.zeros((nb, ns))
    for b in range(nb):
        for s in range(ns):
            cell = cal_gain[2 * b : 2 * b + 2, 2 * s : 2 * s + 2]
            binned[b, s] = cell.sum() / (2 * 2) ** 2
    dark = 200.0 + rng.uniform(0, 20, (nb, ns))
    dn = np.rint(_scene(rng, nb, low=1500, high=3000))
    dn[3, 10, 20] = 4095  # saturated: nodata in band 4 and, smeared, every later band
    cal = write_calibration(tmp_path, "eagle", cal_gain, cal_wl, sensorid="100022")
    # Bad cells in the calibration's own grid (Specim's 1-based layout): cell (5, 7) lies in
    # binned band 2, sample 3; cell (0, 63) in band 0, sample 31.
    write_bad(str(tmp_path / "eagle.bad"), [(5, 7), (0, 63)], layout="specim")
    hdr, _, cube = write_specim_raw(
        tmp_path,
        "eagle_raw",
        dn,
        EAGLE_WL,
        dark=dark,
        dark_lines=DARK_LINES,
        sensorid="100022",
        extra_keys={"binning": "{2, 2}", "tint": "10.0"},
    )
    out = str(tmp_path / "rad.tif")
    gb.radiance_file(hdr, cal, output=out)
    got, nodata, tags, _ = _read(out)
    d = _refined_dark(cube[LINES:])
    d[0, :2] = np.nan
    signal = cube[:LINES].astype(np.float64) - d
    fsc = 0.002 / 10.0 * 2  # frame transfer (ms) / tint (ms) × spectral binning
    want = _smear(signal, fsc) * binned / 10.0
    nd = np.zeros(want.shape, bool)
    nd[:, 0, :2] = True
    nd[10, 3:, 20] = True
    nd[:, 2, 3] = nd[:, 0, 31] = True
    med, p99 = _compare(got, want, nodata, nd)
    assert med <= 1e-4 and p99 <= 1e-3, (med, p99)
    assert "fsc = 0.0004" in tags["SMEAR"] and tags["BAD_PIXELS"].startswith("2 from")
    assert tags["BINNING_RATIO"].startswith("2x2")
    # Without the smear correction the values differ well beyond the tolerance.
    plain = signal * binned / 10.0
    ok = ~nd
    assert np.median(np.abs(plain[ok] - want[ok]) / want[ok]) > 1e-3


def test_hawk_arsf_bad_file_and_saturation(tmp_path):
    rng = np.random.default_rng(7)
    wl = np.arange(1000.0, 1120.0, 10.0)
    nb = wl.size
    gain = rng.uniform(1.0, 3.0, (nb, SAMPLES))
    dark = 800.0 + rng.uniform(0, 40, (nb, SAMPLES))
    dn = np.rint(_scene(rng, nb, low=2000, high=9000))
    dn[6, 30, 4] = 16383  # Hawk's 14-bit maximum
    cal = write_calibration(tmp_path, "hawk", gain, wl, sensorid="300011")
    write_bad(str(tmp_path / "hawk.bad"), [(4, 9), (11, 0)], layout="arsf")
    hdr, _, cube = write_specim_raw(
        tmp_path, "hawk_raw", dn, wl, dark=dark, dark_lines=DARK_LINES, sensorid="300011"
    )
    out = str(tmp_path / "rad.tif")
    gb.radiance_file(hdr, cal, output=out)
    got, nodata, tags, _ = _read(out)
    want = (cube[:LINES] - _refined_dark(cube[LINES:])) * gain / 10.0
    nd = np.zeros(want.shape, bool)
    nd[:, 0, :2] = True
    nd[30, 6, 4] = True  # no smear on a Hawk: only the saturated cell
    nd[:, 4, 9] = nd[:, 11, 0] = True
    med, p99 = _compare(got, want, nodata, nd)
    assert med <= 1e-4 and p99 <= 1e-3, (med, p99)
    assert tags["SMEAR"] == "none" and tags["SENSOR"] == "Hawk"


# --------------------------------------------------------------------------------- HySpex
def _hyspex(tmp_path, name, re_first=False):
    rng = np.random.default_rng(11)
    wl = np.arange(900.0, 1060.0, 10.0)
    nb, ns, nl = wl.size, 24, 40
    qe = rng.uniform(0.3, 0.9, nb)
    re = rng.uniform(50.0, 200.0, (nb, ns))
    bg = 100.0 + rng.uniform(0, 10, (nb, ns))
    dn = np.rint(_scene(rng, nb, lines=nl, samples=ns, low=400, high=3000))
    dn[2, 7, 5] = 4095  # 2**(16 - bitshift 4) - 1
    fields = {
        "SF": 1.5,
        "integrationTime": 4000,
        "bitshift": 4,
        "apertureSize": 0.004,
        "pixelSizeX": 2.5e-4,
        "pixelSizeY": 2.5e-4,
    }
    path = write_hyspex(tmp_path, name, dn, wl, bg, qe=qe, re=re, re_first=re_first, fields=fields)
    step = np.append(np.diff(wl), np.diff(wl)[-1])
    gain = (
        constants.h
        * constants.c
        * 1e9
        * 1e6
        * 100.0
        / (
            re
            * qe[:, None]
            * fields["SF"]
            * fields["integrationTime"]
            * np.pi
            * fields["apertureSize"] ** 2
            * fields["pixelSizeX"]
            * fields["pixelSizeY"]
            * step[:, None]
            * wl[:, None]
        )
    )
    want = (dn.transpose(1, 0, 2) - bg) * gain
    nd = np.zeros(want.shape, bool)
    nd[7, 2, 5] = True
    return path, want, nd


@pytest.mark.parametrize("re_first", [False, True])
def test_hyspex_against_hypro_formula(tmp_path, re_first):
    path, want, nd = _hyspex(tmp_path, "line", re_first)
    out = str(tmp_path / "rad.tif")
    gb.radiance_file(path, output=out)
    got, nodata, tags, _ = _read(out)
    med, p99 = _compare(got, want, nodata, nd)
    assert med <= 1e-4 and p99 <= 1e-3, (med, p99)
    assert tags["CALIBRATION_ARRAYS"] == ("RE before QE" if re_first else "QE before RE")


# ----------------------------------------------------------------------------- hostile
def _refused(tmp_path, *words, **kwargs):
    out = tmp_path / "rad.tif"
    with pytest.raises(GeoboresightError) as err:
        gb.radiance_file(output=str(out), **kwargs)
    message = str(err.value)
    assert "\n" not in message and "Traceback" not in message
    for w in words:
        assert w in message, message
    assert not out.exists() and not [p for p in os.listdir(tmp_path) if "tmp" in p]
    return message


def test_calibration_for_another_sensor_is_refused(tmp_path):
    hdr, cal, *_ = _fenix(tmp_path, sensorid="350002")
    _refused(tmp_path, "350002", "350005", input=hdr, calibration=cal)


def test_calibration_at_another_binning_is_refused(tmp_path):
    hdr, cal, *_ = _fenix(tmp_path, binning=(4, 2))
    _refused(tmp_path, "binning", "4", input=hdr, calibration=cal)


def test_wavelengths_not_within_a_band_are_refused(tmp_path):
    hdr, cal, cube, gain, _ = _fenix(tmp_path)
    write_calibration(tmp_path, "shifted", gain, FENIX_WL + 6.0, sensorid="350005", extra_keys={})
    _refused(tmp_path, "band 1", "880.00 nm", input=hdr, calibration=str(tmp_path / "shifted.cal"))


def test_missing_tint_is_refused(tmp_path):
    rng = np.random.default_rng(2)
    wl = np.arange(1000.0, 1120.0, 10.0)
    gain = rng.uniform(1.0, 3.0, (wl.size, SAMPLES))
    cal = write_calibration(tmp_path, "hawk", gain, wl, sensorid="300011")
    hdr, *_ = write_specim_raw(
        tmp_path,
        "hawk_raw",
        _scene(rng, wl.size).round(),
        wl,
        dark=800.0,
        dark_lines=DARK_LINES,
        sensorid="300011",
        drop_keys=("tint",),
    )
    _refused(tmp_path, "'tint'", hdr, input=hdr, calibration=cal)


def test_dark_file_at_another_tint_is_refused(tmp_path):
    rng = np.random.default_rng(4)
    wl = np.arange(1000.0, 1120.0, 10.0)
    gain = rng.uniform(1.0, 3.0, (wl.size, SAMPLES))
    cal = write_calibration(tmp_path, "hawk", gain, wl, sensorid="300011")
    hdr, *_ = write_specim_raw(
        tmp_path, "line", _scene(rng, wl.size).round(), wl, sensorid="300011"
    )
    write_specim_raw(
        tmp_path,
        "DARKREF_line",
        np.full((wl.size, 16, SAMPLES), 800.0),
        wl,
        sensorid="300011",
        extra_keys={"tint": "20.0"},
    )
    _refused(tmp_path, "DARKREF_line.hdr", "20", "10", input=hdr, calibration=cal)


@pytest.mark.parametrize("layout", ["specim", "arsf"])
def test_bad_file_outside_the_image_is_refused(tmp_path, layout):
    hdr, cal, *_ = _fenix(tmp_path)
    write_bad(str(tmp_path / "fenix_cal.bad"), [(2, SAMPLES + 5)], layout=layout)
    _refused(tmp_path, "fenix_cal.bad", "outside", input=hdr, calibration=cal)


def test_truncated_calibration_is_refused(tmp_path):
    hdr, _, cube, gain, _ = _fenix(tmp_path)
    short = write_calibration(
        tmp_path, "short", gain, FENIX_WL, sensorid="350005", truncate_to=1000
    )
    _refused(tmp_path, "truncated", "short.cal", input=hdr, calibration=short)


def test_hyspex_without_calibration_arrays_is_refused(tmp_path):
    wl = np.arange(900.0, 1060.0, 10.0)
    dn = np.full((wl.size, 8, 12), 500.0)
    path = write_hyspex(tmp_path, "bare", dn, wl, np.zeros((wl.size, 12)), calibration=False)
    _refused(tmp_path, "no calibration arrays", input=path)


def test_capture_without_calibration_is_refused(tmp_path):
    hdr, *_ = _fenix(tmp_path)
    _refused(tmp_path, "calibration", input=hdr)


# -------------------------------------------------------------------- radiance on the fly
def _ratio(path):
    with rasterio.open(path) as src:
        return src.read(1), src.nodata


def test_ratio_on_the_fly_equals_ratio_of_radiance(tmp_path):
    hdr, cal, cube, gain, tints = _fenix(tmp_path, seed=8)
    fly = str(tmp_path / "fly.tif")
    gb.ratio_file(hdr, output=fly, layout=gb.DualLayout(vnir_calibration=cal))
    want, nd = _fenix_expected(cube, gain, tints)
    i1010, i920 = 13, 4
    assert FENIX_WL[i1010] == 1010 and FENIX_WL[i920] == 920
    got, nodata = _ratio(fly)
    ok = ~(nd[:, i1010] | nd[:, i920])
    np.testing.assert_allclose(got[ok], (want[:, i1010] / want[:, i920])[ok], rtol=1e-4)
    assert (got[~ok] == nodata).all()  # the frame counter's cells are nodata
    # Without a calibration the same ratio is raw DN (dark, gains and tints in it).
    dn = str(tmp_path / "dn.tif")
    gb.ratio_file(hdr, output=dn)
    raw = cube[:LINES].astype(np.float64)
    dn_ratio = _ratio(dn)[0]
    np.testing.assert_allclose(dn_ratio[ok], (raw[:, i1010] / raw[:, i920])[ok], rtol=1e-5)
    assert np.median(np.abs(dn_ratio[ok] / got[ok] - 1)) > 0.5


def test_radiance_on_the_fly_through_the_command_line(tmp_path):
    from click.testing import CliRunner

    from geoboresight.cli import main

    hdr, cal, cube, gain, tints = _fenix(tmp_path, seed=9)
    out = str(tmp_path / "ratio.tif")
    run = CliRunner().invoke(
        main, ["ratio", "--vnir", hdr, "--vnir-calibration", cal, "--output", out]
    )
    assert run.exit_code == 0, run.output
    want, nd = _fenix_expected(cube, gain, tints)
    got, _ = _ratio(out)
    ok = ~(nd[:, 13] | nd[:, 4])
    np.testing.assert_allclose(got[ok], (want[:, 13] / want[:, 4])[ok], rtol=1e-4)
    info = CliRunner().invoke(main, ["info", "--vnir", hdr, "--vnir-calibration", cal])
    assert info.exit_code == 0, info.output
    assert "uW cm-2 sr-1 nm-1" in info.output
    assert "tint1 = 28 ms" in info.output and "calibration 350005 (match)" in info.output
    plain = CliRunner().invoke(main, ["info", "--vnir", hdr])
    assert "values: DN" in plain.output and "tint2 = 8 ms" in plain.output


def test_info_refuses_a_mismatched_calibration_naming_both(tmp_path):
    from click.testing import CliRunner

    from geoboresight.cli import main

    hdr, cal, *_ = _fenix(tmp_path, sensorid="350002")
    run = CliRunner().invoke(main, ["info", "--vnir", hdr, "--vnir-calibration", cal])
    assert run.exit_code == 1
    line = run.output.strip().splitlines()[-1]
    assert "350002" in line and "350005" in line and "--vnir-calibration" in line


def test_hyspex_on_the_fly_reads_its_own_calibration(tmp_path):
    path, want, nd = _hyspex(tmp_path, "line")
    image, plan = gb.io.radiance.radiance_image(path, path)
    with rasterio.open(image.source) as src:
        got = src.read().transpose(1, 0, 2)
    np.testing.assert_array_equal(~np.isfinite(got), nd)
    np.testing.assert_allclose(got[~nd], want[~nd], rtol=1e-5)


def test_the_report_and_the_ratio_say_dn_or_radiance(tmp_path):
    from geoboresight.report.page import ratio_values

    hdr, cal, *_ = _fenix(tmp_path)
    assert "raw DN" in ratio_values(gb.open_dual(hdr))
    assert "radiances (uW cm-2 sr-1 nm-1)" in ratio_values(gb.open_dual(hdr, vnir_calibration=cal))
    out = str(tmp_path / "ratio.tif")
    gb.ratio_file(hdr, output=out, layout=gb.DualLayout(vnir_calibration=cal))
    with rasterio.open(out) as src:
        assert src.tags()["NUMERATOR_UNITS"] == "uW cm-2 sr-1 nm-1"


def test_envi_bil_output_holds_the_same_radiance(tmp_path):
    hdr, cal, cube, gain, tints = _fenix(tmp_path, seed=12)
    tif, img = str(tmp_path / "rad.tif"), str(tmp_path / "rad.img")
    gb.radiance_file(hdr, cal, output=tif)
    gb.radiance_file(hdr, cal, output=img)
    a, nd_a, *_ = _read(tif)
    b, nd_b, tags, _ = _read(img)
    np.testing.assert_array_equal(a, b)
    assert nd_a == nd_b == -9999
    with rasterio.open(img) as src:
        envi = src.tags(ns="ENVI")
        wl, fwhm = gb.io.read_wavelengths(src)
    np.testing.assert_allclose(wl, FENIX_WL)
    np.testing.assert_allclose(fwhm, 3.0)
    assert envi["units"] == "uW cm-2 sr-1 nm-1" and "tint1: 28 ms" in envi["integration_time"]
    # Read back as a dual-sensor cube: the ratio is the same from either file.
    r1, r2 = str(tmp_path / "r1.tif"), str(tmp_path / "r2.tif")
    gb.ratio_file(tif, output=r1)
    gb.ratio_file(str(tmp_path / "rad.hdr"), output=r2)
    np.testing.assert_array_equal(_ratio(r1)[0], _ratio(r2)[0])


def test_simulated_capture_calibrates_to_the_simulated_radiance(tmp_path):
    """The simulator's raw capture and calibration give back, in µW cm⁻² sr⁻¹ nm⁻¹, the
    radiance its detectors turned into DN: L = 100 · (DN − dark) / (G · r(λ)) with the
    simulator's own gain G, response r and dark offset (1 W m⁻² = 100 µW cm⁻²), within what
    the 64 dark frames' read noise leaves in the dark estimate."""
    from geoboresight.simulate.sensor import SWIR, VNIR

    folder = tmp_path / "scene"
    gb.simulate_file(output=str(folder), lines=24, seed=5, capture=True)
    out = str(tmp_path / "rad.img")
    gb.radiance_file(str(folder / "capture.hdr"), str(folder / "capture_cal.cal"), output=out)
    got, nodata, *_ = _read(out)
    for det, name, first in ((VNIR, "vnir", 0), (SWIR, "swir", 96)):
        with rasterio.open(folder / f"{name}.img") as src:
            dn = src.read().transpose(1, 0, 2).astype(float)
            wl, _ = gb.io.read_wavelengths(src)
        g = det.gain * det.relative_response(wl)
        want = 100.0 * (dn - det.dark_dn) / g[:, None]
        part = got[:, first : first + dn.shape[1]]
        ok = (part != nodata) & (dn < 4095)
        tol = 100.0 * 4 * det.read_noise_dn / np.sqrt(64) / g[:, None]
        assert (np.abs(part - want) <= np.broadcast_to(tol, want.shape))[ok].mean() > 0.999
    ratio = gb.ratio_file(
        str(folder / "capture.hdr"),
        output=str(tmp_path / "r.tif"),
        layout=gb.DualLayout(vnir_calibration=str(folder / "capture_cal.cal")),
    )
    assert ratio["valid_pixels"] > 0


def test_a_calibration_for_a_file_that_is_not_a_raw_capture_is_refused(tmp_path):
    hdr, cal, *_ = _fenix(tmp_path)
    rad = str(tmp_path / "rad.tif")
    gb.radiance_file(hdr, cal, output=rad)
    out = tmp_path / "ratio.tif"
    for layout, words in (
        (gb.DualLayout(vnir_calibration=cal), ("rad.tif", "raw Specim capture or a HySpex")),
        (gb.DualLayout(swir_calibration=cal), ("swir_calibration", "no SWIR file")),
    ):
        with pytest.raises(GeoboresightError) as err:
            gb.ratio_file(rad if "rad.tif" in words else hdr, output=str(out), layout=layout)
        assert all(w in str(err.value) for w in words), str(err.value)
        assert not out.exists()


def test_on_the_fly_without_python_pixel_functions_gives_the_same_ratio(tmp_path, monkeypatch):
    """Where GDAL may not run Python pixel functions, GDAL's own sum and mul read the capture
    as radiance: the same ratio."""
    hdr, cal, *_ = _fenix(tmp_path, seed=14)
    layout = gb.DualLayout(vnir_calibration=cal)
    a, b = str(tmp_path / "a.tif"), str(tmp_path / "b.tif")
    gb.ratio_file(hdr, output=a, layout=layout)
    with open(gb.io.radiance.radiance_image(hdr, cal)[0].source) as f:
        assert "<PixelFunctionLanguage>Python" in f.read()  # the one-level VRT by default
    monkeypatch.setenv("GDAL_VRT_ENABLE_PYTHON", "NO")
    gb.ratio_file(hdr, output=b, layout=layout)
    np.testing.assert_allclose(_ratio(a)[0], _ratio(b)[0], rtol=1e-6)
    with open(gb.io.radiance.radiance_image(hdr, cal)[0].source) as f:
        assert "Python" not in f.read()


@pytest.mark.parametrize("smear", ["auto", "on"])
def test_strip_by_strip_equals_one_strip(tmp_path, smear):
    """The operation streams: strips of 7 lines give the radiance of one 64-line strip (the
    smear runs along the bands of each line, never across lines)."""
    hdr, cal, *_ = _fenix(tmp_path, seed=15)
    a, b = str(tmp_path / "a.img"), str(tmp_path / "b.img")
    gb.radiance_file(hdr, cal, output=a, block_rows=7, smear=smear)
    gb.radiance_file(hdr, cal, output=b, block_rows=LINES, smear=smear)
    np.testing.assert_array_equal(_read(a)[0], _read(b)[0])


def test_a_darkref_file_at_the_captures_tint_gives_the_dark_level(tmp_path):
    """Without dark frames, a DARKREF_<name> capture beside it (hylite's lab convention) at the
    same integration time is the dark level: its mean per band and sample."""
    rng = np.random.default_rng(16)
    wl = np.arange(1000.0, 1120.0, 10.0)
    gain = rng.uniform(1.0, 3.0, (wl.size, SAMPLES))
    cal = write_calibration(tmp_path, "hawk", gain, wl, sensorid="300011")
    dn = np.rint(_scene(rng, wl.size, low=2000, high=6000))
    hdr, _, cube = write_specim_raw(tmp_path, "line", dn, wl, sensorid="300011")
    _, _, ref = write_specim_raw(
        tmp_path,
        "DARKREF_line",
        800.0 + rng.normal(0, 3, (wl.size, 16, SAMPLES)),
        wl,
        sensorid="300011",
    )
    out = str(tmp_path / "rad.tif")
    gb.radiance_file(hdr, cal, output=out)
    got, nodata, tags, _ = _read(out)
    dark = ref.astype(float).mean(axis=0)
    want = (cube.astype(float) - dark) * gain / 10.0
    nd = np.zeros(want.shape, bool)
    nd[:, 0, :2] = True
    med, p99 = _compare(got, want, nodata, nd)
    assert med <= 1e-4 and p99 <= 1e-3, (med, p99)
    assert "DARKREF_line.hdr" in tags["DARK"]
