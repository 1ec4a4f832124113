"""File-level operations of the references the boresight shadow map is validated against
(paper §3.1): the ground-truth shadow of a surface model for a sun position, and the
ATCOR-4-style dark-pixel baseline. Each streams a raster strip by strip.
"""

from __future__ import annotations

import contextlib

import numpy as np

from .. import io
from ..errors import ParameterError
from ..io.checks import check_cell_size, check_heights, no_valid_error
from ..io.dual import TOLERANCE_NM
from ..io.georef import grid_place, metric_matrix
from ..io.wavelengths import nearest_band, wavelengths_of
from ..io.windows import Sample
from ..shadow import incidence
from ..shadow.classes import MASK_NODATA, MASK_SHADOW
from ..shadow.darkpixel import (
    DARK_PERCENTILE,
    DEFAULT_BANDS_NM,
    THRESHOLD,
    fit_dark_pixel,
)
from ..shadow.illumination import (
    MASK_FRACTION,
    SUPERSAMPLE,
    SURFACES,
    grid_matrix,
    halo_rows,
    shadow_fraction,
)
from ..shadow.incidence import Z_FACTOR
from ..shadow.surface import AUTO, choose_surface
from ._shadow_masks import mask_raster
from ._surface import relief_and_walls, sun_angles

#: The dark-pixel bands as the text parameter gives them (nm, comma-separated).
BANDS_NM = ",".join(f"{b:g}" for b in DEFAULT_BANDS_NM)


# ---------------------------------------------------------------------------------- sun-shadow


def sun_shadow_file(
    dsm,
    *,
    output,
    sun_zenith=None,
    sun_azimuth=None,
    mask=None,
    hillshade=None,
    band=1,
    cell_size=None,
    supersample=SUPERSAMPLE,
    surface=AUTO,
    z_factor=Z_FACTOR,
    block_rows=io.DEFAULT_BLOCK_ROWS,
    acquisition_time=None,
    progress=None,
) -> dict:
    """Ground-truth shadow fraction, shadow mask and hillshade of a surface model.

    Cast shadows are found by marching towards the sun (the method of GRASS ``r.sunmask``) on
    ``supersample`` × ``supersample`` sub-cells; the hillshade is the cosine of the solar
    incidence angle from Horn's gradient (as ``gdaldem hillshade``). The model is streamed in
    strips read with a halo as deep as the longest shadow the relief can cast, so the shadow
    fraction equals one call on the whole surface model (the hillshade too, except next to
    nodata cells, which are filled with the mean height of their strip).

    Parameters
    ----------
    dsm : path
        Surface model (heights in metres).
    output : path
        Shadow fraction (0–1, float32, nodata −9999).
    sun_zenith : float
        Sun zenith angle, degrees from vertical (0–90); or give ``acquisition_time``.
    sun_azimuth : float
        Sun azimuth, degrees clockwise from north towards the sun.
    mask : path, optional
        Shadow mask (1 where the fraction is at least 0.5, 0 not, 255 nodata).
    hillshade : path, optional
        Cosine of the solar incidence angle (float32).
    band : int
        Band of the surface model.
    cell_size : float, optional
        Cell size in metres for a surface model without a geotransform (row 0 is north).
    supersample : int
        Sub-cells per cell side.
    surface : {"auto", "blocks", "smooth"}
        Flat-topped cells (buildings) or an interpolated surface (terrain); ``auto`` chooses
        blocks when the DSM has walls (:func:`~geoboresight.shadow.surface.choose_surface`),
        else smooth.
    z_factor : float
        Vertical exaggeration of the hillshade.
    block_rows : int
        Lines per strip (without the halo).
    acquisition_time : str, optional
        ISO 8601 date and time (UTC without an offset): the sun's zenith and azimuth are
        computed for it at the surface model's centre (NREL's SPA,
        :func:`geoboresight.shadow.solar.sun_position`; the azimuth turned to the grid's
        north), instead of ``sun_zenith`` and ``sun_azimuth``. Needs a georeferenced model.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` (and ``mask``, ``hillshade``), shadow and valid pixels, and the relief (m).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1: the ground-truth
    shadow map from a surface model, hillshade and shadow model).
    """
    if acquisition_time is None:  # fail before reading anything
        sun_angles(sun_zenith, sun_azimuth, None, None, needed_by="dsm")
    if surface != AUTO and surface not in SURFACES:
        raise ParameterError(
            f"parameter 'surface': {surface!r} is not one of {AUTO}, {', '.join(SURFACES)}"
        )
    with io.open_raster(dsm, "surface model") as src:
        grid = io.Grid.of(src)
        matrix = grid_matrix(metric_matrix(grid, f"surface model {dsm}"), cell_size)
        if grid.georeferenced:
            check_cell_size(cell_size, matrix, f"surface model {dsm}")
        zen, az, how = sun_angles(
            sun_zenith, sun_azimuth, acquisition_time, grid_place(grid), needed_by="dsm"
        )
        if acquisition_time is not None:
            progress.info(f"sun zenith {zen:.2f}°, azimuth {az:.2f}°: {how}")
        read = io.band_reader(src, band)
        strips = {"height": grid.height, "width": grid.width, "block_rows": block_rows}

        # Pass 1: the relief bounds how far a shadow can reach; walls say blocks or terrain.
        lo, hi, n_valid, walls, pairs = relief_and_walls(
            read, matrix, progress=progress.sub(0, 0.1), message="relief", **strips
        )
        if n_valid == 0:
            raise no_valid_error(dsm, "surface model")
        check_heights(lo, hi, dsm)
        if surface == AUTO:
            surface = choose_surface(walls, pairs)
            progress.info(
                f"surface: {surface} ({walls} of {pairs} neighbouring-cell pairs are walls, "
                f"steps ≥ 2 m steeper than 70°)"
            )
        interpolation = SURFACES[surface]
        relief = hi - lo
        above, below = halo_rows(relief, zen, az, matrix, grid.shape)
        halo = (above + 1, below + 1)  # Horn's 3 × 3 window needs one more line
        tags = {
            "product": "ground-truth shadow fraction from a surface model (Brook & Ben-Dor 2011, §3.1)",
            "method": f"ray march towards the sun ({surface} surface), "
            f"{supersample}×{supersample} sub-cells",
            "sun_zenith_deg": zen,
            "sun_azimuth_deg": az,
            "sun_position": how,
            "dsm": dsm,
        }
        if not grid.georeferenced:
            tags["geometry"] = (
                f"raw grid, cell size {cell_size} m, row 0 = north edge, columns run east"
            )
        sun = {"sun_zenith": zen, "sun_azimuth": az, "transform": matrix}

        def kernel(z, valid):
            frac = shadow_fraction(
                z,
                valid,
                **sun,
                supersample=supersample,
                relief=relief,
                interpolation=interpolation,
            )
            cos_i = incidence.hillshade(z, valid, **sun, z_factor=z_factor) if hillshade else None
            return frac, valid, cos_i

        n_shadow = _write_sun_shadow(
            read, kernel, grid, tags, (output, mask, hillshade), halo, strips, progress
        )
    out = dict(output=output, shadow_pixels=n_shadow, valid_pixels=n_valid)
    out.update(relief_m=round(relief, 3), surface=surface)
    return out | {k: v for k, v in (("mask", mask), ("hillshade", hillshade)) if v}


