"""Relative DEM kernels (paper §3.2) on synthetic image pairs with known offset and relief."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from dem_synth import bump, pair, texture
from pykrige.ok import OrdinaryKriging
from scipy import ndimage

from geoboresight import io
from geoboresight.dem.disparity import _warp, disparity_map, disparity_noise
from geoboresight.dem.height import (
    HeightFactor,
    disparity_to_height,
    ground_sample_distance,
    height_factor,
    height_precision,
    parallax_factor,
    zero_lowest,
)
from geoboresight.dem.kriging import (
    LocalKriging,
    cross_validate,
    fit_variogram,
    grid_step,
    krige_grid,
)
from geoboresight.dem.relative import (
    control_points,
    line_statistics,
    match_halo,
    match_strip,
    relative_dem,
    strip_rows,
)
from geoboresight.errors import InputError, ParameterError
from geoboresight.operations._offset import drift_profile, line_offset
from geoboresight.sensor.bands import band_mean
from geoboresight.sensor.coregister import coregister, coregister_halo, profile_to_lines
from geoboresight.sensor.offset import estimate_offset, merged_offset, offset_angles, offset_profile


def fourier_shift(img, shift):
    """``out(x) = img(x − shift)``: a feature at x appears at x + shift (exact, periodic)."""
    ky = np.fft.fftfreq(img.shape[0])[:, None]
    kx = np.fft.fftfreq(img.shape[1])[None]
    return np.fft.ifft2(
        np.fft.fft2(img) * np.exp(-2j * np.pi * (ky * shift[0] + kx * shift[1]))
    ).real


@pytest.fixture(scope="module")
def tex():
    rng = np.random.default_rng(3)
    return ndimage.gaussian_filter(rng.normal(size=(160, 320)), 1.5)


# ------------------------------------------------------------------------------- offset
@pytest.mark.parametrize("shift", [(0.37, -0.21), (2.3, 0.64), (-1.73, 0.05)])
def test_offset_recovers_fourier_shift(tex, shift):
    moved = fourier_shift(tex, shift)
    v, s = tex[16:144, 16:304], moved[16:144, 16:304]
    rng = np.random.default_rng(0)
    s = 0.8 * s + 0.1 + rng.normal(0, 0.02 * s.std(), s.shape)  # other band: gain, bias, noise
    off = estimate_offset(v, s)
    assert off.along == pytest.approx(shift[0], abs=0.03)
    assert off.across == pytest.approx(shift[1], abs=0.03)


def test_offset_ignores_masked_clouds(tex):
    moved = fourier_shift(tex, (1.25, -0.4))
    v, s = tex[16:144, 16:304].copy(), moved[16:144, 16:304].copy()
    valid = np.ones(v.shape, bool)
    valid[40:70, 100:160] = False
    v[~valid], s[~valid] = 50.0, 50.0  # a saturated cloud, identical in both: would pull to 0
    off = estimate_offset(v, s, valid)
    assert off.along == pytest.approx(1.25, abs=0.05)
    assert off.across == pytest.approx(-0.4, abs=0.05)


def test_offset_profile_sees_linear_drift():
    rows, cols = 512, 120
    coef = texture(rows, cols, seed=5)
    r, c = np.mgrid[0:rows, 0:cols].astype(float)
    drift = 0.2 + 0.6 * r / rows  # along-track offset grows along the line
    v = ndimage.map_coordinates(coef, [r + 24, c + 24], prefilter=False)
    s = ndimage.map_coordinates(coef, [r + 24 - drift, c + 24 + 0.3], prefilter=False)
    prof = offset_profile(v, s, block_rows=128)
    expected = 0.2 + 0.6 * prof.rows / rows
    np.testing.assert_allclose(prof.along, expected, atol=0.05)
    np.testing.assert_allclose(prof.across, -0.3, atol=0.05)
    lines = profile_to_lines(prof.rows, prof.along, rows)
    assert lines.shape == (rows,) and lines[0] < lines[-1]


def test_offset_angles_formula():
    ang = offset_angles(2.0, -0.5, ifov_mrad=1.0, flying_height=1500.0)
    assert ang["along_mrad"] == pytest.approx(1e3 * math.atan(2.0 * math.tan(1e-3)))
    assert ang["along_mrad"] == pytest.approx(2.0, rel=1e-5)  # small angles: p · IFOV
    assert ang["across_deg"] == pytest.approx(math.degrees(-0.5e-3), rel=1e-5)
    assert ang["gsd_m"] == pytest.approx(1.5)
    assert ang["along_m"] == pytest.approx(3.0)
    with pytest.raises(ParameterError, match="ifov"):
        offset_angles(1.0, 0.0, ifov_mrad=0.0)


def test_offset_rejects_mismatched_grids(tex):
    with pytest.raises(InputError, match="same pixel grid"):
        estimate_offset(tex, tex[:-1])


# ------------------------------------------------------------------------------- coregister
def test_coregister_undoes_the_offset(tex):
    shift = (1.4, -0.6)
    moved = fourier_shift(tex, shift)
    out, ok = coregister(moved, *shift)
    inner = ok.copy()
    inner[:4], inner[-4:], inner[:, :4], inner[:, -4:] = False, False, False, False
    err = (out - tex)[inner]
    assert np.sqrt(np.mean(err**2)) < 0.02 * tex.std()
    # Pixels that would come from beyond the image are invalid, not extrapolated.
    assert not ok[-1].any() and not ok[:, 0].any()
    # A per-line offset equal to the constant gives the same result.
    out2, ok2 = coregister(moved, np.full(tex.shape[0], shift[0]), np.full(tex.shape[0], shift[1]))
    np.testing.assert_allclose(out2[inner], out[inner], atol=1e-3)


@pytest.mark.parametrize("order", [0, 1, 3])
@pytest.mark.parametrize("shift", [(2, -1), (-3, 0), (0, 4)])
def test_coregister_by_whole_pixels_is_the_slice(tex, order, shift):
    # A whole-pixel offset moves pixels and nothing else: output[r, c] = input[r + a, c + b],
    # as slicing gives it, for every order (an interpolating kernel passes through its
    # samples). The only error allowed is the float32 rounding of the output.
    a, b = shift
    out, ok = coregister(tex, float(a), float(b), order=order)
    rows, cols = tex.shape
    ref = np.full(tex.shape, np.nan)
    ref[max(0, -a) : rows - max(0, a), max(0, -b) : cols - max(0, b)] = tex[
        max(0, a) : rows - max(0, -a), max(0, b) : cols - max(0, -b)
    ]
    assert ok.sum() > 0.8 * ok.size
    assert np.isfinite(ref[ok]).all()  # nothing from beyond the image is called valid
    np.testing.assert_allclose(out[ok], ref[ok].astype(np.float32), rtol=1e-6, atol=0)


def test_coregister_puts_both_lobes_of_a_target_in_one_pixel():
    # A small target seen by the VNIR at (30.3, 40.7) and by the SWIR displaced by the
    # boresight offset (1.37, -0.62) px: both images are the analytic footprint (a Gaussian
    # of σ 1.2 px), so the truth does not come from the resampler. After co-registration the
    # SWIR footprint's centroid is the VNIR's and its peak pixel is the same pixel. Cubic convolution's
    # error on a Gaussian of σ 1.2 px is a few 1e-3 of the peak, which moves the
    # centroid by well under 0.02 px; the test fails by 1.4 px without the shift.
    r, c = np.mgrid[0:64, 0:80].astype(float)
    centre, off = np.array([30.3, 40.7]), np.array([1.37, -0.62])

    def blob(at):
        return np.exp(-((r - at[0]) ** 2 + (c - at[1]) ** 2) / (2 * 1.2**2))

    vnir, swir = blob(centre), blob(centre + off)
    out, ok = coregister(swir, *off)
    out = np.where(ok, out, 0.0)

    def centroid(img):
        return np.array([(img * r).sum(), (img * c).sum()]) / img.sum()

    np.testing.assert_allclose(centroid(out), centroid(vnir), atol=0.02)
    assert np.argmax(out) == np.argmax(vnir)
    assert np.abs(centroid(swir) - centroid(vnir)).max() > 1.0  # the test can fail


def test_coregister_masks_invalid_neighbourhood(tex):
    valid = np.ones(tex.shape, bool)
    valid[50, 60] = False
    out, ok = coregister(tex, 0.5, 0.0, valid)
    assert not ok[49:51, 60].all()
    assert ok[20, 20]


# ------------------------------------------------------------------------------- disparity
@pytest.fixture(scope="module")
def relief_pair():
    h = bump(160, 120)
    v, s, da, dc = pair(160, 120, offset=(0.4, -0.3), dsm=h, noise=3.0)
    return h, v, s, da, dc


def test_disparity_subpixel_accuracy(relief_pair):
    h, v, s, da, dc = relief_pair
    d = disparity_map(v, s, window=11, center=(0.4, -0.3))
    m = d.reliable
    assert m.mean() > 0.8
    err_a = (d.along - da)[m]
    err_c = (d.across - dc)[m]
    assert abs(err_a.mean()) < 0.02
    assert np.sqrt(np.mean(err_a**2)) < 0.08
    assert np.sqrt(np.mean(err_c**2)) < 0.08


def test_refinement_removes_peak_locking(relief_pair):
    h, v, s, da, dc = relief_pair
    rmse = []
    for refine in (0, 2):
        d = disparity_map(v, s, window=11, center=(0, 0), refine=refine)
        rmse.append(np.sqrt(np.nanmean((d.along - da)[d.reliable] ** 2)))
    assert rmse[1] < 0.75 * rmse[0]


def test_disparity_reliability_and_masks():
    v, s, da, dc = pair(120, 100, offset=(1.0, 0.0))
    v[:, 70:], s[:, 70:] = 1000.0, 1000.0  # no texture: nothing to match
    valid = np.ones(v.shape, bool)
    valid[10:40, 10:40] = False  # a cloud
    d = disparity_map(v, s, valid, window=9, center=(1.0, 0.0))
    assert not d.reliable[:, 75:].any()
    assert not d.reliable[10:40, 10:40].any()
    assert d.reliable[60:100, 20:60].mean() > 0.9
    assert np.all(d.peak[d.reliable] >= 0.6)


def test_disparity_peak_beyond_search_range_is_unreliable():
    v, s, da, dc = pair(100, 80, offset=(5.0, 0.0))
    d = disparity_map(v, s, window=9, search_along=3, center=(0.0, 0.0))
    assert d.reliable.mean() < 0.05
    d2 = disparity_map(v, s, window=9, search_along=3, center=(4.0, 0.0))
    assert d2.reliable.mean() > 0.8


def test_disparity_bad_parameters():
    v, s, _, _ = pair(40, 40)
    with pytest.raises(ParameterError, match="window"):
        disparity_map(v, s, window=8)
    with pytest.raises(InputError, match="same pixel grid"):
        disparity_map(v, s[:, :-2])


def test_disparity_noise_estimates_known_sigma():
    rng = np.random.default_rng(0)
    rows, cols, w = 300, 300, 10
    # Independent errors per matching window (blocks of w × w), on a sloping relief.
    block = rng.normal(0, 0.07, (rows // w, cols // w))
    noise = np.kron(block, np.ones((w, w)))
    r, c = np.mgrid[0:rows, 0:cols]
    d = 0.003 * r + 0.002 * c + noise
    est = disparity_noise(d, np.ones(d.shape, bool), spacing=w)
    assert est == pytest.approx(0.07, rel=0.1)


# ------------------------------------------------------------------------------- height
def test_height_factor_from_geometry():
    f = height_factor(1500.0, 1.0, squint_along_deg=2.0)
    assert f.along == pytest.approx(math.tan(math.radians(2.0)) / 1.5)
    assert f.across == 0.0
    # A 30 m building at 1.5 m GSD and tan θ = 0.05 makes one pixel of parallax.
    k = height_factor(1500.0, 1.0, math.degrees(math.atan(0.05))).along
    assert 30.0 * k == pytest.approx(1.0)
    with pytest.raises(ParameterError, match="parallel"):
        HeightFactor(0.0, 0.0).check()
    with pytest.raises(ParameterError, match="flying_height"):
        height_factor(-5.0, 1.0, 2.0)


def test_disparity_to_height_inverts_parallax():
    rng = np.random.default_rng(1)
    h = rng.uniform(0, 30, (20, 20))
    f = HeightFactor(0.02, -0.01)
    got = disparity_to_height(1.3 + f.along * h, -0.2 + f.across * h, f)
    got = zero_lowest(got, np.ones(h.shape, bool), percentile=0.0)
    np.testing.assert_allclose(got, h - h.min(), atol=1e-9)


def test_precision_says_no_dem_from_noise():
    rng = np.random.default_rng(2)
    f = HeightFactor(0.001)  # small squint: 1 mm of disparity per ... 0.001 px per metre
    sigma_d = 0.05
    noise_only = rng.normal(0, sigma_d, (100, 100)) / f.along
    p = height_precision(noise_only, np.ones((100, 100), bool), sigma_d, f)
    assert p.sigma_h_m == pytest.approx(50.0)
    assert not p.meaningful
    assert "no meaningful DEM" in p.message()
    relief = np.tile(np.linspace(0, 300, 100), (100, 1)) + noise_only
    p2 = height_precision(relief, np.ones((100, 100), bool), sigma_d, f)
    assert p2.meaningful


# ------------------------------------------------------------------------------- kriging
@pytest.mark.parametrize("model", ["spherical", "exponential", "gaussian", "linear", "power"])
def test_kriging_equals_pykrige_when_the_neighbourhood_holds_every_point(model):
    """One block, every point in its neighbourhood: PyKrige's global ordinary kriging
    (``exact_values=False``), estimate and variance, on the same points and variogram."""
    rng = np.random.default_rng(0)
    x, y = rng.uniform(0, 80, 60), rng.uniform(0, 50, 60)
    z = 10 * np.sin(x / 12) + 5 * np.cos(y / 9) + rng.normal(0, 0.3, 60)
    vg = fit_variogram(x, y, z, model=model)
    ref = _pykrige(x, y, z, vg)
    np.testing.assert_allclose(ref.variogram_model_parameters, vg.parameters)
    gx, gy = np.arange(80.0), np.arange(50.0)
    z_ref, v_ref = ref.execute("grid", gx, gy)
    kr = LocalKriging(x, y, z, vg, n_closest_points=60, step=1)
    dem, var = kr.grid_rows(0, 50, 80)
    # PyKrige inverts the matrix, we solve: the Gaussian model's matrix is ill-conditioned.
    tol = 1e-3 if model == "gaussian" else 1e-8
    np.testing.assert_allclose(dem, z_ref, atol=tol * 10)
    np.testing.assert_allclose(var, v_ref, atol=tol * 10)
    est, v = kr.points(np.tile(gx, 50), np.repeat(gy, 80))
    np.testing.assert_allclose(est, z_ref.ravel(), atol=tol * 10)
    np.testing.assert_allclose(v, v_ref.ravel(), atol=tol * 10)
    np.testing.assert_allclose(
        vg(np.linspace(0, 100, 7)),
        ref.variogram_function(ref.variogram_model_parameters, np.linspace(0, 100, 7)),
        rtol=1e-12,
    )


@pytest.mark.parametrize("model", ["spherical", "exponential"])
def test_local_kriging_is_as_close_to_pykrige_global_as_its_moving_window(model):
    """1,500 points, local neighbourhoods shared by blocks: within 0.05 m RMS and 1 m at most
    of PyKrige's global kriging (z spans ±15 m), no farther from it than PyKrige's own
    moving window (16 points per pixel), and kriging variances within 1 % (median)."""
    rng = np.random.default_rng(1)
    n = 1500
    x, y = rng.uniform(0, 160, n), rng.uniform(0, 100, n)
    z = 10 * np.sin(x / 12) + 5 * np.cos(y / 9) + rng.normal(0, 0.3, n)
    vg = fit_variogram(x, y, z, model=model)
    ref = _pykrige(x, y, z, vg)
    gx, gy = np.arange(160.0), np.arange(100.0)
    z_glob, v_glob = ref.execute("grid", gx, gy)
    z_mw, _ = ref.execute("grid", gx, gy, n_closest_points=16, backend="C")
    dem, var = krige_grid(x, y, z, (100, 160), vg, n_closest_points=16, step=1, block_rows=30)

    def rms(a):
        return float(np.sqrt(np.mean(np.square(a))))

    assert rms(dem - z_glob) < 0.05
    assert np.abs(dem - z_glob).max() < 1.0
    assert rms(dem - z_glob) <= rms(z_mw - z_glob)
    assert np.median(np.abs(var - v_glob) / v_glob) < 0.01
    truth = 10 * np.sin(gx[None] / 12) + 5 * np.cos(gy[:, None] / 9)
    assert rms(dem - truth) < 0.3
    cv = cross_validate(x, y, z, vg, n_closest_points=16)
    assert cv["rmse_m"] < 1.0 and cv["n"] == 150
    # Held out of the line's own kriging (no second tree): the same validation.
    kr = LocalKriging(x, y, z, vg, n_closest_points=16)
    again = cross_validate(x, y, z, vg, n_closest_points=16, kriging=kr)
    assert again["n"] == 150
    assert again["rmse_m"] == pytest.approx(cv["rmse_m"], rel=0.02)


@pytest.mark.parametrize("block_rows", [7, 33, 100])
def test_kriged_strips_equal_the_whole_grid(block_rows):
    """The grid kriged strip by strip (coarse nodes, blocks cached across strips) is the
    grid kriged at once. On a surface whose range is long, the coarser node grid stays within
    0.5 % RMS (3 % at most) of the relief of every-pixel kriging, and as close to the truth."""
    rng = np.random.default_rng(2)
    x, y = rng.uniform(0, 60, 700), rng.uniform(0, 300, 700)
    z = 20 * np.sin(y / 60) + 10 * np.cos(x / 25) + rng.normal(0, 0.5, 700)
    vg = fit_variogram(x, y, z)
    assert grid_step(vg) > 1  # the range allows a coarser grid
    whole, whole_var = LocalKriging(x, y, z, vg).grid_rows(0, 300, 60)
    kr = LocalKriging(x, y, z, vg)
    parts = [kr.grid_rows(r, min(300, r + block_rows), 60) for r in range(0, 300, block_rows)]
    np.testing.assert_array_equal(np.concatenate([p[0] for p in parts]), whole)
    np.testing.assert_array_equal(np.concatenate([p[1] for p in parts]), whole_var)
    fine, _ = LocalKriging(x, y, z, vg, step=1).grid_rows(0, 300, 60)
    relief = np.ptp(fine)
    assert np.sqrt(np.mean((whole - fine) ** 2)) < 0.005 * relief
    assert np.abs(whole - fine).max() < 0.03 * relief
    truth = 20 * np.sin(np.arange(300.0)[:, None] / 60) + 10 * np.cos(np.arange(60.0)[None] / 25)
    assert np.sqrt(np.mean((whole - truth) ** 2)) <= 1.1 * np.sqrt(np.mean((fine - truth) ** 2))


def test_kriging_respects_mask():
    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, 30, 80), rng.uniform(0, 30, 80)
    z = x + y + rng.normal(0, 0.1, 80)
    vg = fit_variogram(x, y, z, model="linear")
    mask = np.ones((30, 30), bool)
    mask[:5] = False
    dem, var = krige_grid(x, y, z, (30, 30), vg, mask=mask, n_closest_points=8)
    assert np.isnan(dem[:5]).all() and np.isfinite(dem[5:]).all()


def test_variogram_fit_failure_is_clear():
    x = np.arange(50.0)
    with pytest.raises(ParameterError, match="variogram fit failed"):
        fit_variogram(x, x, np.full(50, 3.0))
    with pytest.raises(InputError, match="too few"):
        fit_variogram(x[:5], x[:5], x[:5])


def test_control_points_are_cell_medians():
    h = np.arange(100.0).reshape(10, 10)
    rel = np.ones((10, 10), bool)
    rel[0:5, 0:5] = False
    x, y, z = control_points(h, rel, spacing=5)
    assert len(z) == 3
    i = np.argmin(np.hypot(x - 2, y - 7))
    assert z[i] == pytest.approx(np.median(h[5:10, 0:5]))


# ------------------------------------------------------------------------------- the chain
def test_relative_dem_recovers_relief():
    h = bump(180, 120, relief=30.0)
    v, s, _, _ = pair(180, 120, offset=(0.6, 0.2), dsm=h, k_along=1 / 30, noise=3.0)
    r = relative_dem(v, s, factor=HeightFactor(1 / 30), window=13)
    ok = np.isfinite(r.dem)
    assert ok.all()
    assert np.corrcoef(r.dem[ok], h[ok])[0, 1] > 0.97
    err = r.dem[ok] - h[ok]
    assert np.sqrt(np.mean((err - err.mean()) ** 2)) < 1.5
    assert r.precision.meaningful
    # σ_h = σ_d / k and the estimate is near the measured per-pixel height scatter.
    assert r.precision.sigma_h_m == pytest.approx(r.precision.sigma_d_px * 30.0)
    assert r.cross_validation["rmse_m"] < 2.0


def test_relative_dem_refuses_invisible_relief():
    h = bump(120, 100, relief=30.0)
    k = 0.0008  # a realistic small squint: 30 m → 0.024 px
    v, s, _, _ = pair(120, 100, offset=(0.6, 0.2), dsm=h, k_along=k, noise=20.0)
    with pytest.raises(InputError, match="no meaningful DEM"):
        relative_dem(v, s, factor=HeightFactor(k), window=13)


def test_relative_dem_no_reliable_matches():
    rng = np.random.default_rng(0)
    v = rng.normal(size=(80, 80))
    s = rng.normal(size=(80, 80))  # unrelated images
    with pytest.raises(InputError, match="larger"):
        relative_dem(v, s, factor=HeightFactor(0.05), window=9)


# ------------------------------------------------------------------------------- height factor
def test_parallax_factor_from_k_or_geometry():
    assert parallax_factor(0.05) == HeightFactor(0.05, 0.0)
    assert parallax_factor(0.05, parallax_axis="across", invert_parallax=True) == HeightFactor(
        0.0, -0.05
    )
    k = parallax_factor(squint_deg=2.0, flying_height=1500.0, ifov_mrad=1.0).along
    assert k == height_factor(1500.0, 1.0, 2.0).along
    assert ground_sample_distance(1500.0, 1.0) == pytest.approx(1.5)
    assert ground_sample_distance(None, 1.0) is None
    with pytest.raises(ParameterError, match="squint_deg"):
        parallax_factor(squint_deg=0.0, flying_height=1500.0, ifov_mrad=1.0)
    with pytest.raises(ParameterError, match="height_factor"):
        parallax_factor(-0.03)
    with pytest.raises(ParameterError, match="height_factor.*squint_deg.*flying_height.*ifov_mrad"):
        parallax_factor(squint_deg=2.0)
    with pytest.raises(ParameterError, match="must both be > 0"):
        ground_sample_distance(0.0, 1.0)


# ------------------------------------------------------------------------------- window vs whole
# The kernels that run strip by strip in the file-level operations, against one call on the
# whole array (as xarray-spatial tests its NumPy kernels against their blockwise versions).
def _array_reader(*arrays):
    def read(r0, r1):
        return tuple(a[..., r0:r1, :] for a in arrays)

    return read


def _assemble(parts, shape, dtype):
    out = np.full(shape, np.nan, dtype)
    for win, part in parts:
        out[..., win.row_off : win.row_off + win.height, :] = part
    return out


@pytest.mark.parametrize("block_rows", [1, 7, 40, 97, 500])
def test_band_mean_by_windows_equals_whole(block_rows):
    rng = np.random.default_rng(4)
    stack = rng.normal(1000.0, 50.0, (6, 97, 41)).astype("float32")
    valid = rng.random((97, 41)) > 0.1
    whole, ok = band_mean(stack, valid)
    parts = io.map_windows(
        _array_reader(stack, valid), band_mean, height=97, width=41, block_rows=block_rows
    )
    got = _assemble(((w, m) for w, (m, _) in parts), whole.shape, np.float64)
    np.testing.assert_array_equal(got, whole)
    assert whole.dtype == np.float64
    # The bands added in order, as a hand loop over bands would.
    np.testing.assert_array_equal(whole, sum(b.astype(np.float64) for b in stack) / 6)
    np.testing.assert_array_equal(ok, valid)


@pytest.mark.parametrize(("rows", "block"), [(300, 128), (256, 64), (200, 256), (130, 40)])
def test_drift_profile_by_windows_equals_whole(rows, block):
    """The operation's profile (one block per map_windows strip, the tail block flush with the
    end of the line) is the kernel's offset_profile on the whole image."""
    cols = 100
    coef = texture(rows, cols, seed=5)
    r, c = np.mgrid[0:rows, 0:cols].astype(float)
    drift = 0.2 + 0.6 * r / rows
    v = ndimage.map_coordinates(coef, [r + 24, c + 24], prefilter=False)
    s = ndimage.map_coordinates(coef, [r + 24 - drift, c + 24 + 0.3], prefilter=False)
    valid = np.ones((rows, cols), bool)
    valid[rows // 3 : rows // 3 + 30, 10:90] = False  # a cloud
    valid[-12:] = False  # nodata at the end of the line
    whole = offset_profile(v, s, valid, block_rows=block)
    got = drift_profile(_reader(v, s, valid), block)
    for name in ("rows", "along", "across", "error", "valid_fraction"):
        np.testing.assert_array_equal(getattr(got, name), getattr(whole, name), err_msg=name)
    with pytest.raises(ParameterError, match="at least 8 lines"):
        drift_profile(_reader(v, s, valid), 5)


def _pykrige(x, y, z, vg):
    """PyKrige's OrdinaryKriging with our fitted variogram. Its parameters go in as a dict: a
    list means [sill, range, nugget] to PyKrige, while it reports [psill, range, nugget]."""
    names = {"linear": ("slope", "nugget"), "power": ("scale", "exponent", "nugget")}
    keys = names.get(vg.model, ("psill", "range", "nugget"))
    return OrdinaryKriging(
        x,
        y,
        z,
        variogram_model=vg.model,
        variogram_parameters=dict(zip(keys, vg.parameters, strict=True)),
        exact_values=False,
    )


def _reader(v, s, valid):
    """An in-memory stand-in for io.bands.MatchingReader."""
    return SimpleNamespace(
        height=v.shape[0],
        width=v.shape[1],
        read=lambda r0, r1: (v[r0:r1], s[r0:r1], valid[r0:r1]),
    )


def _coregister_by_strips(band, along, across, valid, order, block_rows):
    """coregister strip by strip, as coregister_file runs it: the halo the shift and the
    kernel reach."""
    height, width = band.shape
    per_line = np.ndim(along) > 0

    def shift(x, ok, *, block):
        lines = slice(block.row0, block.row0 + x.shape[0])
        al, ac = (along[lines], across[lines]) if per_line else (along, across)
        out, out_ok = coregister(x, al, ac, ok, order=order)
        return out[block.inner], out_ok[block.inner]

    halo = coregister_halo(along, order)
    parts = list(
        io.map_windows(
            _array_reader(band, valid),
            shift,
            height=height,
            width=width,
            block_rows=block_rows,
            halo=halo,
            pass_block=True,
        )
    )
    out = _assemble(((w, o) for w, (o, _) in parts), band.shape, np.float32)
    ok = _assemble(((w, k) for w, (_, k) in parts), band.shape, np.float64) > 0
    return out, ok


@pytest.mark.parametrize("order", [1, 3])
@pytest.mark.parametrize("drift", [False, True])
@pytest.mark.parametrize("block_rows", [9, 32, 100])
def test_coregister_by_strips_equals_whole(tex, order, drift, block_rows):
    band = (1000.0 + 200.0 * tex / tex.std()).astype("float32")
    valid = np.ones(band.shape, bool)
    valid[40:52, 100:130] = False
    valid[:, 300:] = False
    rows = band.shape[0]
    if drift:
        along = profile_to_lines(np.array([20.0, 140.0]), np.array([1.3, 2.9]), rows)
        across = np.full(rows, -0.6)
    else:
        along, across = 2.4, -0.6
    whole, ok = coregister(band, along, across, valid, order=order)
    got, got_ok = _coregister_by_strips(band, along, across, valid, order, block_rows)
    np.testing.assert_array_equal(got_ok, ok)
    np.testing.assert_allclose(got[ok], whole[ok], rtol=1e-6)  # float32 rounding at most
    assert ok.sum() > 0.8 * valid.sum()


# ------------------------------------------------------------------------------- streaming
def test_merged_offset_is_estimate_offset_on_one_block_and_recovers_a_long_line(tex):
    """A line of one block: the merged offset is estimate_offset's. A long line: the summed
    block spectra recover the shift, and the operation's block loop (line_offset) gives the
    kernel's merged offset."""
    moved = fourier_shift(tex, (1.25, -0.4))
    v, s = tex[16:144, 16:304], moved[16:144, 16:304]
    valid = np.ones(v.shape, bool)
    valid[40:70, 100:160] = False
    assert merged_offset(v, s, valid) == estimate_offset(v, s, valid)
    rows = 700
    coef = texture(rows, 120, seed=9)
    r, c = np.mgrid[0:rows, 0:120].astype(float)
    v = ndimage.map_coordinates(coef, [r + 24, c + 24], prefilter=False)
    s = ndimage.map_coordinates(coef, [r + 24 - 0.63, c + 24 + 0.31], prefilter=False)
    ok = np.ones(v.shape, bool)
    ok[300:340, 20:90] = False
    off = merged_offset(v, s, ok)
    assert off.along == pytest.approx(0.63, abs=0.03)
    assert off.across == pytest.approx(-0.31, abs=0.03)
    got, prof = line_offset(_reader(v, s, ok), profile_rows=128)
    assert got == off
    whole = offset_profile(v, s, ok, block_rows=128)
    np.testing.assert_array_equal(prof.along, whole.along)


def test_all_valid_warp_shortcut_equals_the_interpolated_validity():
    rng = np.random.default_rng(4)
    b = rng.normal(size=(40, 30))
    coef = ndimage.spline_filter(b, order=3, mode="nearest")
    vb = np.ones(b.shape, bool)
    rows, cols = np.arange(40.0), np.arange(30.0)
    dy = rng.uniform(-2.5, 2.5, (40, 30))
    dx = rng.uniform(-1.5, 1.5, (40, 30))
    fast = _warp(b, coef, vb, rows, cols, dy, dx, all_valid=True)
    slow = _warp(b, coef, vb, rows, cols, dy, dx, all_valid=False)
    np.testing.assert_array_equal(fast[0], slow[0])
    np.testing.assert_array_equal(fast[1], slow[1])
    assert not fast[1].all() and fast[1].any()


@pytest.mark.parametrize("block_rows", [100, 255])
def test_matching_by_strips_equals_the_whole_line(block_rows):
    """match_strip through map_windows with match_halo: the disparity of the whole-array
    call to float32 rounding (the same windows; the box filters' running sums start on other
    lines), the same reliable pixels, and the same line statistics (datum, σ_d, relief,
    control points within 0.05 m)."""
    rows, cols = 700, 120
    h = bump(rows, cols, relief=30.0)
    v, s, _, _ = pair(rows, cols, offset=(0.6, 0.2), dsm=h, k_along=1 / 30, noise=3.0)
    ok = np.ones(v.shape, bool)
    ok[200:230, 20:60] = False
    f = HeightFactor(1 / 30)
    whole = match_strip(v, s, ok, factor=f, center=(0.6, 0.2), window=13)
    halo = match_halo(13, center_along=0.6)
    parts = [
        p
        for _, p in io.map_windows(
            lambda a, b: (v[a:b], s[a:b], ok[a:b]),
            lambda a, b, c, *, block: match_strip(
                a,
                b,
                c,
                factor=f,
                center=(0.6, 0.2),
                rows=block.inner,
                first_line=block.row0,
                line_shape=v.shape,
                window=13,
            ),
            height=rows,
            width=cols,
            block_rows=strip_rows(5, block_rows),
            halo=(halo, halo),
            pass_block=True,
        )
    ]
    along = np.concatenate([p.disparity.along for p in parts])
    reliable = np.concatenate([p.disparity.reliable for p in parts])
    np.testing.assert_array_equal(reliable, whole.disparity.reliable)
    np.testing.assert_allclose(along, whole.disparity.along, atol=1e-6)
    a = line_statistics(parts, factor=f, window=13)
    b = line_statistics([whole], factor=f, window=13)
    assert a.datum == pytest.approx(b.datum, abs=0.05)
    assert a.precision.sigma_d_px == pytest.approx(b.precision.sigma_d_px, rel=1e-3)
    assert a.precision.relief_m == pytest.approx(b.precision.relief_m, rel=1e-3)
    assert a.reliable == b.reliable and a.points[0].size == b.points[0].size
    np.testing.assert_allclose(a.points[2], b.points[2], atol=0.05)
    # σ_d from the kernel of the whole image (disparity_noise) is the merged one.
    d_par = whole.disparity.along  # factor along-track only
    assert b.precision.sigma_d_px == pytest.approx(
        disparity_noise(d_par, whole.disparity.reliable, spacing=13), rel=1e-8
    )


def test_sampled_statistics_stay_close_to_the_exact_ones():
    """Above SAMPLE_SIZE values, a regular lattice of the heights and second differences:
    here a sample of ~1/7 gives the datum within 0.2 m, σ_d and the relief within 3 %."""
    rows, cols = 400, 120
    h = bump(rows, cols, relief=30.0)
    v, s, _, _ = pair(rows, cols, offset=(0.6, 0.2), dsm=h, k_along=1 / 30, noise=3.0)
    f = HeightFactor(1 / 30)
    exact = match_strip(v, s, factor=f, center=(0.6, 0.2), window=13)
    sample = match_strip(v, s, factor=f, center=(0.6, 0.2), window=13, sample_size=7000)
    assert sample.heights.size < exact.heights.size / 5
    a = line_statistics([exact], factor=f, window=13)
    b = line_statistics([sample], factor=f, window=13)
    assert b.datum == pytest.approx(a.datum, abs=0.2)
    assert b.precision.sigma_d_px == pytest.approx(a.precision.sigma_d_px, rel=0.03)
    assert b.precision.relief_m == pytest.approx(a.precision.relief_m, rel=0.03)
    assert b.precision.meaningful == a.precision.meaningful


@pytest.mark.parametrize("model", ["spherical", "exponential", "gaussian", "linear", "power"])
def test_variogram_fit_equals_pykrige_on_a_square_field(model):
    # On a square field the lag classes are PyKrige's own, so the fit is PyKrige's.
    rng = np.random.default_rng(11)
    x, y = rng.uniform(0, 300, 600), rng.uniform(0, 280, 600)
    z = 5 * np.sin(x / 40) + 3 * np.cos(y / 55) + rng.normal(0, 0.5, 600)
    ours = fit_variogram(x, y, z, model=model)
    ref = OrdinaryKriging(x, y, z, variogram_model=model, nlags=20, weight=True)
    # Both are SciPy's least_squares (soft-L1) from the same start on the same classes, which
    # stops when the cost changes by less than ftol = 1e-8 of itself: the two minima agree to
    # that in cost, and to about sqrt(ftol) = 1e-4 in parameters along flat directions (the
    # classes differ in their last bits, so the iterations do too). A nugget of ~1e-39
    # compares absolutely.
    from pykrige.core import _variogram_residuals

    function = OrdinaryKriging.variogram_dict[model]

    def cost(params):
        r = _variogram_residuals(np.asarray(params), ref.lags, ref.semivariance, function, True)
        return float(np.sum(2.0 * (np.sqrt(1.0 + r**2) - 1.0)))  # soft-L1, as least_squares

    assert cost(ours.parameters) == pytest.approx(cost(ref.variogram_model_parameters), rel=1e-7)
    scale = max(abs(v) for v in ours.parameters)
    np.testing.assert_allclose(
        ours.parameters, ref.variogram_model_parameters, rtol=1e-4, atol=1e-7 * scale
    )
    from geoboresight.dem.kriging import experimental_variogram

    lags, semi = experimental_variogram(x, y, z, 20)
    np.testing.assert_allclose(lags, ref.lags, rtol=1e-12)
    np.testing.assert_allclose(semi, ref.semivariance, rtol=1e-12)


def test_variogram_of_a_long_strip_finds_the_relief_range():
    # A 300 × 30,000 px strip of a Gaussian random field with a spherical-like range of about
    # 120 px (smoothed white noise) plus a 1 m nugget. PyKrige's 20 classes from 0 to the
    # largest distance are 1,500 px wide: its fit is nearly all nugget. Capped lags find the
    # range and a partial sill that dominates the nugget.
    from scipy import ndimage

    rng = np.random.default_rng(5)
    field = ndimage.gaussian_filter(rng.normal(size=(30_000, 300)), 40, mode="wrap")
    field *= 4.0 / field.std()
    n = 20_000
    yi, xi = rng.integers(0, 30_000, n), rng.integers(0, 300, n)
    z = field[yi, xi] + rng.normal(0, 1.0, n)
    x, y = xi.astype(float), yi.astype(float)
    ours = fit_variogram(x, y, z)
    psill, rng_px, nugget = ours.parameters
    # Sill = field variance 16 + noise 1; the smooth field's variogram rises slowly near 0,
    # so the spherical model may put the 1 m² noise into its rise rather than a nugget.
    assert 60 < rng_px < 300 and psill > 5 * nugget
    assert psill + nugget == pytest.approx(17.0, rel=0.3)
    ref = OrdinaryKriging(x[:2000], y[:2000], z[:2000], variogram_model="spherical", nlags=20)
    ref_psill, _, ref_nugget = ref.variogram_model_parameters
    assert ref_psill < ref_nugget  # the failure the cap removes


def test_variogram_nugget_floor_filters_correlated_matching_noise():
    # Matched heights carry noise correlated over the matching window, which the short lags
    # hide: the free fit may put the nugget near 0 and krige the noise. With the known noise
    # variance as a floor the nugget is at least that, and the DEM is never farther from the
    # truth (seeds 0-3; on one of them the free fit's nugget is 0.9 for a noise of 6.25).
    from scipy import ndimage

    worse, better = 0, 0
    for seed in range(4):
        rng = np.random.default_rng(seed)
        h, w = 400, 300
        truth = ndimage.gaussian_filter(rng.normal(size=(h, w)), 25)
        truth *= 6 / truth.std()
        noise = ndimage.uniform_filter(rng.normal(size=(h, w)), 15)
        noise *= 2.5 / noise.std()
        yy, xx = np.mgrid[0:h:4, 0:w:4]
        x, y, z = xx.ravel() * 1.0, yy.ravel() * 1.0, (truth + noise)[yy, xx].ravel()
        rmse = []
        for floor in (0.0, 2.5**2):
            vg = fit_variogram(x, y, z, min_nugget=floor)
            assert vg.parameters[2] >= floor * (1 - 1e-9)
            dem, _ = LocalKriging(x, y, z, vg).grid_rows(0, h, w)
            rmse.append(np.sqrt(np.mean((dem - truth) ** 2)))
        worse += rmse[1] > rmse[0] * 1.001
        better += rmse[1] < rmse[0] * 0.95
    assert worse == 0 and better >= 1


def test_variogram_nugget_floor_unknown_noise_sets_no_floor():
    # σ_h cannot always be estimated (NaN): the fit is then the free one, not an error.
    rng = np.random.default_rng(0)
    x, y = rng.uniform(0, 100, 200), rng.uniform(0, 100, 200)
    z = np.sin(x / 15) * 5 + rng.normal(0, 0.3, 200)
    free = fit_variogram(x, y, z)
    assert fit_variogram(x, y, z, min_nugget=float("nan")).parameters == free.parameters


# ------------------------------------------------------------------- co-registration kernel
@pytest.mark.parametrize("shift", [(1.3, -0.7), (2.0, 0.25), (-0.5, 0.0), (0.35, 1.8)])
def test_cubic_convolution_is_gdals_cubic(tex, shift):
    """Keys' cubic convolution (a = −1/2) is GDAL's cubic resampling: a same-size warp onto a
    grid translated by the offset gives the same values away from the image's edges (GDAL
    treats a kernel cut by the edge its own way), to float32 rounding."""
    from rasterio.transform import Affine
    from rasterio.warp import Resampling, reproject

    img = (1000.0 + 100.0 * tex / tex.std()).astype(np.float32)
    along, across = shift
    out, ok = coregister(img, along, across, order=3)
    ref = np.zeros_like(img)
    reproject(
        img,
        ref,
        src_transform=Affine.identity(),
        dst_transform=Affine.translation(across, along),
        src_crs="EPSG:3857",
        dst_crs="EPSG:3857",
        resampling=Resampling.cubic,
    )
    inner = np.zeros(ok.shape, bool)
    inner[5:-5, 5:-5] = True
    assert (ok & inner).sum() > 0.9 * inner.sum()
    np.testing.assert_allclose(out[ok & inner], ref[ok & inner], rtol=0, atol=1e-3)


@pytest.mark.parametrize("order", [1, 3])
def test_cubic_and_linear_reproduce_their_polynomials(order):
    """Linear interpolation reproduces a plane, Keys' cubic convolution a quadratic (its
    third-order accuracy, Keys 1981): exact values at the shifted positions."""
    r, c = np.mgrid[0:40, 0:50].astype(np.float64)
    along, across = 0.37, -1.62

    def field(r, c):
        plane = 3.0 * r - 2.0 * c + 50.0
        return plane + (0.05 * (r - 20) ** 2 - 0.03 * (r - 20) * (c - 25) if order == 3 else 0)

    out, ok = coregister(field(r, c), along, across, order=order)
    assert ok.sum() > 0.85 * ok.size
    np.testing.assert_allclose(out[ok], field(r + along, c + across)[ok], atol=2e-3)


@pytest.mark.parametrize("order", [0, 1, 3])
def test_coregister_stack_is_each_band_alone_and_one_mask(tex, order):
    """A stack shifted at once gives each band what the one-band kernel gives it, from the
    file's own integer type, with one valid mask; a per-line offset equal to the constant
    gives the same (the drift path)."""
    from geoboresight.sensor.coregister import coregister_stack

    # More bands and lines than one group and chunk of the kernel, neither a multiple of them.
    stack = np.stack([tex * (1 + 0.1 * i) + 3000 for i in range(37)]).astype(np.uint16)
    valid = np.ones(tex.shape, bool)
    valid[30:33, 40:45] = False
    out, ok = coregister_stack(stack, 1.45, -0.3, valid, order=order)
    assert out.dtype == np.float32 and ok.shape == tex.shape
    for i in range(37):
        one, one_ok = coregister(stack[i], 1.45, -0.3, valid, order=order)
        np.testing.assert_array_equal(one_ok, ok)
        # The same taps; BLAS may add a product's four terms in another order for a matrix of
        # another shape (seen with NumPy 1.26's OpenBLAS on one CPU): float32 rounding apart.
        np.testing.assert_array_max_ulp(out[i][ok], one[ok], maxulp=2)
    rows = tex.shape[0]
    # A profile whose values vary by 1e-12 takes the per-line path.
    wobble = np.full(rows, 1.45) + np.r_[1e-12, np.zeros(rows - 1)]
    drift, d_ok = coregister_stack(stack, wobble, np.full(rows, -0.3), valid, order=order)
    np.testing.assert_array_equal(d_ok[1:], ok[1:])
    np.testing.assert_allclose(drift[:, 1:][:, ok[1:]], out[:, 1:][:, ok[1:]], rtol=1e-5)
    # The hole and the image's edge are invalid, nothing else near them is kept by luck.
    assert not ok[28:34, 38:46].all() and not ok[-1].any()


def test_coregister_refuses_an_order_it_has_not_and_a_profile_of_another_length(tex):
    with pytest.raises(ParameterError, match="'order'"):
        coregister(tex, 0.5, 0.5, order=2)
    with pytest.raises(InputError, match="along-track offset has 3 values"):
        coregister(tex, np.zeros(3), 0.0)


def test_refinement_warps_are_scipys_cubic_spline(tex):
    """The refinement's warps (one set of B-spline weights, 16 gathered coefficients per
    shift) are ``map_coordinates(order=3, mode="nearest")`` on the coefficients, edges
    included, for a per-pixel base and every integer shift around it."""
    from geoboresight.dem.disparity import _warps

    b = 1000.0 + 100.0 * tex / tex.std()
    coef = ndimage.spline_filter(b, order=3, mode="nearest")
    rows = np.arange(-4, b.shape[0] + 4, dtype=float)
    cols = np.arange(b.shape[1], dtype=float)
    base_a = 0.7 + 0.4 * np.sin(rows[:, None] / 9.0) + 0 * cols
    base_c = -0.3 + 0.3 * np.cos(cols[None, :] / 7.0) + 0 * rows[:, None]
    shifts = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
    got = _warps(coef, np.ones(b.shape, bool), rows, cols, base_a, base_c, shifts, True)
    for dy, dx in shifts:
        r, c = np.broadcast_arrays(rows[:, None] + base_a + dy, cols[None, :] + base_c + dx)
        ref = ndimage.map_coordinates(coef, [r, c], order=3, mode="nearest", prefilter=False)
        np.testing.assert_allclose(got[(dy, dx)][0], ref, rtol=1e-12, atol=1e-9)


def test_memory_is_given_back_once_the_arenas_hold_more_than_the_bound(monkeypatch):
    """release_memory trims glibc's arenas only when their free memory passes ``retain``
    (a trim after every strip made the next strip page-fault its temporaries in again)."""
    from geoboresight.operations import dem as dem_op

    calls, free = [], [0]
    monkeypatch.setattr(dem_op, "_LIBC", (calls.append, lambda: free[0]))
    free[0] = dem_op.RETAIN_FREE - 1
    dem_op.release_memory()
    assert calls == []
    free[0] = dem_op.RETAIN_FREE + 1
    dem_op.release_memory()
    assert calls == [0]
    # Without mallinfo2 (glibc < 2.33) every call trims, as before.
    monkeypatch.setattr(dem_op, "_LIBC", (calls.append, None))
    dem_op.release_memory()
    assert calls == [0, 0]
    # On this machine's C library the real functions are found (or none at all).
    monkeypatch.setattr(dem_op, "_LIBC", None)
    dem_op.release_memory()
    assert dem_op._LIBC is False or callable(dem_op._LIBC[0])
