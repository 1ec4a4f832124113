"""shadow.blocks.shadow_map_block: the shadow map's per-pixel pipeline on a block of lines; read
in strips with shadow_map_halo lines around, it gives what the whole image gives."""

from __future__ import annotations

import numpy as np
import pytest

from geoboresight.io.windows import map_windows
from geoboresight.sensor.dark import DarkLevels
from geoboresight.shadow import blocks, darkness
from geoboresight.shadow.classes import MASK_SHADOW, NODATA_CLASS, default_table


def scene(rows=60, cols=40, seed=1):
    rng = np.random.default_rng(seed)
    lit = np.ones((rows, cols))
    lit[20:35, 10:25] = 0.08  # a shadow
    lit[40:50, 5:12] = 0.5  # half shade
    dark = 100.0
    blue = dark + 300 * (0.3 + 0.7 * lit) + rng.normal(0, 2, (3, rows, cols))
    nir = dark + 1000 * lit + rng.normal(0, 5, (4, rows, cols))
    swir = dark + 800 * np.roll(lit, 1, axis=0) + rng.normal(0, 5, (2, rows, cols))
    valid = np.ones((rows, cols), bool)
    valid[:, -1] = False
    return blue, nir, swir, valid


@pytest.mark.parametrize("edge_pixels", [0, 2])
def test_strips_with_the_halo_equal_the_whole_image(edge_pixels):
    blue, nir, swir, valid = scene()
    sig = [darkness.signal(x, 100.0).ravel() for x in (blue, nir, swir)]
    cal = darkness.calibrate_shadow_map(
        *sig,
        np.ones_like(sig[0]),
        valid.ravel(),
        dark=DarkLevels(100.0, 100.0),
        table=default_table(),
        offset=(1.0, 0.0),
    )
    kw = dict(calibration=cal, dark_levels=(100.0, 100.0, 100.0), edge_pixels=edge_pixels)
    c, m = blocks.shadow_map_block(blue, nir, swir, valid, **kw)
    assert (m[25:30, 14:20] == MASK_SHADOW).all() and (m[3:10, :-1] == 0).all()
    assert (c[:, -1] == NODATA_CLASS).all() and set(np.unique(c)) > {0, NODATA_CLASS}
    stack = np.concatenate([blue, nir, swir])

    def read(r0, r1):
        return stack[:, r0:r1], valid[r0:r1]

    def kernel(x, ok):
        return blocks.shadow_map_block(x[:3], x[3:7], x[7:], ok, **kw)

    halo = blocks.shadow_map_halo(cal, edge_pixels)
    got_c, got_m = np.zeros_like(c), np.zeros_like(m)
    for win, (cc, mm) in map_windows(
        read, kernel, height=60, width=40, block_rows=7, halo=(halo, halo)
    ):
        got_c[win.row_off : win.row_off + win.height] = cc
        got_m[win.row_off : win.row_off + win.height] = mm
    np.testing.assert_array_equal(got_c, c)
    np.testing.assert_array_equal(got_m, m)
