"""File-level shadow map (paper §3.1, made physical): VNIR + SWIR in, a shadow mask and the
four shadow-fraction classes out, calibrated to the scene (:mod:`geoboresight.shadow.map`).

Two passes over the flight line: a random sample calibrates the map (dark levels, sunlit
modes, sunlit ratio, the scaled class table) and a central block of lines gives the boresight
offset; then the map is written strip by strip, each strip by the kernel
:func:`geoboresight.shadow.map.shadow_map_block`. The dark levels are found in
:mod:`geoboresight.io.dark`.
"""

from __future__ import annotations

import contextlib
import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .. import io
from ..errors import InputError, ParameterError
from ..io import georef
from ..io.bands import BoresightOffset, band_range
from ..io.dark import DarkLevels, dark_level_of
from ..io.dual import BandChoice, DualLayout
from ..io.masks import mask_raster
from ..io.shadow import class_table_csv
from ..io.windows import Sample
from ..shadow import classes as cls
from ..shadow import illumination as ill
from ..shadow import map as smap
from ._operation import operation
from .shadow import (
    check_cell_size,
    check_heights,
    class_table,
    grid_place,
    no_valid_error,
    sun_angles,
)

#: Pixels drawn at random to calibrate the map.
SAMPLE_SIZE = 200_000


@dataclass(frozen=True)
class MapSample(Sample):
    """The shadow map's calibration sample: :class:`~geoboresight.io.windows.Sample` with
    :data:`SAMPLE_SIZE` pixels by default."""

    sample_size: int = SAMPLE_SIZE


@dataclass(frozen=True)
class MapCalibration(MapSample, BoresightOffset):
    """How the shadow map is calibrated on the flight line: the random sample
    (``sample_size``, ``seed``; :class:`MapSample`) and the boresight offset of the SWIR
    (``offset_along``, ``offset_across``; :class:`BoresightOffset`: both None = measured)."""


@dataclass(frozen=True)
class Detection:
    """The spectral shadow test: core shadow at or below ``core_darkness`` (natural log of the
    SWIR signal over its sunlit mode; with a surface model, whose prior replaces it, only for
    the edges a pixel this dark is at least half shaded, and near the model's sunward edge)
    and partial shadow looked for ``edge_pixels`` around it."""

    core_darkness: float = smap.CORE_DARKNESS
    edge_pixels: int = smap.EDGE_PIXELS


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
    puts it)."""

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


def _spread(bands: tuple[int, ...], n: int) -> list[int]:
    idx = np.unique(np.linspace(0, len(bands) - 1, min(n, len(bands))).round().astype(int))
    return [bands[i] for i in idx]


def _dark_level(sensor, src, bands, given, sample, valid, progress) -> smap.DarkLevel:
    """Given, the product's dark reference or the header's (io.dark), else the dark object."""
    level = dark_level_of(sensor, bands, src.tags(ns="ENVI"), src.count, given)
    if level is None:
        level = smap.dark_level(sample, valid)
    progress.info(level.describe(sensor.name))
    return level


def _saturation(src) -> float | None:
    """The value a saturated element reads: the integer data type's largest; None for floats."""
    dtype = np.dtype(src.dtypes[0])
    return float(np.iinfo(dtype).max) if dtype.kind in "iu" else None