def _write_sun_shadow(read, kernel, grid, tags, paths, halo, strips, progress) -> int:
    """The shadow fraction (and mask, hillshade) written strip by strip; the shadow pixels."""
    output, mask, hillshade = paths
    n_shadow = 0
    with contextlib.ExitStack() as stack:
        fdst = stack.enter_context(
            io.create_raster(output, grid, tags=tags, band_names=["shadow fraction"])
        )
        mdst = hdst = None
        if mask:
            mdst = stack.enter_context(
                mask_raster(mask, grid, tags, "shadow mask (fraction ≥ 0.5)")
            )
        if hillshade:
            hdst = stack.enter_context(
                io.create_raster(
                    hillshade,
                    grid,
                    tags={**tags, "product": "cosine of the solar incidence angle"},
                    band_names=["cos(incidence)"],
                )
            )
        for win, (frac, ok, cos_i) in io.map_windows(
            read,
            kernel,
            halo=halo,
            progress=progress.sub(0.1, 1.0),
            message="marching towards the sun",
            **strips,
        ):
            fdst.write(np.where(ok, frac, io.FLOAT_NODATA).astype("float32"), 1, window=win)
            shadow = frac >= MASK_FRACTION
            n_shadow += int(shadow[ok].sum())
            if mdst is not None:
                m = np.where(ok, shadow.astype(np.uint8), MASK_NODATA)
                mdst.write(m.astype(np.uint8), 1, window=win)
            if hdst is not None:
                hdst.write(np.where(ok, cos_i, io.FLOAT_NODATA).astype("float32"), 1, window=win)
    return n_shadow


# --------------------------------------------------------------------------- dark-pixel-shadow


def _wavelength_list(text) -> list[float]:
    """The ``bands_nm`` parameter: nm, comma- or semicolon-separated (or a sequence)."""
    try:
        if isinstance(text, str):
            vals = [float(v) for v in text.replace(";", ",").split(",") if v.strip()]
        else:
            vals = [float(v) for v in text]
    except (TypeError, ValueError):
        raise ParameterError(
            f"parameter 'bands_nm': {text!r} is not a comma-separated list of nm"
        ) from None
    if len(vals) < 2:
        raise ParameterError("parameter 'bands_nm': give at least two wavelengths (visible …, NIR)")
    return vals


