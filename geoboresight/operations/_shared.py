"""What several file-level operations share: the checks of their shadow and surface-model
inputs, the sun's position from the time and place, the dark levels, the measured boresight
offset, and a surface model opened on the image's grid (directly, or through the line's IGM
or GLT). Each operation calls these; none borrows another operation's parts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import io
from ..errors import InputError, ParameterError
from ..io import georef
from ..io.bands import BoresightOffset, MatchBands, open_matching_pair
from ..io.dark import dark_level_of
from ..shadow import illumination as ill
from ..shadow import map as smap
from ..shadow import prior as sp
from ..shadow.surface import surface_walls


def no_valid_error(path: str, what: str = "ratio raster") -> InputError:
    """The error of an input whose every pixel is nodata."""
    return InputError(
        f"{what} {path} has no valid pixel (every pixel is nodata or not finite): check the "
        "file and its nodata value"
    )


#: Heights (m) beyond any surface a surface model shows (dry land reaches −430 m at the Dead
#: Sea and 8,849 m at Everest): a fill value not declared as nodata (−9999, −32768, 3.4e38),
#: or heights not in metres.
LOWEST_HEIGHT_M, HIGHEST_HEIGHT_M = -1_000.0, 9_000.0


def check_heights(lo: float, hi: float, path: str, what: str = "surface model") -> None:
    """Refuse a surface model whose lowest or highest valid height (m) is not a height on
    Earth: an undeclared fill value (−9999 in the holes of a DSM whose nodata is unset) would
    be taken for a pit 10 km deep, and the shadows cast into it and the relief (how far every
    shadow is searched) would silently be wrong."""
    for value, bad in ((lo, lo < LOWEST_HEIGHT_M), (hi, hi > HIGHEST_HEIGHT_M)):
        if bad:
            raise InputError(
                f"{what} {path} holds a height of {value:g} m, beyond the Earth's surface (−430 to 8,849 m): "
                f"if {value:g} marks missing cells, declare it the file's nodata value (e.g. "
                f"gdal_edit.py -a_nodata {value:g}); else give heights in metres"
            )


def check_cell_size(cell_size, matrix, what: str) -> None:
    """Refuse a ``cell_size`` (m) the user gave for a grid whose geotransform already gives its
    cells (``matrix``: :func:`geoboresight.shadow.illumination.grid_matrix`, metres) and says
    otherwise: one of the two is wrong, and using either silently would scale every shadow."""
    if not cell_size:
        return
    sides = np.hypot(*np.asarray(matrix, float).reshape(2, 2))  # column and row steps (m)
    if np.all(np.abs(sides - float(cell_size)) <= 0.01 * sides):
        return
    raise ParameterError(
        f"parameter 'cell_size': {float(cell_size):g} m, but {what} has cells of "
        f"{sides[0]:.4g} × {sides[1]:.4g} m from its geotransform: leave 'cell_size' empty (it "
        "is for a surface model without a geotransform), or fix the geotransform"
    )


#: How far an estimated shadow fraction may stray outside 0–1 (an unmixed or fitted fraction's
#: noise) before the file is taken for something else: a percentage, classes, a ratio.
FRACTION_SLACK = 0.05


def check_fraction_nodata(src, path: str, what: str = "shadow fraction") -> None:
    """Refuse a shadow-fraction raster whose declared nodata is a fraction (0–1): with nodata
    0, every sunlit pixel would be read as missing (no shadow edge next to sunlit ground is
    left, or the sunlit ground is written as nodata)."""
    nd = src.nodata
    if nd is not None and np.isfinite(nd) and 0.0 <= nd <= 1.0:
        raise InputError(
            f"{what} {path} declares {nd:g} as its nodata value, but {nd:g} is a shadow fraction "
            "(0 sunlit, 1 full shadow): its pixels would be read as missing; remove the nodata "
            "value or set one outside 0–1 (e.g. gdal_edit.py -unsetnodata, or -a_nodata -9999)"
        )


def check_fraction(f: np.ndarray, ok: np.ndarray, path: str, what: str = "shadow fraction"):
    """Refuse a shadow-fraction strip with values outside 0–1 (beyond :data:`FRACTION_SLACK`):
    a percentage or a class raster given as a fraction would otherwise be clipped to 0–1 and
    silently give a wrong result."""
    v = np.asarray(f)[np.asarray(ok, bool)]
    if not v.size:
        return
    lo, hi = float(v.min()), float(v.max())
    if lo >= -FRACTION_SLACK and hi <= 1.0 + FRACTION_SLACK:
        return
    if lo >= -FRACTION_SLACK and hi <= 100.0 + FRACTION_SLACK:
        hint = "a percentage? divide it by 100 (e.g. gdal_calc.py, or QGIS's Raster calculator)"
    elif lo >= 0 and hi <= 255 and float(hi).is_integer():
        hint = (
            "bytes scaled 0–255? divide it by 255 (e.g. gdal_calc.py, or QGIS's Raster calculator)"
        )
    else:
        hint = "give a fraction: shadow-map's 'fraction' or sun-shadow's output"
    raise InputError(
        f"{what} {path} holds values from {lo:g} to {hi:g}, but a shadow fraction is 0–1 "
        f"(nodata aside): {hint}"
    )


def grid_place(grid) -> tuple[float, float, object] | None:
    """(lon, lat, CRS) of the centre of a grid with a CRS and a geotransform, else None: where
    the sun is computed from the acquisition time (:func:`sun_angles`)."""
    if grid.crs is None or grid.transform is None:
        return None
    t, c, r = grid.transform, grid.width / 2.0, grid.height / 2.0
    cx, cy = t.a * c + t.b * r + t.c, t.d * c + t.e * r + t.f
    lon, lat = georef.centre_lonlat(np.array([cx]), np.array([cy]), grid.crs)
    return lon, lat, grid.crs


def sun_angles(
    sun_zenith, sun_azimuth, acquisition_time, place, *, needed_by: str
) -> tuple[float, float, str]:
    """The sun's (zenith, azimuth, how) for casting shadows: the angles given, or computed
    from ``acquisition_time`` at ``place`` ((lon, lat, CRS of the grid the shadows are cast
    on), or None when unknown) with NREL's SPA (:func:`geoboresight.shadow.solar.sun_position`),
    the azimuth turned from true north to the grid's north (meridian convergence)."""
    from ..shadow import illumination as ill
    from ..shadow.solar import states_offset, sun_position

    given = [sun_zenith is not None, sun_azimuth is not None]
    if acquisition_time is None:
        if not all(given):
            raise ParameterError(
                f"parameter '{needed_by}' needs the sun's position: give 'sun_zenith' and "
                "'sun_azimuth' (degrees; the azimuth clockwise from north towards the sun), "
                "or 'acquisition_time'"
            )
        zen, az = ill.check_sun(sun_zenith, sun_azimuth)
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
        lo, hi, n = ill.height_range(z[own], valid[own])
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
    shift, within :data:`geoboresight.shadow.map.DSM_TOLERANCE` pixels, that best matches the
    image's NIR darkness, where the image's parts agree on it
    (:func:`geoboresight.shadow.map.prior_registration`; False = the prediction where the DSM
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


#: Bands per instrument read for the dark level besides the signal bands (evenly spaced).
DARK_BANDS = 16
#: Lines of the central block the boresight offset is measured on.
OFFSET_ROWS = 512


def spread_bands(bands: tuple[int, ...], n: int) -> list[int]:
    """At most ``n`` of ``bands``, evenly spaced over them (the first and last included)."""
    idx = np.unique(np.linspace(0, len(bands) - 1, min(n, len(bands))).round().astype(int))
    return [bands[i] for i in idx]


def dark_level(sensor, src, bands, given, sample, valid, progress) -> smap.DarkLevel:
    """One instrument's dark level: ``given``, the product's dark reference or the header's
    (:func:`geoboresight.io.dark.dark_level_of`), else the dark object of ``sample``
    (n_bands, n_pixels; :func:`geoboresight.shadow.map.dark_level`) in ``bands``."""
    level = dark_level_of(sensor, bands, src.tags(ns="ENVI"), src.count, given)
    if level is None:
        level = smap.dark_level(sample, valid)
    progress.info(level.describe(sensor.name))
    return level


def band_dark_levels(sensor, src, bands, sampled, given, sample, valid, progress) -> np.ndarray:
    """The dark level of each of ``bands``: per band from the product or header when it lists
    them, else the one level (given, or the dark object of ``sample`` in the ``sampled``
    bands: :func:`dark_level`)."""
    level = dark_level_of(sensor, bands, src.tags(ns="ENVI"), src.count, given)
    if level is None:
        level = dark_level(sensor, src, sampled, given, sample, valid, progress)
    else:
        progress.info(level.describe(sensor.name))
    # A level below the darkest pixel or above the signal is refused as shadow-map refuses it.
    smap.check_sample(sample, valid, level, name=f"{sensor.name} {sensor.path}")
    if level.band_levels is None:
        return np.full(len(bands), level.level)
    return np.broadcast_to(level.for_bands(bands, bands), (len(bands),)).astype(float)


def saturation_value(src) -> float | None:
    """The value a saturated element reads: the integer data type's largest; None for floats."""
    dtype = np.dtype(src.dtypes[0])
    return float(np.iinfo(dtype).max) if dtype.kind in "iu" else None


def central_rows(height: int) -> tuple[int, int]:
    """The central block of at most :data:`OFFSET_ROWS` lines of a flight line of ``height``
    lines: where the boresight offset is measured and the surface model registered."""
    r0 = max(0, height // 2 - OFFSET_ROWS // 2)
    return r0, min(height, r0 + OFFSET_ROWS)


def boresight_offset(dual, v_src, s_src, rb, given: BoresightOffset, progress):
    """(along, across, how): the SWIR's boresight offset (px), ``given``, else measured on the
    central block (:func:`geoboresight.dem.offset.estimate_offset`, the ratio's bands ``rb``);
    0 when it cannot be measured there. The log gives it."""
    along, across, how = _offset(dual, v_src, s_src, rb, given, progress)
    progress.info(f"boresight offset {along:+.2f} px along, {across:+.2f} px across ({how})")
    return along, across, how


def _offset(dual, v_src, s_src, rb, given: BoresightOffset, progress):
    if given.offset_along is not None or given.offset_across is not None:
        return float(given.offset_along or 0.0), float(given.offset_across or 0.0), "given"
    from ..dem.offset import estimate_offset

    r0, r1 = central_rows(dual.height)
    vv, vok = io.band_reader(v_src, rb.vnir_band)(r0, r1)
    ss, sok = io.band_reader(s_src, rb.swir_band)(r0, r1)
    try:
        off = estimate_offset(vv, ss, vok & sok)
    except InputError as e:
        progress.info(f"boresight offset not measurable ({e}); the SWIR is used unshifted")
        return 0.0, 0.0, "not measurable: 0"
    return off.along, off.across, f"measured on lines {r0}–{r1}"


@dataclass(frozen=True)
class OpenedSurface:
    """A surface model opened for an operation: its raster on the image's grid (``src``),
    the cast's kernel value (``prior``), the lines (above, below) a strip needs for its cast
    shadows (``halo``) and where the sun's angles came from (``sun``)."""

    src: object
    prior: sp.SurfacePrior
    halo: tuple[int, int]
    sun: str = "given"


def _sun(surface: SurfaceModel, place) -> tuple[float, float, str]:
    return sun_angles(
        surface.sun_zenith, surface.sun_azimuth, surface.acquisition_time, place, needed_by="dsm"
    )


def _surface_via_geolocation(surface: SurfaceModel, dual, stack, progress):
    """The DSM (on a map grid) read at every raw pixel through the line's IGM or GLT: a
    temporary raster on the image's grid, the raw grid's geometry, and the place for the sun."""
    import tempfile

    import rasterio

    from ..io.sample import raw_grid_matrix, surface_on_raw_grid

    if surface.igm and surface.glt:
        raise ParameterError(
            "parameters 'igm' and 'glt': give the line's geolocation once, its IGM or its GLT"
        )
    if surface.glt:
        from ..georef.geoloc import glt_coordinates

        glt = georef.glt_for(
            surface.glt,
            f"image {dual.vnir.path}",
            width=dual.width,
            height=dual.height,
            crs=surface.igm_crs,
        )
        x, y = glt_coordinates(
            glt.sample,
            glt.line,
            glt.valid,
            glt.grid.transform,
            width=dual.width,
            height=dual.height,
        )
        if not np.isfinite(x).any():
            raise InputError(
                f"GLT {surface.glt} shows fewer than 3 pixels of the {dual.height} × "
                f"{dual.width} image: give the GLT of this flight line"
            )
        coords = georef.Coordinates(x, y, glt.grid.crs, surface.glt, f"GLT {surface.glt}")
    else:
        coords = georef.coordinates_for(dual.vnir.path, igm=surface.igm, crs=surface.igm_crs)
    source = f"GLT {surface.glt}" if surface.glt else f"IGM {surface.igm}"
    if coords.x.shape != (dual.height, dual.width):
        raise InputError(
            f"IGM {surface.igm} has {coords.x.shape[0]} × {coords.x.shape[1]} pixels but the "
            f"image {dual.height} × {dual.width}: give the IGM of this flight line"
        )
    matrix, crs, rms = raw_grid_matrix(coords)
    src = _open_dsm(surface.dsm, stack)
    folder = stack.enter_context(tempfile.TemporaryDirectory(prefix="geoboresight-dsm-"))
    path = f"{folder}/dsm_raw.tif"
    profile = dict(
        driver="GTiff",
        width=dual.width,
        height=dual.height,
        count=1,
        dtype="float32",
        nodata=float("nan"),
        tiled=True,
        blockxsize=256,
        blockysize=256,
    )
    with io.quiet_georef(), rasterio.open(path, "w", **profile) as dst:
        covered = surface_on_raw_grid(src, coords, dst, progress.sub(0.0, 0.05))
    if covered == 0:
        raise InputError(
            f"surface model {surface.dsm} does not cover the flight line: none of the "
            f"{source}'s pixels fall on it (check both files' CRS)"
        )
    share = covered / float(dual.height * dual.width)
    cell = float(np.sqrt(abs(np.linalg.det(matrix))))
    progress.info(
        f"surface model {surface.dsm} read at the raw pixels through the {source}: "
        f"{100 * share:.1f} % covered; raw grid {cell:.2f} m pixels, affine within "
        f"{rms:.2f} m RMS ({georef.crs_name(crs)})"
    )
    if rms > cell:
        progress.info(
            f"warning: the flight line departs from an affine grid by {rms:.1f} m RMS (more "
            "than a pixel): its shadows are cast on the line's mean geometry"
        )
    lon, lat = georef.centre_lonlat(coords.x, coords.y, coords.crs)
    raw = stack.enter_context(io.open_raster(path, "surface model"))
    return raw, matrix, (lon, lat, crs)


def _open_dsm(path, stack):
    """The surface model opened; refused when it has more than one band: its first band would
    be used without a word (a DSM and a DTM in one file, or an image given for the DSM)."""
    src = stack.enter_context(io.open_raster(path, "surface model"))
    if src.count != 1:
        raise InputError(
            f"surface model {path} has {src.count} bands: give a single-band DSM (heights in "
            f"metres), e.g. its band 1 with gdal_translate -b 1 {path} dsm.tif"
        )
    return src


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


def _surface_on_image_grid(surface: SurfaceModel, dual, stack):
    """The DSM on the image's grid: (raster, the grid's metric matrix, the place for the sun)."""
    if surface.igm_crs:
        raise ParameterError(
            "parameter 'igm_crs' is the CRS of the line's IGM or GLT: give 'igm' or 'glt' "
            "too, or leave it empty"
        )
    src = _open_dsm(surface.dsm, stack)
    if (src.height, src.width) != (dual.height, dual.width):
        raise InputError(
            f"surface model {surface.dsm} has {src.height} × {src.width} cells but the "
            f"image {dual.height} × {dual.width} pixels: give a DSM on the image's grid, or "
            "the line's IGM ('igm') to read a DSM on a map grid at the image's pixels"
        )
    grid = io.Grid.of(src)
    # Of the image's size but on another map grid (shifted, rotated, south-up, another
    # CRS): its cells are not the image's pixels.
    dual.grid.require_same(grid, f"image {dual.vnir.path}", f"surface model {surface.dsm}")
    if grid.transform is not None:
        matrix = ill.grid_matrix(georef.metric_matrix(grid, f"surface model {surface.dsm}"))
        check_cell_size(surface.cell_size, matrix, f"surface model {surface.dsm}")
        return src, matrix, grid_place(grid)
    if dual.grid.transform is not None:
        matrix = ill.grid_matrix(georef.metric_matrix(dual.grid, f"image {dual.vnir.path}"))
        check_cell_size(surface.cell_size, matrix, f"image {dual.vnir.path}")
        return src, matrix, grid_place(dual.grid)
    if surface.cell_size:
        return src, ill.grid_matrix(None, surface.cell_size), None
    raise ParameterError(
        f"surface model {surface.dsm} and the image have no geotransform: give "
        "'cell_size' (the DSM's cell size in metres)"
    )


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
    if surface.igm or surface.glt:
        if surface.cell_size:
            raise ParameterError(
                "parameter 'cell_size' is for a surface model without a geotransform: with the "
                "line's IGM or GLT the pixels' size comes from it; leave 'cell_size' empty"
            )
        src, matrix, place = _surface_via_geolocation(surface, dual, stack, progress)
    else:
        src, matrix, place = _surface_on_image_grid(surface, dual, stack)
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
    relief = float(hi - lo)
    halo = ill.halo_rows(relief, zen, az, matrix, (dual.height, dual.width))
    progress.info(
        f"surface model {surface.dsm}: relief {relief:.1f} m, {kind} surface ({walls} of "
        f"{pairs} cell pairs are walls); sun zenith {zen:.2f}°, azimuth {az:.2f}° ({how})"
    )
    if not surface.clearance >= 0:
        raise ParameterError(f"parameter 'clearance': {surface.clearance!r} must be ≥ 0 (m)")
    prior = sp.surface_prior(
        relief,
        float(hi),
        sun_zenith=zen,
        sun_azimuth=az,
        transform=matrix,
        surface=kind,
        clearance=surface.clearance,
        shape=(dual.height, dual.width),
    )
    return OpenedSurface(src, prior, halo, how)


#: How the user gives the offset instead of measuring it (the error of a line too small).
GIVE_OFFSET = ": give it ('offset_along', 'offset_across')"


def measured_offset(
    dual, given: BoresightOffset, progress, hint: str = GIVE_OFFSET
) -> tuple[float, float, str]:
    """The boresight offset δ: given, else measured as ``boresight-offset`` measures it (the
    ratio's bands, Fourier cross-correlation over the whole line); ``hint`` ends the error of
    a line too small to measure it on."""
    if given.offset_along is not None or given.offset_across is not None:
        return float(given.offset_along or 0.0), float(given.offset_across or 0.0), "given"
    from .offset import line_offset

    with open_matching_pair(dual, MatchBands()) as pair:
        off, _ = line_offset(pair, 0, progress, given=hint)
    return off.along, off.across, "measured (boresight-offset)"


def sensor_dark_levels(sensor, bands, given, sample, progress):
    """One instrument's dark level for ``bands`` (1-based file bands), for a detector that
    needs it only when nothing else gives it: given, the product's dark reference or the
    header (:func:`geoboresight.io.dark.dark_level_of`, as :func:`dark_level`), else the dark
    object of ``sample()`` (n_bands, n_pixels), drawn only then. Returns (level per band,
    :class:`~geoboresight.shadow.map.DarkLevel`)."""
    with io.open_raster(sensor.reads, sensor.name) as src:
        level = dark_level_of(sensor, bands, src.tags(ns="ENVI"), src.count, given)
    if level is None:
        values, ok = sample()
        level = smap.dark_level(values, ok)
    progress.info(level.describe(sensor.name))
    return np.broadcast_to(np.asarray(level.for_bands(bands, bands), float), (len(bands),)), level
