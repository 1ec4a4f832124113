"""File-level direct georeferencing: an image, its navigation, line times, sensor model,
lever arm, boresight and a DEM to an IGM (Brook & Ben-Dor 2011, §2, Eq. 1–2), line block by
line block."""

from __future__ import annotations

import contextlib
import os

import numpy as np

from ..errors import InputError, ParameterError
from ..io import navigation as nio
from ..io.envi import envi_header
from ..io.igm import ANGLE_BANDS, IGM_BANDS, block_writer
from ..io.image import open_raster
from ..io.navigation import line_times_for, sensor_model_for
from ..io.terrain import dem_overview, read_surface
from ..sensor.boresight import Boresight, LeverArm
from ..sensor.georeference import ned_to_ecef, platform, rays, trace
from ._geometry import SensorGeometry, Terrain

#: Lines per block: memory stays bounded (about 0.4 kB per pixel of a block) whatever the
#: line's length.
BLOCK_LINES = 256

__all__ = ["SensorGeometry", "Terrain", "direct_georeference_file", "view_angles"]


def _as(kind, value, label):
    if value is None:
        return kind()
    if isinstance(value, kind):
        return value
    try:
        return kind(*(float(v) for v in value))
    except (TypeError, ValueError):
        raise ParameterError(
            f"{label} must be three numbers, not {value!r}", params=(label,)
        ) from None


def _image_size(input):
    with open_raster(input, "input") as src:
        return src.width, src.height


def _header(input):
    keys = envi_header(os.fspath(input)) or {}
    return keys


def _edges(model):
    """A sparse set of the model's pixels (every 16th and the last): the swath's outline."""
    idx = np.unique(np.r_[np.arange(0, model.n_pixels, 16), model.n_pixels - 1])
    return model.look_vectors()[idx]


def _footprint(pos, r, look, b, lever, low, high, crs):
    """Map x, y where the rays of ``look`` cross the heights ``low`` and ``high`` (NaN: a ray
    that misses): the crossings of the ellipsoids inflated by those heights (within a few
    centimetres of them at a DEM's heights), converted by one pyproj transform."""
    from ..sensor.georeference import ECEF, transformer
    from ..sensor.intersect import crossings

    origins, d = rays(pos, r, look, b, lever)
    t_high, t_low = crossings(low, high, origins, d)
    t = np.stack([t_low, np.where(np.isfinite(t_low), t_high, np.nan)])
    p = origins[None, :, None, :] + t[..., None] * d[None]
    x, y, _ = transformer(ECEF, crs).transform(
        p[..., 0].ravel(), p[..., 1].ravel(), p[..., 2].ravel()
    )
    return np.asarray(x), np.asarray(y)


