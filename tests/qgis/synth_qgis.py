"""A small raw VNIR/SWIR pair for the overlay tests (library-made, no provider)."""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from synth import SWIR_WL, VNIR_WL, cube, write_envi  # noqa: E402


def raw_pair(folder):
    vn, sw = cube(len(VNIR_WL), 40, 30, seed=1), cube(len(SWIR_WL), 40, 30, seed=2)
    v = write_envi(os.path.join(folder, "v.img"), vn, VNIR_WL)
    s = write_envi(os.path.join(folder, "s.img"), sw, SWIR_WL)
    return v, s, vn, sw
