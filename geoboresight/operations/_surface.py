"""The surface model and the sun for an operation that casts shadows: the DSM opened on the
image's grid (directly, or read at the raw pixels through the line's IGM or GLT), the sun's
position (given, or from the acquisition time at the scene's place), the relief (how far its
shadows reach) and the kind of surface, as the prior the shadow kernels take."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import io
from ..errors import ParameterError
from ..io import georef
from ..io.checks import check_heights, no_valid_error
from ..io.sample import surface_on_image_grid
from ..shadow import illumination
from ..shadow.prior import SurfacePrior, surface_prior
from ..shadow.surface import height_noise, second_differences, surface_walls
from ._glt import line_coordinates


@dataclass(frozen=True)
class SurfaceModel:
    """A surface model (DSM, heights in metres) and the sun's position: the cast shadow it
    predicts is the shadow map's prior. ``dsm`` None = no surface model.

    The DSM is on the image's grid, or on a map grid with ``igm``, the line's IGM (each raw
    pixel's map coordinates: the DSM is read at every raw pixel, and the sun's azimuth is
    from north), or with ``glt``, its GLT (each raw pixel at the mean of the map cells that
    show it: :func:`geoboresight.georef.geoloc.glt_coordinates`); ``igm_crs``, their CRS when
    the file carries none (or to override it). ``sun_zenith`` 0–90° (< 90), ``sun_azimuth`` clockwise from north towards
    the sun (as ``sun-shadow``); or ``acquisition_time`` (ISO 8601, UTC without an offset),
    from which they are computed at the scene's centre (NREL's SPA:
    :func:`geoboresight.shadow.solar.sun_position`). ``cell_size`` (m) for a DSM without a
    geotransform (else the image's); ``clearance`` (m): a caster must rise this far above the
    sun line to cast shadow (the DSM's height noise: about 3 × its standard deviation; 0 =
    exact, as ``sun-shadow``); ``register``: first move the cast shadow by the sub-pixel
    shift, within :data:`geoboresight.shadow.darkness.DSM_TOLERANCE` pixels, that best matches the
    image's NIR darkness, where the image's parts agree on it
    (:func:`geoboresight.shadow.prior.prior_registration`; False = the prediction where the DSM
    puts it).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.SurfaceModel()  # no surface model: the shadow map from the image alone
    SurfaceModel(dsm=None, sun_zenith=None, sun_azimuth=None, cell_size=None, clearance=1.0,
        igm=None, acquisition_time=None, glt=None, igm_crs=None, register=True)
    >>> surface = gb.SurfaceModel(dsm="dsm.tif", acquisition_time="2009-06-12T09:30:00Z")
    >>> surface.sun_zenith is None  # found from the time and the DSM's position when run
    True
    """

    dsm: str | None = None
    sun_zenith: float | None = None
    sun_azimuth: float | None = None
    cell_size: float | None = None
    clearance: float = 1.0
    igm: str | None = None
    acquisition_time: str | None = None
    glt: str | None = None
    igm_crs: str | None = None
    register: bool = True


@dataclass(frozen=True)
class OpenedSurface:
    """A surface model opened for an operation: its raster on the image's grid (``src``),
    the cast's kernel value (``prior``), the lines (above, below) a strip needs for its cast
    shadows (``halo``) and where the sun's angles came from (``sun``)."""

    src: object
    prior: SurfacePrior
    halo: tuple[int, int]
    sun: str = "given"


def open_surface(surface: SurfaceModel, dual, block_rows, stack, progress) -> OpenedSurface | None:
    """Check the surface model against the image, read it on the image's grid (through the
    line's IGM or GLT when given), find the sun, its relief (how far its shadows reach) and
    whether it has walls (blocks or smooth surface, as ``sun-shadow``). None without a DSM."""
    from ..shadow.surface import choose_surface

    if not surface.dsm:
        _refuse_without_dsm(surface)
        return None
    # The scene's place is needed only for the sun from the time alone: otherwise the sun is
    # known, or refused (missing, or given twice), before any reading.
    angles = surface.sun_zenith is not None or surface.sun_azimuth is not None
    sun = _sun(surface, None) if surface.acquisition_time is None or angles else None
    coords, geolocation = None, ""
    if surface.igm or surface.glt:
        if surface.cell_size:
            raise ParameterError(
                "parameter 'cell_size' is for a surface model without a geotransform: with the "
                "line's IGM or GLT the pixels' size comes from it; leave 'cell_size' empty"
            )
        coords, geolocation = line_coordinates(
            dual, igm=surface.igm, glt=surface.glt, crs=surface.igm_crs
        )
    elif surface.igm_crs:
        raise ParameterError(
            "parameter 'igm_crs' is the CRS of the line's IGM or GLT: give 'igm' or 'glt' "
            "too, or leave it empty"
        )
    on_grid = surface_on_image_grid(
        surface.dsm,
        dual.grid,
        stack,
        image=f"image {dual.vnir.path}",
        coords=coords,
        geolocation=geolocation,
        cell_size=surface.cell_size,
        progress=progress,
    )
    src, place = on_grid.src, on_grid.place
    matrix = illumination.grid_matrix(on_grid.matrix, surface.cell_size)
    zen, az, how = sun or _sun(surface, place)
    if zen >= 90.0:
        raise ParameterError(
            f"parameter 'sun_zenith': {zen:g}° puts the sun on or below the horizon: every "
            "surface would be in shadow; give the zenith of the acquisition (below 90°)"
        )
    lo, hi, n_valid, walls, pairs = relief_and_walls(
        io.band_reader(src, 1),
        matrix,
        message="surface model relief",
        height=dual.height,
        width=dual.width,
        block_rows=block_rows,
    )
    if n_valid == 0:
        raise no_valid_error(surface.dsm, "surface model")
    check_heights(lo, hi, surface.dsm)
    kind = choose_surface(walls, pairs)
    noise = height_noise(
        io.reduce_windows(
            io.band_reader(src, 1),
            second_differences,
            lambda a, b: a + b,
            0,
            message="surface model height noise",
            height=dual.height,
            width=dual.width,
            block_rows=block_rows,
        )
    )
    relief = float(hi - lo)
    halo = illumination.halo_rows(relief, zen, az, matrix, (dual.height, dual.width))
    progress.info(
        f"surface model {surface.dsm}: relief {relief:.1f} m, {kind} surface ({walls} of "
        f"{pairs} cell pairs are walls); sun zenith {zen:.2f}°, azimuth {az:.2f}° ({how})"
    )
    if not surface.clearance >= 0:
        raise ParameterError(f"parameter 'clearance': {surface.clearance!r} must be ≥ 0 (m)")
    prior = surface_prior(
        relief,
        float(hi),
        sun_zenith=zen,
        sun_azimuth=az,
        transform=matrix,
        surface=kind,
        clearance=surface.clearance,
        shape=(dual.height, dual.width),
        noise=noise,
    )
    return OpenedSurface(src, prior, halo, how)


def sun_angles(
    sun_zenith, sun_azimuth, acquisition_time, place, *, needed_by: str
) -> tuple[float, float, str]:
    """The sun's (zenith, azimuth, how) for casting shadows: the angles given, or computed
    from ``acquisition_time`` at ``place`` ((lon, lat, CRS of the grid the shadows are cast
    on), or None when unknown) with NREL's SPA (:func:`geoboresight.shadow.solar.sun_position`),
    the azimuth turned from true north to the grid's north (meridian convergence)."""
    from ..shadow.solar import states_offset, sun_position

    given = [sun_zenith is not None, sun_azimuth is not None]
    if acquisition_time is None:
        if not all(given):
            raise ParameterError(
                f"parameter '{needed_by}' needs the sun's position: give 'sun_zenith' and "
                "'sun_azimuth' (degrees; the azimuth clockwise from north towards the sun), "
                "or 'acquisition_time'"
            )
        zen, az = illumination.check_sun(sun_zenith, sun_azimuth)
        return zen, az, "given"
    if any(given):
        raise ParameterError(
            "parameter 'acquisition_time': give the sun's position once, either the time or "
            "'sun_zenith' and 'sun_azimuth', not both"
        )
    if place is None:
        raise ParameterError(
            "parameter 'acquisition_time' needs the scene's position: give a georeferenced "
            "surface model (or the line's IGM, 'igm', where taken), or 'sun_zenith' and "
            "'sun_azimuth'"
        )
    lon, lat, crs = place
    zen, az = sun_position(acquisition_time, lon, lat)
    if not zen < 90.0:
        # Checked here, not by check_sun: the user gave a time, not a zenith, so the message
        # names the time (a wrong date or UTC offset is the usual cause).
        raise ParameterError(
            f"parameter 'acquisition_time': at {acquisition_time} the sun is "
            f"{zen - 90.0:.1f}° below the horizon at {lat:.4f}°, {lon:.4f}° (zenith "
            f"{zen:.1f}°): no sunlight casts shadows; check the date and the UTC offset (a "
            "time without an offset is UTC)"
        )
    bearing = georef.true_north_bearing(lon, lat, crs)
    # A local time given without its offset gives a wrong sun without any error: say so.
    utc = "" if states_offset(acquisition_time) else " (no UTC offset given: read as UTC)"
    how = (
        f"computed for {acquisition_time}{utc} at {lat:.4f}°, {lon:.4f}° (NREL SPA; azimuth "
        f"{az:.2f}° from true north, {(az + bearing) % 360.0:.2f}° from grid north)"
    )
    return zen, (az + bearing) % 360.0, how


def relief_and_walls(read, matrix, *, progress=None, message="relief", **strips) -> tuple:
    """One pass over a surface model's strips: its lowest and highest height, its valid cells,
    and the walls among its neighbouring-cell pairs (:func:`surface_walls`), as
    ``(lo, hi, n_valid, walls, pairs)``. The relief bounds how far a shadow can reach; walls
    say blocks or terrain. One line of halo below, so that the pairs of lines across strip
    edges are counted (once: each strip counts the pairs whose upper line is its own)."""

    def one(z, valid, block):
        own = block.inner
        lo, hi, n = illumination.height_range(z[own], valid[own])
        pairs = slice(own.start, own.stop + 1)
        return lo, hi, n, *surface_walls(z[pairs], valid[pairs], matrix=matrix)

    return io.reduce_windows(
        read,
        one,
        lambda a, b: (min(a[0], b[0]), max(a[1], b[1]), a[2] + b[2], a[3] + b[3], a[4] + b[4]),
        (np.inf, -np.inf, 0, 0, 0),
        halo=(0, 1),
        pass_block=True,
        progress=progress,
        message=message,
        **strips,
    )


def _sun(surface: SurfaceModel, place) -> tuple[float, float, str]:
    return sun_angles(
        surface.sun_zenith, surface.sun_azimuth, surface.acquisition_time, place, needed_by="dsm"
    )


def _refuse_without_dsm(surface: SurfaceModel) -> None:
    """Refuse the surface model's other options when no DSM is given."""
    extra = [
        n
        for n, v in (
            ("sun_zenith", surface.sun_zenith),
            ("sun_azimuth", surface.sun_azimuth),
            ("acquisition_time", surface.acquisition_time),
            ("igm", surface.igm),
            ("glt", surface.glt),
            ("igm_crs", surface.igm_crs),
        )
        if v is not None
    ]
    if extra:
        raise ParameterError(
            f"parameter{'s' if len(extra) > 1 else ''} {', '.join(repr(n) for n in extra)} "
            "only used with a surface model: give 'dsm' too, or leave them empty"
        )
