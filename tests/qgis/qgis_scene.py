"""The small dual-sensor scene every QGIS test runs on.

The simulator's scene (geoboresight.simulate, with its truth files) when it exists; otherwise a
random ENVI pair with wavelengths written by the I/O layer, enough for the ratio and statistics.
"""

from __future__ import annotations

import os

import numpy as np

LINES = 48


def make_scene(folder: str) -> dict:
    """Write the scene into ``folder``; a dict of its files (vnir, swir, truth_*, ...)."""
    try:
        from geoboresight.io.scene import write_scene
        from geoboresight.simulate import simulate_scene
    except ImportError:
        return _random_scene(folder)
    scene = simulate_scene(preset="mixed", lines=LINES, seed=3)
    folder = os.path.join(folder, "sim")
    write_scene(scene, folder)
    files = {}
    for name in sorted(os.listdir(folder)):
        stem, ext = os.path.splitext(name)
        if ext in (".hdr", ".xml"):
            continue
        files.setdefault(stem, os.path.join(folder, name))
    return files


def _random_scene(folder: str) -> dict:
    from geoboresight.io import write_envi

    rng = np.random.default_rng(7)
    vnir_wl = np.linspace(400.0, 970.0, 12)
    swir_wl = 980.0 + 30.0 * np.arange(20)
    shape = (LINES, 40)
    vnir = rng.integers(200, 4000, (len(vnir_wl), *shape)).astype("uint16")
    swir = rng.integers(200, 4000, (len(swir_wl), *shape)).astype("uint16")
    files = {
        "vnir": write_envi(os.path.join(folder, "vnir.img"), vnir, vnir_wl),
        "swir": write_envi(os.path.join(folder, "swir.img"), swir, swir_wl),
    }
    return files