def dark_pixel_shadow_file(
    vnir,
    *,
    output,
    shadow_function=None,
    bands_nm=BANDS_NM,
    vnir_wavelengths=None,
    tolerance_nm=TOLERANCE_NM,
    dark_percentile=DARK_PERCENTILE,
    threshold=THRESHOLD,
    sample=Sample(),
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Statistical dark-pixel shadow mask of the ATCOR-4 kind, the paper's baseline.

    Core-shadow candidates are the pixels darkest in the NIR and in the visible; a matched
    filter from the scene statistics (on a random sample of the flight line) gives each pixel a
    shadow function Φ (0 scene average, 1 like the candidates); the mask is Φ ≥ ``threshold``.

    Parameters
    ----------
    vnir : path
        VNIR image or merged cube with wavelength metadata.
    output : path
        Shadow mask (byte: 1 shadow, 0 not, 255 nodata).
    shadow_function : path, optional
        Shadow function Φ (float32, nodata −9999).
    bands_nm : str
        Wavelengths of the bands used (nm, comma-separated; the longest is the NIR).
    vnir_wavelengths : str, optional
        Band centres of the VNIR file in nm, comma-separated (only if it has none).
    tolerance_nm : float
        Largest distance from a requested wavelength to a band centre.
    dark_percentile : float
        Candidates are darker than this percentile of the scene (NIR and visible).
    threshold : float
        Shadow where Φ reaches this value.
    sample : Sample
        The random sample of the statistics: ``sample_size`` pixels (default 50,000) and
        ``seed`` (same seed, same result).
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` (and ``shadow_function``), the shadow pixels and the number of candidates.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1: the comparison
    with ATCOR-4's statistical shadow detection). Richter, R.; Müller, A. De-shadowing of
    satellite/airborne imagery. Int. J. Remote Sens. 2005, 26, 3137–3148.

    Examples
    --------
    >>> import geoboresight as gb
    >>> result = gb.dark_pixel_shadow_file("sample_data/scene/vnir.hdr", output="out/dark.tif")
    >>> result["shadow_pixels"]
    12980
    """
    targets = _wavelength_list(bands_nm)
    with io.open_raster(vnir, "VNIR image") as src:
        grid = io.Grid.of(src)
        wl = wavelengths_of(src, vnir, vnir_wavelengths, "--vnir-wavelengths / vnir_wavelengths=")[
            0
        ]
        bands = [nearest_band(wl, b, tolerance_nm, vnir) + 1 for b in targets]
        nir_index = int(np.argmax(targets))
        progress.info("dark-pixel bands: " + ", ".join(f"{b} ({wl[b - 1]:.0f} nm)" for b in bands))
        read = io.bands_reader([(src, b) for b in bands])
        strips = {"height": grid.height, "width": grid.width, "block_rows": block_rows}
        pixels, ok = io.sample_windows(
            read,
            size=sample.sample_size,
            seed=sample.seed,
            progress=progress.sub(0, 0.3),
            **strips,
        )
        if not ok.any():
            raise no_valid_error(vnir, "VNIR image")
        model = fit_dark_pixel(
            pixels,
            ok,
            nir_index=nir_index,
            dark_percentile=dark_percentile,
            threshold=threshold,
        )
        tags = {
            "product": "dark-pixel shadow mask (ATCOR-4-style statistical baseline)",
            "bands": ",".join(str(b) for b in bands),
            "dark_percentile": dark_percentile,
            "threshold": threshold,
        }

        def kernel(x, valid):
            phi = model.shadow_function(x, valid) if shadow_function else None
            return model.mask(x, valid), phi

        n_shadow = 0
        with contextlib.ExitStack() as stack:
            dst = stack.enter_context(mask_raster(output, grid, tags, "dark-pixel shadow"))
            pdst = None
            if shadow_function:
                pdst = stack.enter_context(
                    io.create_raster(
                        shadow_function, grid, tags=tags, band_names=["shadow function"]
                    )
                )
            for win, (m, phi) in io.map_windows(
                read, kernel, progress=progress.sub(0.3, 1.0), message="dark pixels", **strips
            ):
                dst.write(m, 1, window=win)
                n_shadow += int((m == MASK_SHADOW).sum())
                if pdst is not None:
                    pdst.write(np.where(np.isfinite(phi), phi, io.FLOAT_NODATA), 1, window=win)
    out = {"output": output, "shadow_pixels": n_shadow, "candidates": model.n_candidates}
    if shadow_function:
        out["shadow_function"] = shadow_function
    return out