def _offset(dual, v_src, s_src, rb, given: BoresightOffset, progress):
    if given.offset_along is not None or given.offset_across is not None:
        return float(given.offset_along or 0.0), float(given.offset_across or 0.0), "given"
    from ..dem.offset import estimate_offset

    r0 = max(0, dual.height // 2 - OFFSET_ROWS // 2)
    r1 = min(dual.height, r0 + OFFSET_ROWS)
    vv, vok = io.band_reader(v_src, rb.vnir_band)(r0, r1)
    ss, sok = io.band_reader(s_src, rb.swir_band)(r0, r1)
    try:
        off = estimate_offset(vv, ss, vok & sok)
    except InputError as e:
        progress.info(f"boresight offset not measurable ({e}); the SWIR is used unshifted")
        return 0.0, 0.0, "not measurable: 0"
    return off.along, off.across, f"measured on lines {r0}–{r1}"


@dataclass(frozen=True)
class _Surface:
    """An opened surface model: what the strips need to cast its shadows."""

    src: object
    zenith: float
    azimuth: float
    matrix: np.ndarray
    relief: float
    surface: str
    halo: tuple[int, int]
    clearance: float = 0.0
    top: float = 0.0  # highest valid height
    height: int = 0  # lines of the grid
    ray: tuple = (0.0, 0.0, 0)  # (Δrow, Δcol) per cell towards the sun, steps over the relief
    sun: str = "given"  # where the sun's angles came from
    reach: float = 0.0  # cells down-sun by which the clearance shortens a shadow on level ground
    shift: tuple = (0.0, 0.0)  # rows, columns by which the cast shadow is moved (registration)

    def unseen(self, z, valid, row0):
        """Pixels a caster beyond the surface model's edge could shade."""
        return ill.unseen_casters(
            z,
            valid,
            sun_zenith=self.zenith,
            sun_azimuth=self.azimuth,
            top=self.top,
            transform=self.matrix,
            row0=row0,
            height=self.height,
            clearance=self.clearance,
        )

    def _cast(self) -> dict:
        """The cast's keywords: the sun, the grid, the relief, the surface, the clearance."""
        return dict(
            sun_zenith=self.zenith,
            sun_azimuth=self.azimuth,
            transform=self.matrix,
            relief=self.relief,
            interpolation=ill.SURFACES[self.surface],
            clearance=self.clearance,
        )

    def prior(self, z, valid, sub_cells=None):
        """The cast-shadow fraction (the prior), moved by the registration; from
        ``sub_cells`` (:meth:`sub_cells` of the same block) when already cast."""
        if sub_cells is None:
            return ill.shadow_fraction(z, valid, shift=self.shift, **self._cast())
        ok = np.asarray(valid, bool) & np.isfinite(z)
        return ill.cell_fraction(sub_cells, ill.SUPERSAMPLE, self.shift, ok).astype(np.float32)

    def sub_cells(self, z, valid):
        """The cast shadow on the sub-cell grid (unmoved), as the prior casts it (with the
        clearance): what is registered is the prior the refinement starts from."""
        return ill.sub_cell_shadow(z, valid, **self._cast())

    def heights(self, z, valid):
        """The heights moved with the cast shadow (bilinear; NaN where the nearest source
        cell has none), so that a caster's top stays beside its shadow."""
        z = np.where(valid, z, np.nan)
        if self.shift == (0.0, 0.0):
            return z
        ok = ndimage.shift(np.isfinite(z).astype(np.float64), self.shift, order=0, cval=0.0)
        filled = np.where(np.isfinite(z), z, np.nanmean(z) if np.isfinite(z).any() else 0.0)
        moved = ndimage.shift(filled, self.shift, order=1, mode="nearest")
        return np.where(ok > 0.5, moved, np.nan)


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


def _open_surface(surface: SurfaceModel, dual, block_rows, stack, progress) -> _Surface | None:
    """Check the surface model against the image and find its relief (how far its shadows
    reach) and whether it has walls (blocks or smooth surface, as ``sun-shadow``)."""
    from ..shadow.surface import choose_surface
    from .shadow_truth import relief_and_walls

    if not surface.dsm:
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
            place = grid_place(grid)
        elif dual.grid.transform is not None:
            matrix = ill.grid_matrix(georef.metric_matrix(dual.grid, f"image {dual.vnir.path}"))
            check_cell_size(surface.cell_size, matrix, f"image {dual.vnir.path}")
            place = grid_place(dual.grid)
        elif surface.cell_size:
            matrix = ill.grid_matrix(None, surface.cell_size)
            place = None
        else:
            raise ParameterError(
                f"surface model {surface.dsm} and the image have no geotransform: give "
                "'cell_size' (the DSM's cell size in metres)"
            )
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
    drow, dcol, rise = ill.sun_step(zen, az, matrix, 1.0)
    steps = ill.march_steps(relief, rise, (dual.height, dual.width), drow, dcol)
    return _Surface(
        src,
        zen,
        az,
        matrix,
        relief,
        kind,
        halo,
        float(surface.clearance),
        float(hi),
        dual.height,
        (drow, dcol, steps),
        how,
        float(surface.clearance) / rise if rise > 0 else 0.0,
    )


@operation(
    inputs=("vnir", "swir", "classes", "surface.dsm", "surface.igm", "surface.glt"),
    outputs=("output", "mask", "fraction"),
)
def shadow_map_file(
    vnir,
    swir=None,
    classes=None,
    *,
    output,
    mask=None,
    fraction=None,
    layout=DualLayout(),
    bands=BandChoice(),
    dark=DarkLevels(),
    surface=SurfaceModel(),
    detection=Detection(),
    calibration=MapCalibration(),
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Shadow mask and scene-calibrated shadow-fraction classes of a VNIR + SWIR flight line.

    Parameters
    ----------
    vnir : path
        VNIR file (ENVI or GeoTIFF, raw DN or radiance), or a merged VNIR+SWIR cube when
        ``swir`` is None.
    swir : path, optional
        SWIR file on the same pixel grid.
    classes : path, optional
        Class table (CSV or JSON) whose ratio intervals are scaled to the scene; None = Table 2.
    output : path
        Byte class raster (0 no shadow, 1–4 the classes, 255 nodata) with a colour table.
    mask : path, optional
        Binary shadow mask (1 shadow, 0 not, 255 nodata).
    fraction : path, optional
        The estimated shadow fraction (float32, 0–1; what the classes are cut from): the
        input of ``deshadow``.
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    bands : BandChoice
        The bands of the boresight ratio (Eq. 3) the classes are scaled by, nearest 920 nm
        (VNIR) and 1010 nm (SWIR) by default; its ``tolerance_nm`` also bounds the blue, NIR
        and SWIR ranges. The faces always give ``band_mode="wavelength"``.
    dark : DarkLevels
        Dark level (DN of zero signal) of each instrument (``vnir_dark``, ``swir_dark``);
        None = the sensor product's dark reference, else the header's 'dark level', else
        estimated from the data (dark object): :func:`geoboresight.io.dark.dark_level_of`.
        Give 0 for radiance.
    surface : SurfaceModel
        A surface model on the image's grid (``dsm``) and the sun (``sun_zenith``,
        ``sun_azimuth``; ``cell_size`` for a DSM without a geotransform): the cast shadow it
        predicts is the prior, the spectra refine its edges and fraction, and no pixel away
        from it is shadow, except where a caster beyond the model's edge could shade it
        (:func:`geoboresight.shadow.map.dsm_shadow_fraction`). How far the
        model and the image disagree is reported (best shift, share of predicted shadow that
        is spectrally lit). Default: none (spectral evidence only).
    detection : Detection
        ``core_darkness``: core shadow where the SWIR signal over its sunlit mode is at or
        below this (natural log, default ln 1/6; with a surface model only at the prior's
        edges and near the model's sunward edge);
        ``edge_pixels``: partial shadow is looked for this many pixels around it.
    calibration : MapCalibration
        The random sample that calibrates the map (``sample_size``, default 200,000;
        ``seed``) and the boresight offset of the SWIR relative to the VNIR (px,
        ``offset_along``, ``offset_across``; both None = measured on a central block).
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` (and ``mask``), the calibration (dark levels and their source, sunlit
        signals, sunlit ratio, class scale, offset), the class boundaries used, pixels per
        class, shadow pixels and ``warnings``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Table 2).
    Chavez, P.S. Remote Sens. Environ. 1988, 24, 459–479 (dark-object subtraction).
    """
    core_darkness, edge_pixels = detection.core_darkness, detection.edge_pixels
    sample = offset = calibration
    if int(edge_pixels) != edge_pixels or edge_pixels < 0:
        raise ParameterError(f"parameter 'edge_pixels': {edge_pixels!r} must be a whole number ≥ 0")
    edge_pixels = int(edge_pixels)
    base_table = class_table(classes)
    dual = io.as_dual(vnir, swir, layout)
    rb = dual.ratio_bands(bands)
    tolerance_nm = bands.tolerance_nm
    blue_b = band_range(dual.vnir, *smap.BLUE_NM, tolerance_nm=tolerance_nm)
    nir_b = band_range(dual.vnir, *smap.NIR_NM, tolerance_nm=tolerance_nm)
    swir_b = band_range(dual.swir, *smap.SWIR_NM, tolerance_nm=tolerance_nm)
    v_dark_b = sorted(set(_spread(dual.vnir.bands, DARK_BANDS) + blue_b + nir_b + [rb.vnir_band]))
    s_dark_b = sorted(set(_spread(dual.swir.bands, DARK_BANDS) + swir_b + [rb.swir_band]))
    progress.info(
        f"signals: blue bands {blue_b[0]}–{blue_b[-1]}, NIR bands {nir_b[0]}–{nir_b[-1]} of "
        f"{dual.vnir.path}, SWIR bands "
        f"{swir_b[0]}–{swir_b[-1]} of {dual.swir.path}; ratio {rb.swir_nm:.1f}/{rb.vnir_nm:.1f} nm"
    )
    warnings: list[str] = []
    strips = {"height": dual.height, "width": dual.width, "block_rows": block_rows}
    with contextlib.ExitStack() as stack:
        v_src = stack.enter_context(io.open_raster(dual.vnir.reads, "VNIR"))
        s_src = (
            v_src if dual.merged else stack.enter_context(io.open_raster(dual.swir.reads, "SWIR"))
        )
        dsm = _open_surface(surface, dual, block_rows, stack, progress)
        # Pass 1: a random sample of the line for the dark levels and the sunlit modes.
        sources = [(v_src, b) for b in v_dark_b] + [(s_src, b) for b in s_dark_b]
        pixels, ok = io.sample_windows(
            io.bands_reader(sources),
            size=sample.sample_size,
            seed=sample.seed,
            progress=progress.sub(0, 0.3),
            **strips,
        )
        if not ok.any():
            raise no_valid_error(vnir, "VNIR/SWIR image")
        nv = len(v_dark_b)
        vs, ss = pixels[:nv], pixels[nv:]
        # The physics the map needs, checked before calibrating: unsaturated pixels with
        # signal, and dark levels within the data's range (else "no shadow" would be reported).
        checks = {}
        for sensor, values, src in ((dual.vnir, vs, v_src), (dual.swir, ss, s_src)):
            label = f"{sensor.name} {sensor.path}"
            checks[sensor.name] = smap.check_sample(
                values, ok, None, name=label, saturation=_saturation(src)
            )
            if checks[sensor.name].saturated:
                warnings.append(
                    f"{sensor.name}: {checks[sensor.name].saturated} of {int(ok.sum())} sampled "
                    "pixels are saturated and were left out of the calibration"
                )
                progress.info(warnings[-1])
        ok = ok & checks["VNIR"].usable & checks["SWIR"].usable
        v_dark = _dark_level(dual.vnir, v_src, v_dark_b, dark.vnir_dark, vs, ok, progress)
        s_dark = _dark_level(dual.swir, s_src, s_dark_b, dark.swir_dark, ss, ok, progress)
        for sensor, values, level in ((dual.vnir, vs, v_dark), (dual.swir, ss, s_dark)):
            smap.check_sample(values, ok, level, name=f"{sensor.name} {sensor.path}")
        blue_lv = v_dark.for_bands(v_dark_b, blue_b)
        nir_lv = v_dark.for_bands(v_dark_b, nir_b)
        swir_lv = s_dark.for_bands(s_dark_b, swir_b)
        blue_s = smap.signal(vs[[v_dark_b.index(b) for b in blue_b]], blue_lv)
        nir_s = smap.signal(vs[[v_dark_b.index(b) for b in nir_b]], nir_lv)
        swir_s = smap.signal(ss[[s_dark_b.index(b) for b in swir_b]], swir_lv)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio_s = ss[s_dark_b.index(rb.swir_band)] / vs[v_dark_b.index(rb.vnir_band)]
        along, across, how = _offset(dual, v_src, s_src, rb, offset, progress)
        progress.info(f"boresight offset {along:+.2f} px along, {across:+.2f} px across ({how})")
        cal = smap.calibrate_shadow_map(
            blue_s,
            nir_s,
            swir_s,
            ratio_s,
            ok,
            vnir_dark=v_dark,
            swir_dark=s_dark,
            table=base_table,
            offset=(along, across),
            core=core_darkness,
        )
        progress.info(
            f"sunlit ratio {cal.ratio_mode:.3f}: Table 2's ratio bounds on this scene would be × "
            f"{cal.ratio_mode / smap.PAPER_SUNLIT_RATIO:.3f}: {cal.table.describe()}"
        )
        fraction_classes = "; ".join(f"{c.id}: {cls.fraction_text(c)}" for c in cal.table.classes)
        # Pass 2: the map, strip by strip (shadow.map.shadow_map_block); the halo covers the
        # SWIR shift and the edge search.
        read_image = io.bands_reader(
            [(v_src, b) for b in blue_b]
            + [(v_src, b) for b in nir_b]
            + [(s_src, b) for b in swir_b]
            + [(v_src, rb.vnir_band), (s_src, rb.swir_band)]  # valid in the ratio's bands too
        )
        if dsm is None:
            read = read_image
        else:
            read_z = io.band_reader(dsm.src, 1)

            def read(r0, r1):
                values, valid = read_image(r0, r1)
                z, z_ok = read_z(r0, r1)
                return values, valid, z, z_ok, r0

        at_nir, at_swir = len(blue_b), len(blue_b) + len(nir_b)
        at_end = at_swir + len(swir_b)
        levels = (blue_lv, nir_lv, swir_lv)

        def fraction_of(values, valid, prior=None, z=None, z_ok=None, unseen=None):
            """(shadow fraction, darkness) of a block of the read bands."""
            return smap.shadow_fraction_block(
                values[:at_nir],
                values[at_nir:at_swir],
                values[at_swir:at_end],
                valid,
                calibration=cal,
                dark_levels=levels,
                edge_pixels=edge_pixels,
                prior=prior,
                heights=None if z is None else dsm.heights(z, z_ok),
                clearance=0.0 if dsm is None else dsm.clearance,
                unseen=unseen,
                ray=None if dsm is None else dsm.ray,
                reach=0.0 if dsm is None else dsm.reach,
            )

        def kernel(values, valid, z=None, z_ok=None, r0=0):
            if z is None:
                f, _ = fraction_of(values, valid)
                return (
                    smap.shadow_classes(f, cal.table),
                    smap.shadow_mask(f),
                    f,
                    None,
                    None,
                    None,
                    None,
                )
            prior = dsm.prior(z, z_ok)
            unseen = dsm.unseen(z, z_ok, r0)
            f, d = fraction_of(values, valid, prior, z, z_ok, unseen)
            # Pixels the surface model has no height for (beyond its extent, its nodata): no
            # prior says anything there, so the spectra alone judge them, as without a model
            # (the prior's "no shadow away from the predicted shadow" would drop them all).
            holes = valid & ~z_ok
            if holes.any():
                f_spectral, _ = fraction_of(values, valid)
                f = np.where(holes, f_spectral, f)
            c = smap.shadow_classes(f, cal.table)
            m = smap.shadow_mask(f)
            # Predicted shadow away from its edges, and the part of it spectrally lit.
            deep = ndimage.binary_erosion(prior >= 0.5) & np.isfinite(f)
            with np.errstate(invalid="ignore"):
                lit = deep & (d > smap.LIT_DARKNESS)
            return c, m, f, deep, lit, unseen & np.isfinite(f), holes & np.isfinite(f)

        halo = smap.shadow_map_halo(cal, edge_pixels)
        if dsm is None:
            halo = (halo, halo)
        else:
            # The sweep of the predicted shadow's far end looks this many lines towards the sun.
            sweep = int(np.ceil(dsm.reach * abs(dsm.ray[0]))) + 1
            up, down = (sweep, 0) if dsm.ray[0] < 0 else (0, sweep)
            halo = (halo + dsm.halo[0] + up, halo + dsm.halo[1] + down)
        agreement = {}
        if dsm is not None:
            # Registration, on a central block of lines (as the boresight offset): the cast
            # shadow is moved by the sub-pixel shift that best matches the NIR's darkness
            # (applied), then the best whole-pixel shift of what remains onto the dark pixels
            # is reported (a DSM more than a pixel off, another date).
            r0 = max(0, dual.height // 2 - OFFSET_ROWS // 2)
            r1 = min(dual.height, r0 + OFFSET_ROWS)
            values, valid, z, z_ok, _ = read(r0, r1)
            sub_cells = dsm.sub_cells(z, z_ok)  # cast once: registered, then the prior
            agreement = smap.registration_result()
            if surface.register:
                nir = smap.signal(values[at_nir:at_swir], nir_lv)
                agreement = smap.prior_registration(
                    smap.nir_darkness(nir, cal, valid & z_ok), sub_cells, ill.SUPERSAMPLE
                )
                dsm = dataclasses.replace(
                    dsm,
                    shift=(
                        agreement["dsm_registration_rows"],
                        agreement["dsm_registration_columns"],
                    ),
                )
            prior_c = dsm.prior(z, z_ok, sub_cells)
            _, d_c = fraction_of(values, valid, prior_c, z, z_ok, dsm.unseen(z, z_ok, r0))
            agreement.update(smap.prior_agreement(d_c, prior_c, valid))

        tags = {
            "product": "boresight shadow map: mask and scene-calibrated Table 2 classes "
            "(Brook & Ben-Dor 2011, §3.1)",
            "vnir": dual.vnir.path,
            "swir": dual.swir.path,
            **{k: str(v) for k, v in cal.as_dict().items()},
            "classes": fraction_classes,
            "table2_ratio_bounds_on_scene": cal.table.describe(),
            "table2_ratio_bounds_csv": class_table_csv(cal.table).replace("\n", " | "),
            "method": "dark-object subtraction; SWIR darkness against its sunlit mode (core ≤ "
            f"{core_darkness:.3f}, natural log) on the SWIR resampled by the boresight offset; "
            "not water (blue/NIR); shadow fraction of the pixels within "
            f"{edge_pixels} px by unmixing between the local sunlit and core-shadow signals; "
            "classes by Table 2's fraction intervals",
        }
        if dsm is not None:
            tags.update(
                dsm=surface.dsm,
                sun_zenith_deg=str(dsm.zenith),
                sun_azimuth_deg=str(dsm.azimuth),
                sun_position=dsm.sun,
                **({"igm": surface.igm} if surface.igm else {}),
                **({"glt": surface.glt} if surface.glt else {}),
                dsm_surface=dsm.surface,
                dsm_registration_rows=str(dsm.shift[0]),
                dsm_registration_columns=str(dsm.shift[1]),
                method="surface model prior: cast shadow from the DSM and the sun (ray march, "
                f"{dsm.surface} surface"
                + (
                    f", moved by {dsm.shift[0]:+.2f} rows and {dsm.shift[1]:+.2f} columns to "
                    "match the NIR's darkness"
                    if surface.register
                    else ""
                )
                + "), refined by SWIR/NIR darkness within "
                f"{smap.DSM_TOLERANCE} px (lit above ln 1/2 of the sunlit mode, rim shadow at "
                f"or below ln 1/3 unless more than the clearance ({dsm.clearance:g} m) above the "
                "shadow: a caster's top; beyond it, down-sun of the predicted shadow by the "
                f"{dsm.reach:.2f} cells the clearance shortens a shadow, where connected to it "
                "along the sun's direction) and unmixed within "
                f"{edge_pixels} px (at least half shaded only where as dark as core shadow or "
                "deep in the prediction; beside it, no more shaded than the signal says against "
                "the darkest lit pixel next to the zone); no shadow away from the predicted "
                "shadow except where a caster beyond the surface model's edge could shade (spectral "
                "estimate there) and in cells the model shades in part that are as dark as core "
                "shadow; classes by Table 2's fraction intervals",
            )
        counts = np.zeros(256, np.int64)
        n_shadow = 0
        dst = stack.enter_context(
            io.create_class_raster(
                output,
                dual.grid,
                tags=tags,
                band_name="shadow class (scene-calibrated Table 2)",
                colormap=cal.table.colormap(),
                category_names=cal.table.names(),
                band_tags={f"CLASS_{k}": v for k, v in cal.table.names().items()},
            )
        )
        mdst = None
        if mask:
            mdst = stack.enter_context(mask_raster(mask, dual.grid, tags, "shadow mask"))
        fdst = None
        if fraction:
            fdst = stack.enter_context(
                io.create_raster(
                    fraction,
                    dual.grid,
                    tags={**tags, "product": "estimated shadow fraction (0–1)"},
                    band_names=["shadow fraction"],
                )
            )
        n_deep = n_lit = n_unseen = n_holes = 0
        for win, (c, m, f, deep, lit, unseen, holes) in io.map_windows(
            read,
            kernel,
            halo=halo,
            progress=progress.sub(0.3, 1.0),
            message="shadow map",
            **strips,
        ):
            dst.write(c, 1, window=win)
            if mdst is not None:
                mdst.write(m, 1, window=win)
            if fdst is not None:
                fdst.write(
                    np.where(np.isfinite(f), f, io.FLOAT_NODATA).astype("float32"), 1, window=win
                )
            counts += np.bincount(c.ravel(), minlength=256)
            n_shadow += int((m == cls.MASK_SHADOW).sum())
            if deep is not None:
                n_deep += int(deep.sum())
                n_lit += int(lit.sum())
                n_unseen += int(unseen.sum())
                n_holes += int(holes.sum())
        n_valid = int(counts[: cls.NODATA_CLASS].sum())
        if n_valid == 0:
            raise no_valid_error(vnir, "VNIR/SWIR image")
    share = n_shadow / n_valid
    if share > 0.6:
        warnings.append(
            f"{100 * share:.0f} % of the valid pixels are shadow: the sunlit mode may not be "
            "sunlit ground (a mostly shaded or dark scene); check the calibration"
        )
    if dsm is not None:
        lit_share = n_lit / n_deep if n_deep else 0.0
        agreement.update(
            dsm_surface=dsm.surface,
            dsm_relief_m=round(dsm.relief, 3),
            dsm_predicted_shadow_pixels=n_deep,
            dsm_predicted_shadow_lit_share=round(lit_share, 4),
            dsm_unseen_share=round(n_unseen / n_valid, 4),
            dsm_missing_share=round(n_holes / n_valid, 4),
        )
        if n_holes:
            warnings.append(
                f"the surface model has no height for {100 * n_holes / n_valid:.1f} % of the "
                "valid pixels (beyond its extent or nodata): the spectra alone judge them"
            )
        if surface.register:
            progress.info(
                "predicted shadow registered to the image: moved by "
                f"{agreement['dsm_registration_rows']:+.2f} rows, "
                f"{agreement['dsm_registration_columns']:+.2f} columns (correlation with the "
                f"NIR's darkness {agreement['dsm_registration_r0']} → "
                f"{agreement['dsm_registration_r']}, t = {agreement['dsm_registration_t']})"
            )
        progress.info(
            f"surface model against the image: {100 * lit_share:.1f} % of the predicted shadow "
            "(away from its edges) is spectrally lit; best shift of the predicted shadow "
            f"{agreement['dsm_shift_rows']:+d} rows, {agreement['dsm_shift_columns']:+d} columns "
            f"(IoU with the dark pixels {agreement['dsm_iou_at_shift']} there, "
            f"{agreement['dsm_iou']} unshifted); {100 * n_unseen / n_valid:.1f} % of the "
            "pixels could be shaded by casters beyond the surface model's edge (spectral "
            "estimate there)"
        )
        if lit_share > 0.2:
            warnings.append(
                f"{100 * lit_share:.0f} % of the shadow the surface model predicts is "
                "spectrally lit: the model may be of another date, not registered with the "
                "image, or the sun's angles wrong"
            )
        gain = (agreement["dsm_iou_at_shift"] or 0) - (agreement["dsm_iou"] or 0)
        if (agreement["dsm_shift_rows"], agreement["dsm_shift_columns"]) != (0, 0) and gain > 0.05:
            warnings.append(
                "the predicted shadow matches the image's dark pixels best shifted by "
                f"{agreement['dsm_shift_rows']:+d} rows, {agreement['dsm_shift_columns']:+d} "
                f"columns (IoU {agreement['dsm_iou']} → {agreement['dsm_iou_at_shift']}): the "
                "surface model is probably not registered with the image"
            )
    for w in warnings:
        progress.info(f"warning: {w}")
    result = {
        "output": output,
        "valid_pixels": n_valid,
        "shadow_pixels": n_shadow,
        "shadow_share": round(share, 4),
        **cal.as_dict(),
        "classes": fraction_classes,
        "table2_ratio_bounds_on_scene": cal.table.describe(),
        **agreement,
        "warnings": warnings,
    }
    if mask:
        result["mask"] = mask
    if fraction:
        result["fraction"] = fraction
    for c in cal.table.classes:
        result[f"class_{c.id}_pixels"] = int(counts[c.id])
    result["no_shadow_pixels"] = int(counts[cls.NO_SHADOW])
    return result
