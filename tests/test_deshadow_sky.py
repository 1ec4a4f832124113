"""De-shadowing with a surface model: the sky-view factor.

Independent truth: analytic sky-view factors (flat ground, a long trench) and synthetic
cubes written from L = ρ·(E_dir·(1 − f) + V·E_sky) with a known V per pixel, a known
E_dir/E_sky per band and roofs of another material, which the estimate never sees.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from geoboresight.errors import ParameterError
from geoboresight.shadow import illumination as ill

SUN = dict(sun_zenith=40.0, sun_azimuth=180.0)  # sun in the south: shadows fall north (up)


def test_sky_view_of_flat_ground_is_one():
    v = ill.sky_view_factor(np.zeros((40, 50)), cell_size=1.0)
    assert np.allclose(v, 1.0)
    # Height noise below the clearance hides no sky.
    z = np.random.default_rng(0).normal(0, 0.3, (60, 60))
    assert ill.sky_view_factor(z, cell_size=1.0, clearance=1.0).mean() > 0.99


@pytest.mark.parametrize("half, depth", [(6, 5.0), (11, 10.0), (4, 10.0)])
def test_sky_view_of_a_long_trench_is_the_analytic_value(half, depth):
    # Walls' first cells at ±half from the trench's middle line, rising `depth`: the 2-D view
    # factor of the opening from the middle is half/√(half² + depth²) (the 3-D horizon
    # integral mean cos² h(φ), h = atan(depth·|sin φ|/half), gives the same). 16 azimuths
    # integrate 1/(1 + a² sin² φ) to within 1.5 % for these shapes (checked by the sum).
    z = np.full((201, 120), depth)
    z[100 - half + 1 : 100 + half, :] = 0.0
    v = ill.sky_view_factor(z, cell_size=1.0, radius=300.0)[100, 60]
    exact = half / math.hypot(half, depth)
    assert v == pytest.approx(exact, rel=0.015)
    # Not the flat value: the test can fail.
    assert v < 0.9


def test_sky_view_rejects_bad_parameters():
    with pytest.raises(ParameterError, match="radius"):
        ill.sky_view_factor(np.zeros((5, 5)), cell_size=1.0, radius=0)
    with pytest.raises(ParameterError, match="directions"):
        ill.sky_view_factor(np.zeros((5, 5)), cell_size=1.0, directions=2)
