"""The sample line's flight files: what an aircraft writes (SBET, line times, sensor models,
a DEM and the true boresight angles), simulated by :mod:`geoboresight.simulate.flight` and
written by :mod:`geoboresight.io.navigation` (the recipe of ``sample_data/scene/flight``)."""

from __future__ import annotations

import json
import os

import numpy as np
import rasterio
from rasterio.transform import Affine

from ..io.navigation import write_line_times, write_sbet, write_sensor_model_csv
from ..simulate.flight import (
    SAMPLE_FLIGHT,
    TRUE_BORESIGHT,
    TRUE_LEVER_ARM,
    Flight,
    relief_dem,
    sensor_models,
)


def write_flight(folder, *, lines=192, samples=286, line_rate=40.0, nav_rate=100.0) -> dict:
    """Write what the aircraft writes for a line of ``lines`` × ``samples`` pixels into
    ``folder``: ``flight.out`` (SBET), ``line_times.txt``, ``vnir_model.csv`` and
    ``swir_model.csv``, ``dem.tif`` (2 m, ellipsoidal heights) and ``flight.json`` (the true
    boresight angles and lever arms). Returns what ``flight.json`` holds."""
    os.makedirs(folder, exist_ok=True)
    flight = Flight(**SAMPLE_FLIGHT)
    times = flight.line_times(lines, rate=line_rate)
    nav = flight.navigation(times[0] - 1.0, times[-1] + 1.0, rate=nav_rate)
    write_sbet(os.path.join(folder, "flight.out"), nav, wander_deg=flight.wander(nav.time))
    write_line_times(os.path.join(folder, "line_times.txt"), times)
    fov = np.degrees(samples * 1e-3)
    vnir, swir = sensor_models(samples, samples)
    # the simulator's models narrowed to the sample's field of view (their smile kept)
    for name, m, own in (("vnir", vnir, 30.0), ("swir", swir, 28.0)):
        scale = np.tan(np.radians(fov / 2)) / np.tan(np.radians(own / 2))
        m = type(m)(np.arctan(np.tan(m.across_rad) * scale), m.along_rad)
        write_sensor_model_csv(os.path.join(folder, f"{name}_model.csv"), m)
    dem = relief_dem(flight, size_m=800.0, cell=2.0, roughness=0.0)
    z = dem.heights.astype("float32")
    profile = dict(driver="GTiff", width=z.shape[1], height=z.shape[0], count=1,
                   dtype="float32", crs=flight.crs, transform=Affine(*dem.transform),
                   compress="deflate", predictor=3, tiled=True)  # fmt: skip
    with rasterio.open(os.path.join(folder, "dem.tif"), "w", **profile) as dst:
        dst.write(z, 1)
    truth = {
        "boresight_deg": {k: list(b.as_tuple()) for k, b in TRUE_BORESIGHT.items()},
        "lever_arm_m": {k: list(v.as_tuple()) for k, v in TRUE_LEVER_ARM.items()},
        "time_offset_s": 0.0,
        "crs": flight.crs,
        "note": "a simulated flight of the sample's size: SBET (platform heading = true "
        "heading + wander angle), line times (GPS s of week), sensor models (radians), a DEM "
        "of ellipsoidal heights; the scene's radiance was simulated in its own track frame",
    }
    with open(os.path.join(folder, "flight.json"), "w", encoding="utf-8") as f:
        json.dump(truth, f, indent=1)
    return truth