def _coverage(nav, times, look, b, lever, offset, low, high, bounds, crs):
    """The share of a sparse sample of pixels whose rays, between the DEM's lowest and
    highest heights, leave its bounds."""
    step = max(1, len(times) // 256)
    pos, r = platform(nav, times[::step], time_offset=offset)
    x, y = _footprint(pos, r, look, b, lever, low, high, crs)
    left, bottom, right, top = bounds
    out = ~((x >= left) & (x <= right) & (y >= bottom) & (y <= top))
    return float(out.mean())


def _window(pos, r, look, b, lever, low, high, crs):
    """The DEM window (left, bottom, right, top) a block of lines sees, with a margin."""
    x, y = _footprint(pos, r, look, b, lever, low, high, crs)
    box = np.nanmin(x), np.nanmin(y), np.nanmax(x), np.nanmax(y)
    pad = 0.02 * max(box[2] - box[0], box[3] - box[1]) + 5.0
    return box[0] - pad, box[1] - pad, box[2] + pad, box[3] + pad


def view_angles(positions, body_to_ecef, look, b, lever, nav_lat, nav_lon):
    """View zenith and azimuth (degrees) of each pixel's ray, from the ground towards the
    sensor, in the local frame below the navigation point."""
    _, d = rays(positions, body_to_ecef, look, b, lever)
    ned = np.einsum("lji,lpj->lpi", ned_to_ecef(nav_lat, nav_lon), d)
    zenith = np.degrees(np.arccos(np.clip(ned[..., 2], -1.0, 1.0)))
    azimuth = np.degrees(np.arctan2(-ned[..., 1], -ned[..., 0])) % 360.0
    return zenith, azimuth


def direct_georeference_file(
    input,
    navigation,
    *,
    output,
    geometry: SensorGeometry = SensorGeometry(),
    time_offset=0.0,
    terrain: Terrain = Terrain(),
    crs=None,
    view_angles_output=None,
    progress=None,
) -> dict:
    """An IGM for ``input`` from the aircraft's navigation (Brook & Ben-Dor 2011, Eq. 1–2).

    Parameters
    ----------
    input : path
        The image (raw geometry): its lines, samples and header (binning, ``x start``, GPS
        start time and ``fps`` when no line-times file is given).
    navigation : path
        SBET, the navigation CSV, a Specim ``.nav`` or HySpex per-line text.
    output : path
        The IGM: float64 easting, northing, ellipsoidal height (GeoTIFF; ENVI BIL in APL's
        layout for ``.bil``/``.img``), nodata where a ray misses.
    geometry : SensorGeometry
        The sensor model (or ``fov``), line times, lever arm (three numbers or a
        ``LeverArm``) and boresight (three numbers or a ``Boresight``).
    time_offset : float
        Seconds added to the line times: the navigation is sampled at ``time + offset``.
    terrain : Terrain
        The DEM (its CRS in metres; its vertical CRS when above a geoid), or a constant
        ellipsoidal height.
    crs : str, optional
        The IGM's CRS (default the DEM's; required with a constant height).
    view_angles_output : path, optional
        View zenith and azimuth of every pixel (degrees).

    Returns
    -------
    dict
        ``output``, ``lines``, ``samples``, ``missed_fraction`` (rays that met no DEM
        height) and ``first_line_time``.

    References
    ----------
    Brook, A. & Ben-Dor, E. (2011). Advantages of the boresight effect in hyperspectral data
    analysis. Remote Sensing 3, 484–502, https://doi.org/10.3390/rs3030484 (§2, Eq. 1–2).
    """
    from ..io.georef import parse_crs

    b = _as(Boresight, geometry.boresight, "boresight")
    lever = _as(LeverArm, geometry.lever_arm, "lever_arm")
    terrain.check()
    dem, height = terrain.dem, terrain.height
    width, lines = _image_size(input)
    keys = _header(input)
    model = sensor_model_for(geometry.sensor_model, geometry.fov, width, keys)
    nav = nio.read_navigation(navigation)
    times = line_times_for(geometry.line_times, keys, lines, navigation, f"input {input}")
    nav.check_covers(times + time_offset, "the line times (with the time offset)")
    if dem is not None:
        low, high, bounds, dem_crs = dem_overview(dem)
        out_crs = parse_crs(crs).to_wkt() if crs else dem_crs
        edges = _edges(model)
        share = _coverage(nav, times, edges, b, lever, time_offset, low, high, bounds, dem_crs)
        if share > 0:
            raise InputError(
                f"DEM {dem} misses {share:.1%} of the pixels (the swath runs beyond it): "
                "give a DEM that covers the line, or --height",
                params=("dem",),
            )
    else:
        if not crs:
            raise ParameterError("a constant height needs an output CRS", params=("crs",))
        out_crs = parse_crs(crs).to_wkt()
    look = model.look_vectors()
    tags = {
        "boresight_deg": " ".join(f"{v:g}" for v in b.as_tuple()),
        "lever_arm_m": " ".join(f"{v:g}" for v in lever.as_tuple()),
        "time_offset_s": f"{time_offset:g}",
        "PRODUCT": "IGM: easting, northing, ellipsoidal height of each raw pixel centre",
    }
    missed = 0
    with block_writer(output, width, lines, out_crs, bands=IGM_BANDS, tags=tags) as write:
        angle_writer = (
            block_writer(view_angles_output, width, lines, out_crs, bands=ANGLE_BANDS, tags=tags)
            if view_angles_output
            else contextlib.nullcontext(None)
        )
        with angle_writer as write_angles:
            for row0 in range(0, lines, BLOCK_LINES):
                t = times[row0 : row0 + BLOCK_LINES]
                pos, r = platform(nav, t, time_offset=time_offset)
                surface = None
                if dem is not None:
                    # only the DEM window this block sees: memory stays bounded by a block
                    box = _window(pos, r, edges, b, lever, low, high, dem_crs)
                    surface = read_surface(dem, bounds=box, vertical_crs=terrain.dem_vertical_crs)
                x, y, h = trace(
                    pos, r, look, b, lever, surface,
                    height=None if surface is not None else height, crs=out_crs,
                )  # fmt: skip
                missed += int(np.count_nonzero(~np.isfinite(x)))
                write(row0, np.stack([x, y, h]))
                if write_angles is not None:
                    at = nav.at(t + time_offset)
                    angles = view_angles(pos, r, look, b, lever, at.lat_deg, at.lon_deg)
                    write_angles(row0, np.stack(angles))
                if progress is not None:
                    progress.update(min(1.0, (row0 + len(t)) / lines), "tracing the rays")
    share = missed / (width * lines)
    if missed and progress is not None:
        progress.info(f"{share:.2%} of the rays meet no DEM height (no data): nodata there")
    return {
        "output": os.fspath(output),
        "view_angles_output": view_angles_output,
        "lines": lines,
        "samples": width,
        "missed_fraction": share,
        "first_line_time": float(times[0]),
    }
