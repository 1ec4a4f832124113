"""De-shadowing with a surface model: the sky-view factor, pairs chosen by the sun's
azimuth and by height, a ratio per pixel from its sky view.

Independent truth: analytic sky-view factors (flat ground, a long trench) and synthetic
cubes written from L = ρ·(E_dir·(1 − f) + V·E_sky) with a known V per pixel, a known
E_dir/E_sky per band and roofs of another material, which the estimate never sees.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from geoboresight.errors import ParameterError
from geoboresight.shadow import deshadow as ds
from geoboresight.shadow import illumination as ill
from geoboresight.shadow import skyview

SUN = dict(sun_zenith=40.0, sun_azimuth=180.0)  # sun in the south: shadows fall north (up)


def test_sky_view_of_flat_ground_is_one():
    v = skyview.sky_view_factor(np.zeros((40, 50)), cell_size=1.0)
    assert np.allclose(v, 1.0)
    # Height noise below the clearance hides no sky.
    z = np.random.default_rng(0).normal(0, 0.3, (60, 60))
    assert skyview.sky_view_factor(z, cell_size=1.0, clearance=1.0).mean() > 0.99


@pytest.mark.parametrize("half, depth", [(6, 5.0), (11, 10.0), (4, 10.0)])
def test_sky_view_of_a_long_trench_is_the_analytic_value(half, depth):
    # Walls' first cells at ±half from the trench's middle line, rising `depth`: the 2-D view
    # factor of the opening from the middle is half/√(half² + depth²) (the 3-D horizon
    # integral mean cos² h(φ), h = atan(depth·|sin φ|/half), gives the same). 16 azimuths
    # integrate 1/(1 + a² sin² φ) to within 1.5 % for these shapes (checked by the sum).
    z = np.full((201, 120), depth)
    z[100 - half + 1 : 100 + half, :] = 0.0
    v = skyview.sky_view_factor(z, cell_size=1.0, radius=300.0)[100, 60]
    exact = half / math.hypot(half, depth)
    assert v == pytest.approx(exact, rel=0.015)
    # Not the flat value: the test can fail.
    assert v < 0.9


def test_sky_view_rejects_bad_parameters():
    with pytest.raises(ParameterError, match="radius"):
        skyview.sky_view_factor(np.zeros((5, 5)), cell_size=1.0, radius=0)
    with pytest.raises(ParameterError, match="directions"):
        skyview.sky_view_factor(np.zeros((5, 5)), cell_size=1.0, directions=2)


def _town(rows=70, cols=80):
    z = np.zeros((rows, cols))
    z[40:50, 10:30] = 8.0
    z[40:50, 45:65] = 5.0
    f = ill.shadow_fraction(z, **SUN, cell_size=1.0, supersample=4).astype(float)
    return z, f


def test_pairs_up_sun_of_the_shadow_are_dropped():
    z, f = _town()
    drow, dcol, _ = ill.sun_step(SUN["sun_zenith"], SUN["sun_azimuth"], ill.grid_matrix(None, 1))
    assert drow > 0  # the sun is down the image (south)
    a, b = ds.pair_indices(f, toward_sun=(drow, dcol))
    a0, b0 = ds.pair_indices(f)
    cols = f.shape[1]
    # Every kept pair's sunlit pixel is not within 60° of the sun's direction.
    dy, dx = b // cols - a // cols, b % cols - a % cols
    cos = (dy * drow + dx * dcol) / np.hypot(dy, dx) / math.hypot(drow, dcol)
    assert len(a) > 20 and (cos < math.cos(math.radians(ds.UP_SUN_DEG)) + 1e-9).all()
    # Without the azimuth, roof pixels (up-sun: the casters) are among the sunlit ones.
    assert (z.reshape(-1)[b0] > 0).any()
    assert not (z.reshape(-1)[b] > 0).any()
    # With heights, no pair joins ground to roof either.
    a2, b2 = ds.pair_indices(f, heights=z)
    assert len(a2) and (z.reshape(-1)[a2] == z.reshape(-1)[b2]).all()


def _lit(rows=70, cols=80, nb=8, seed=3):
    """(cube, sunlit truth, f, V, z, E_dir/E_sky): L = ρ(E_dir(1 − f) + V·E_sky), E_sky = 1,
    V of the blocks from sky_view_factor (checked against the analytic trench above)."""
    rng = np.random.default_rng(seed)
    z, f = _town(rows, cols)
    v = skyview.sky_view_factor(z, cell_size=1.0)
    r = np.linspace(2.0, 20.0, nb)  # E_dir/E_sky: blue to SWIR
    rho = np.empty((nb, rows, cols))
    left = np.zeros((rows, cols), bool)
    left[:, : cols // 2] = True
    rho[:, left] = np.linspace(0.1, 0.4, nb)[:, None]
    rho[:, ~left] = np.linspace(0.3, 0.05, nb)[:, None]
    rho[:, z > 0] = np.linspace(0.05, 0.07, nb)[:, None]  # roofs: another material
    rho *= 1 + 0.02 * rng.standard_normal((1, rows, cols))
    light = r[:, None, None] * (1 - f)[None] + v[None]
    sun = r[:, None, None] + v[None]
    return rho * light, rho * sun, f, v, z, r


def test_deshadow_with_sky_view_recovers_the_sunlit_signal():
    cube, sunlit, f, v, z, r = _lit()
    drow, dcol, _ = ill.sun_step(SUN["sun_zenith"], SUN["sun_azimuth"], ill.grid_matrix(None, 1))
    ia, ib = ds.pair_indices(f, toward_sun=(drow, dcol), heights=z)
    flat = cube.reshape(cube.shape[0], -1)
    vf = v.reshape(-1)
    k, n, spread = ds.illumination_ratio(
        flat[:, ia].T, flat[:, ib].T, sky_view=(vf[ia], vf[ib]), keep=ds.KEEP_WITH_SURFACE
    )
    # The open-ground ratio k = 1 + E_dir/E_sky: within 3 % (the pairs' albedos differ by
    # 2 % noise each; their median is much closer).
    assert np.allclose(k, 1 + r, rtol=0.03)
    out = ds.deshadow(cube, f, ratio=k, sky_view=v)
    full = (f >= 0.999) & (z == 0)
    err = np.abs(out[:, full] / sunlit[:, full] - 1)
    # Each pixel to its own sunlit value: 2 % noise in ρ, the ratio within 3 %.
    assert np.median(err) < 0.03 and np.percentile(err, 95) < 0.08
    # Lit pixels are left as they are.
    lit = f == 0
    assert np.allclose(out[:, lit], cube[:, lit], rtol=1e-6)
    # Without the sky-view factor (one ratio for all) the shadow near the walls (V < 0.9) is
    # under-corrected: the test can fail.
    naive = ds.deshadow(cube, f, ratio=1 + r)
    low_v = full & (v < 0.9)
    assert low_v.sum() > 10
    assert np.median(np.abs(naive[:, low_v] / sunlit[:, low_v] - 1)) > 0.08
    # Without the geometry, pairs of the roofs (another material) enter the consensus.
    a0, b0 = ds.pair_indices(f)
    assert (z.reshape(-1)[b0] > 0).sum() > 0.05 * len(b0)
