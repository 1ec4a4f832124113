"""File-level sub-pixel anomaly detection and unmixing (paper §3.3): RX, SVDD and the boresight
indicator, score maps as vector features, linear unmixing and ROC curves. Whole flight lines,
streamed block by block.

SciPy's image module, scikit-learn, shapely and matplotlib are imported by the operations that
need them, so listing the operations and running RX load none of them.
"""

from __future__ import annotations

import contextlib
import os

import numpy as np

from .. import io
from ..anomaly import indicator as ind
from ..anomaly.bands import BandSelection, select_bands
from ..anomaly.indicator import THRESHOLD
from ..anomaly.polygons import FIELDS
from ..anomaly.roc import PFA, TITLE
from ..anomaly.rx import RXBackground
from ..anomaly.svdd import NU, SAMPLE_SIZE
from ..errors import InputError
from ..io.dual import DualLayout
from ._operation import operation

#: Lines per strip of a cube: 16 lines of a 286-sample AISA line = 4,576 pixels, so a strip's
#: float buffers stay within a few MB (cache-friendly; memory is a few strips per worker).
CUBE_BLOCK_ROWS = 16


def open_image(vnir, swir=None, layout=DualLayout(), spectral=BandSelection()):
    """``(cube, bands, wavelengths, fwhm)``: the image, the 0-based cube bands ``spectral``
    chooses among its good bands (an ENVI 'bbl' marks the others bad), and their centres and
    FWHM (nm, or None).

    A dual dataset (an opened :class:`~geoboresight.io.DualSensor`, VNIR and SWIR files, or a
    sensor product holding both) is read through :func:`~geoboresight.io.as_dual` with
    ``layout``: its sensors' bands, stacked VNIR then SWIR, from what GDAL opens for them. One
    plain file (a merged cube, or a VNIR or SWIR cube alone) is read whole, wavelengths or not.
    """
    from ..io.products import recognise

    if isinstance(vnir, io.DualSensor) or swir or recognise(vnir) is not None:
        dual = io.as_dual(vnir, swir, layout)
        cube, good, wl, fwhm = io.open_sensors((dual.vnir, dual.swir))
        label = ", ".join(dual.files)
    else:
        cube = io.open_cube([vnir])
        good = np.flatnonzero(cube.good)  # bands an ENVI 'bbl' marks bad are never used
        wl = None if cube.wavelengths is None else cube.wavelengths[good]
        fwhm = None if cube.fwhm is None else cube.fwhm[good]
        label = vnir
    pick = select_bands(wl, good.size, spectral.include_nm, spectral.exclude_nm)
    if pick.size < 2:
        cube.close()
        raise InputError(
            f"{label}: once the bands its ENVI 'bbl' marks bad are left out, {pick.size} band(s) "
            "remain: a detector needs at least 2 (check the header's 'bbl' and include_nm)"
        )
    return (
        cube,
        good[pick],
        None if wl is None else wl[pick],
        None if fwhm is None else fwhm[pick],
    )


def band_tags(wl, bands) -> dict:
    """Output tags naming the bands (1-based) and wavelengths a detector used."""
    return {
        "bands_used": ",".join(str(int(b) + 1) for b in bands),
        "wavelengths_used_nm": "" if wl is None else ",".join(f"{w:.1f}" for w in wl),
    }


def to_float32(score: np.ndarray) -> np.ndarray:
    """A score as written: float32, nodata -9999 where not finite."""
    return np.where(np.isfinite(score), score, io.FLOAT_NODATA).astype("float32")


@operation(inputs=("vnir", "swir"), outputs=("output",))
def rx_file(
    vnir,
    swir=None,
    *,
    output,
    layout=DualLayout(),
    spectral=BandSelection(),
    background=RXBackground(),
    regularize=0.0,
    precision="float64",
    block_rows=CUBE_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the RX anomaly score (squared Mahalanobis distance to the background) of an image.

    Pass 1 accumulates the scene mean and covariance over strips (float64, worker threads);
    pass 2 scores each strip: against the scene mean (global) or the mean of an ``outer``
    window minus an ``inner`` guard window around each pixel (local; strips read with
    ``outer - 1`` lines of halo, since windows are shifted to stay inside the image).

    Parameters
    ----------
    vnir : path or DualSensor
        Hyperspectral image (ENVI or GeoTIFF): a merged cube, the VNIR file, a sensor
        product, or a dataset opened with :func:`geoboresight.open_dual`.
    swir : path, optional
        SWIR file on the same pixel grid, stacked after the VNIR bands.
    output : path
        float32 score GeoTIFF on the image's grid, nodata -9999.
    layout : DualLayout
        How to read VNIR and SWIR files that do not say it all (band centres).
    spectral : BandSelection
        Wavelength ranges to use / leave out, e.g. ``include_nm="400-900,1000-1300"``
        (default: leave out the water-vapour absorption bands).
    background : RXBackground
        Scene mean (``mode="global"``), or a windowed mean (``"local"``, ``inner`` and
        ``outer`` window sizes); the covariance stays the scene's.
    regularize : float
        Ridge added to the covariance diagonal, as a fraction of the mean band variance.
    precision : {"float64", "float32"}
        Arithmetic of the scoring pass.
    block_rows : int
        Lines per strip.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the number of ``bands`` used and of ``background_pixels``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 11B).
    Reed, I.S.; Yu, X. Adaptive multiple-band CFAR detection of an optical pattern with unknown
    spectral distribution. IEEE Trans. Acoust. Speech Signal Process. 1990, 38, 1760–1770.
    """
    from ..anomaly import rx

    cube, bands, wl, _ = open_image(vnir, swir, layout, spectral)
    inner, outer = background.inner, background.outer
    with cube:
        local = background.local
        if local:
            rx.check_windows(inner, outer, cube.height, cube.width)
        strips = {
            "height": cube.height,
            "width": cube.width,
            "block_rows": block_rows,
            "workers": io.windows.default_workers(),
        }
        # Pass 1: strips in the files' own type (no float copy); the shift comes from the
        # first strip so that the sums do not depend on thread timing.
        first, first_valid = cube.read(0, min(block_rows, cube.height), bands, None)
        acc = rx.CovarianceAccumulator(
            len(bands), shift=rx.CovarianceAccumulator.strip_shift(first, first_valid)
        )
        del first, first_valid
        for _ in io.map_windows(
            cube.reader(bands, None),
            acc.add_cube,
            **strips,
            progress=progress.sub(0.0, 0.5),
            message="RX: background statistics",
        ):
            pass
        stats = acc.stats()
        det = rx.RXDetector(stats, regularize, wavelengths=wl, band_numbers=bands + 1)
        progress.info(f"RX on {len(bands)} bands, {stats.n} background pixels")
        tags = {
            "product": "RX anomaly score (squared Mahalanobis distance; paper §3.3)",
            **band_tags(wl, bands),
        }
        if local:
            tags["window"] = f"inner {inner} px, outer {outer} px"

            def score(data, valid, block):
                return rx.local_rx(
                    data,
                    det,
                    inner,
                    outer,
                    valid,
                    first_row=block.row0,
                    height=block.height,
                    rows=block.rows,
                    precision=precision,
                )

            scored = io.map_windows(
                cube.reader(bands, "float64"),
                score,
                **strips,
                # Windows are shifted to stay inside the image (as Spectral Python's), so a
                # pixel near the first or last line reaches up to outer - 1 lines away.
                halo=(outer - 1, outer - 1),
                pass_block=True,
                progress=progress.sub(0.5, 1.0),
                message="RX: scoring",
            )
        else:
            scored = io.map_windows(
                cube.reader(bands, None),
                lambda data, valid: det.score_cube(data, valid, precision),
                **strips,
                progress=progress.sub(0.5, 1.0),
                message="RX: scoring",
            )
        with io.create_raster(output, cube.grid, tags=tags, band_names=["RX score"]) as dst:
            for win, s in scored:
                dst.write(to_float32(s), 1, window=win)
    return {"output": output, "bands": len(bands), "background_pixels": stats.n}


@operation(inputs=("vnir", "swir"), outputs=("output",))
def svdd_file(
    vnir,
    swir=None,
    *,
    output,
    layout=DualLayout(),
    spectral=BandSelection(),
    sigma=0.0,
    nu=NU,
    sample_size=SAMPLE_SIZE,
    seed=0,
    block_rows=CUBE_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the SVDD anomaly score ``‖Φ(y) − a‖² − R²`` (Gaussian RBF kernel) of an image.

    The description is trained on pixels drawn uniformly at random over the whole flight line
    (``1.5 × sample_size + 10`` positions, nodata ones dropped, then at most ``sample_size``
    kept), then every strip is scored in worker threads.

    Parameters
    ----------
    vnir : path or DualSensor
        Hyperspectral image (ENVI or GeoTIFF): a merged cube, the VNIR file, a sensor
        product, or a dataset opened with :func:`geoboresight.open_dual`.
    swir : path, optional
        SWIR file on the same pixel grid, stacked after the VNIR bands.
    output : path
        float32 score GeoTIFF on the image's grid (positive outside the description), nodata
        -9999.
    layout : DualLayout
        How to read VNIR and SWIR files that do not say it all (band centres).
    spectral : BandSelection
        Wavelength ranges to use / leave out.
    sigma : float
        Kernel width in image units; 0: the median pairwise distance of the sample.
    nu : float
        Fraction of training pixels allowed outside the description (0–1].
    sample_size : int
        Background pixels drawn for training.
    seed : int
        Random seed of the sample (same seed, same result).
    block_rows : int
        Lines per strip.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the kernel width ``sigma`` and the number of ``support_vectors``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Eq. 7–9, Figure 11C).
    Tax, D.M.J.; Duin, R.P.W. Support vector data description. Mach. Learn. 2004, 54, 45–66.
    """
    from ..anomaly import svdd

    cube, bands, wl, _ = open_image(vnir, swir, layout, spectral)
    with cube:
        strips = {"height": cube.height, "width": cube.width, "block_rows": block_rows}
        rng = np.random.default_rng(seed)
        positions = svdd.sample_positions(cube.height * cube.width, sample_size, rng)

        # Only the lines holding drawn pixels are read (a thousand lines, not the line).
        values, ok = io.read_pixels(
            cube.reader(bands, None),
            positions,
            **strips,
            progress=progress.sub(0.0, 0.2),
            message="SVDD: background sample",
        )
        picked = values[:, ok].T.astype(np.float64)
        sample = svdd.keep_at_most(picked, sample_size, rng)
        model = svdd.fit_svdd(sample, sigma=sigma or None, nu=nu)
        progress.info(
            f"SVDD: {len(sample)} training pixels, σ = {model.sigma:.4g}"
            f"{'' if sigma else ' (median pairwise distance)'}, ν = {model.nu}, "
            f"{len(model.alpha)} support vectors"
        )
        tags = {
            "product": "SVDD anomaly score ||Φ(y)−a||² − R² (RBF kernel; paper Eq. 7–9)",
            "sigma": f"{model.sigma:.6g}",
            "nu": model.nu,
            "support_vectors": len(model.alpha),
            **band_tags(wl, bands),
        }
        with io.create_raster(output, cube.grid, tags=tags, band_names=["SVDD score"]) as dst:
            # Strips in the files' own type, scored in worker threads (thread-safe model).
            for win, s in io.map_windows(
                cube.reader(bands, None),
                model.score_cube,
                **strips,
                workers=io.windows.default_workers(),
                progress=progress.sub(0.2, 1.0),
                message="SVDD: scoring",
            ):
                dst.write(to_float32(s), 1, window=win)
    return {"output": output, "sigma": model.sigma, "support_vectors": len(model.alpha)}


@operation(inputs=("ratio",), outputs=("output", "anomalies"))
def boresight_indicator_file(
    ratio,
    *,
    output,
    anomalies=None,
    threshold=THRESHOLD,
    tail="both",
    window=0,
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the boresight anomaly indicator: the robust z-score of the boresight ratio.

    ``z = (r − median) / (1.4826 · MAD)`` over the scene (the exact median and MAD, in a few
    passes over the strips: memory does not grow with the line); with ``window`` > 1, ``r`` is
    first replaced by its difference to the median of its ``window`` × ``window`` neighbourhood
    (strips read with ``window // 2`` lines of halo; the residuals are spilled once to a
    temporary file beside ``output`` for their median and MAD). Pixels whose score exceeds
    ``threshold`` are anomalies.

    Parameters
    ----------
    ratio : path
        Boresight ratio raster (the ``ratio_file`` output).
    output : path
        float32 score GeoTIFF (|z|, z or −z by ``tail``), nodata -9999.
    anomalies : path, optional
        uint8 GeoTIFF, 1 = anomaly, 0 = background, 255 = nodata.
    threshold : float
        Threshold on the score (σ units; the paper's 3σ rule).
    tail : {"both", "high", "low"}
        Which side of the ratio's distribution stands out.
    window : int
        Odd window of the local median reference; 0 (or 1): the whole scene.
    block_rows : int
        Lines per strip.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, ``anomalies``, the anomaly ``count``, the reference ``median`` and
        ``robust_sigma``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 11D).
    """
    ind.check_options(threshold, tail, window)
    local = bool(window and window > 1)
    passes = 3 if local else 2
    with io.open_raster(ratio, "ratio raster") as src:
        grid = io.Grid.of(src)
        read = io.band_reader(src, 1)
        strips = {"height": grid.height, "width": grid.width, "block_rows": block_rows}
        # The scene's median and MAD are exact order statistics found in a few passes over
        # the strips (memory flat in the line's length), as `stats` finds its percentiles.
        stats_share = progress.sub(0.0, 1 - 1 / passes)
        raw = io.windows.value_passes(
            read,
            ind.valid_values,
            **strips,
            progress=stats_share.sub(0.0, 0.5 if local else 1.0),
            message="indicator: scene statistics",
            passes=5,  # count and extremes, then the median and the MAD, two passes each
        )
        median, sigma = ind.robust_location_blocks(raw)
        fill = None
        halo = (0, 0)
        if local:
            # The scene's median fills nodata in every strip's median filter, as in one
            # whole-image filter; the residuals' own median and MAD are the reference. The
            # residuals (a median filter per strip) are computed once and spilled to disk.
            fill = median
            halo = (window // 2, window // 2)
            with io.Spill(near=output) as spill:
                for _, res in io.map_windows(
                    read,
                    lambda r, ok: ind.local_residual(r, ok, window=window, fill=fill),
                    **strips,
                    halo=halo,
                    progress=stats_share.sub(0.5, 0.75),
                    message="indicator: local residuals",
                ):
                    spill.append(ind.valid_values(res))
                median, sigma = ind.robust_location_blocks(spill.blocks)
        progress.info(f"boresight ratio median {median:.5g}, robust σ {sigma:.4g}")

        def score(r, ok):
            x = ind.local_residual(r, ok, window=window, fill=fill) if local else r
            s = ind.indicator_score(x, ok, median=median, sigma=sigma, tail=tail)
            with np.errstate(invalid="ignore"):
                return s, s > threshold, ok

        tags = {
            "product": "boresight indicator: robust z-score of the boresight ratio (paper §3.3)",
            "median": f"{median:.8g}",
            "robust_sigma": f"{sigma:.8g}",
            "tail": tail,
            "threshold": threshold,
        }
        count = 0
        with (
            io.create_raster(output, grid, tags=tags, band_names=["boresight z-score"]) as dst,
            _optional_mask(anomalies, grid, tags) as mask,
        ):
            for win, (s, flags, ok) in io.map_windows(
                read,
                score,
                **strips,
                halo=halo,
                progress=progress.sub(1 - 1 / passes, 1.0),
                message="indicator: scoring",
            ):
                dst.write(to_float32(s), 1, window=win)
                if mask is not None:
                    mask.write(np.where(ok, flags, 255).astype("uint8"), 1, window=win)
                count += int(flags.sum())
    progress.info(f"{count} pixel(s) beyond {threshold:g} σ")
    return {
        "output": output,
        "anomalies": anomalies,
        "count": count,
        "median": median,
        "robust_sigma": sigma,
    }


def _optional_mask(path, grid, tags):
    """The anomaly mask raster being written, or a context giving None without a path."""
    if not path:
        return contextlib.nullcontext(None)
    return io.create_raster(
        path,
        grid,
        dtype="uint8",
        nodata=255,
        tags=tags,
        band_names=["anomaly (1) / background (0)"],
    )


@operation(inputs=("score",), outputs=("output",))
def anomaly_polygons_file(
    score,
    *,
    output,
    threshold=None,
    geometry="polygon",
    min_pixels=1,
    progress=None,
) -> dict:
    """Write the groups of pixels of a score map at or above a threshold as a vector layer.

    Pixels are grouped 8-connected; each group becomes its pixel outline (polygon) or the
    centre of its highest-scoring pixel (point), with ``n_pixels``, ``score_max``,
    ``score_mean`` and the peak's ``row`` and ``col``. Coordinates follow the raster's CRS and
    geotransform; raw sensor geometry gives pixel coordinates and an undefined CRS.

    Parameters
    ----------
    score : path
        Anomaly score raster (RX, SVDD, boresight indicator), higher = more anomalous.
    output : path
        GeoPackage (or GeoJSON) layer ``anomalies``.
    threshold : float
        Score at or above which a pixel is an anomaly (required).
    geometry : {"polygon", "point"}
        Pixel outlines, or peak pixel centres.
    min_pixels : int
        Groups with fewer pixels are dropped.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` and the number of ``features``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 11 as vectors).
    """
    from ..anomaly.polygons import check_geometry, label_anomalies
    from ..io.anomaly import label_polygons, pixel_points
    from ..io.vector import write_vector

    if threshold is None:
        from ..errors import ParameterError

        raise ParameterError("parameter 'threshold' is required (the anomaly score threshold)")
    check_geometry(geometry)
    with io.open_raster(score, "score raster") as src:
        s, valid = io.read_masked(src, 1)
        grid = io.Grid.of(src)
    labels, table = label_anomalies(s, valid, threshold=threshold, min_pixels=min_pixels)
    if geometry == "point":
        geoms = pixel_points(table["row"], table["col"], grid.transform)
    else:
        outlines = label_polygons(labels, grid.transform)
        geoms = [outlines[int(i)] for i in table["id"]]
    write_vector(
        output,
        geoms,
        {k: table[k] for k in FIELDS},
        crs=grid.crs,
        layer="anomalies",
        description="anomalies (score ≥ threshold)",
    )
    progress.info(f"{len(geoms)} anomaly feature(s) at score ≥ {threshold:g}")
    return {"output": output, "features": len(geoms)}


@operation(inputs=("vnir", "swir", "endmembers"), outputs=("output",))
def unmix_file(
    vnir,
    endmembers,
    swir=None,
    *,
    output,
    layout=DualLayout(),
    spectral=BandSelection(),
    names="",
    method="fcls",
    image_scale=1.0,
    block_rows=CUBE_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the abundance of each endmember per pixel and the residual (linear unmixing).

    The endmember spectra are resampled to the image's band centres with Gaussian responses
    of the image's FWHM, then every strip is unmixed in worker threads.

    Parameters
    ----------
    vnir : path or DualSensor
        Hyperspectral image with wavelength metadata: a merged cube, the VNIR file, a sensor
        product, or a dataset opened with :func:`geoboresight.open_dual`.
    endmembers : path
        Endmember spectra: CSV (wavelength in nm first, one column per material) or an ENVI
        spectral library (.sli + .hdr).
    swir : path, optional
        SWIR file on the same pixel grid, stacked after the VNIR bands.
    output : path
        float32 GeoTIFF: one abundance band per endmember, then the residual RMS over bands;
        nodata -9999.
    layout : DualLayout
        How to read VNIR and SWIR files that do not say it all (band centres).
    spectral : BandSelection
        Wavelength ranges to use / leave out.
    names : str
        Endmembers to use, comma-separated (empty: all in the library).
    method : {"fcls", "nnls", "ucls"}
        Fully constrained (≥ 0, sum to 1; Eq. 11), non-negative, or unconstrained.
    image_scale : float
        Factor turning image values into the library's units (e.g. 0.0001).
    block_rows : int
        Lines per strip.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` and the ``endmembers`` used.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Eq. 10–11).
    Heinz, D.C.; Chang, C.-I. Fully constrained least squares linear spectral mixture analysis
    method for material quantification in hyperspectral imagery. IEEE Trans. Geosci. Remote
    Sens. 2001, 39, 529–545.
    """
    from ..anomaly import unmix
    from ..errors import InputError
    from ..io.spectra import read_spectral_library

    wl_lib, spectra, lib_names = read_spectral_library(endmembers)
    try:
        spectra, chosen = unmix.select_endmembers(
            spectra, lib_names, [n.strip() for n in (names or "").split(",")]
        )
    except InputError as exc:
        raise InputError(f"{endmembers}: {exc}") from None
    cube, bands, wl, fwhm = open_image(vnir, swir, layout, spectral)
    with cube:
        if wl is None:
            raise InputError(
                f"{vnir} has no wavelength metadata: endmembers cannot be resampled to its bands"
            )
        E = unmix.resample(wl_lib, spectra, wl, fwhm, chosen)
        unmix.check_endmembers(E, chosen)
        tags = {
            "product": f"linear unmixing ({method}; paper Eq. 10–11)",
            "endmembers": ",".join(chosen),
            "image_scale": image_scale,
            **band_tags(wl, bands),
        }
        band_names = [f"abundance {n}" for n in chosen] + ["residual RMS (phi)"]
        with io.create_raster(
            output, cube.grid, count=len(chosen) + 1, tags=tags, band_names=band_names
        ) as dst:
            for win, stack in io.map_windows(
                cube.reader(bands, "float64"),
                lambda data, valid: unmix.unmix_cube(
                    data, valid, endmembers=E, method=method, scale=image_scale
                ),
                height=cube.height,
                width=cube.width,
                block_rows=block_rows,
                workers=io.windows.default_workers(),
                progress=progress,
                message="unmixing",
            ):
                dst.write(to_float32(stack), window=win)
    return {"output": output, "endmembers": chosen}


@operation(inputs=("scores", "truth"), outputs=("output", "csv"))
def roc_file(
    scores,
    truth,
    *,
    output,
    csv=None,
    names="",
    truth_threshold=None,
    guard_px=0,
    pfa=PFA,
    title=TITLE,
    progress=None,
) -> dict:
    """Draw the ROC curves (Pd against Pfa) of several score maps against a truth raster.

    Parameters
    ----------
    scores : list of paths, or str
        Score rasters, higher = more anomalous (a list, or paths separated by commas).
    truth : path
        0/1 target mask, or an abundance raster, on the scores' grid.
    output : path
        PNG figure (linear and logarithmic Pfa).
    csv : path, optional
        The curves as CSV (detector, pfa, pd, threshold).
    names : str
        Detector names for the legend, comma-separated (default: the file names).
    truth_threshold : float, optional
        Truth value at or above which a pixel is a target (default: > 0).
    guard_px : int
        Pixels within this distance of a target are left out of the background.
    pfa : float
        False-alarm rate at which Pd is reported.
    title : str
        Figure title.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, ``csv``, and per detector ``auc_<name>`` and ``pd_at_pfa_<name>``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 12).
    """
    from ..anomaly import roc
    from ..errors import InputError, ParameterError
    from ..io.anomaly import write_roc_csv
    from ..io.write import save_figure

    paths = io.split_paths(scores)
    labels = [n.strip() for n in (names or "").split(",") if n.strip()]
    if labels and len(labels) != len(paths):
        raise ParameterError(
            f"parameter 'names': {len(labels)} name(s) for {len(paths)} score raster(s)"
        )
    labels = labels or [os.path.splitext(os.path.basename(p))[0] for p in paths]
    with io.open_raster(truth, "truth raster") as src:
        t, t_valid = io.read_masked(src, 1)
        grid = io.Grid.of(src)
    targets, background = roc.truth_mask(t, t_valid, threshold=truth_threshold, guard_px=guard_px)
    curves = {}
    for i, (name, path) in enumerate(zip(labels, paths, strict=True)):
        with io.open_raster(path, "score raster") as src:
            s, s_valid = io.read_masked(src, 1)
            io.Grid.of(src).require_same(grid, f"score raster {path}", f"truth {truth}")
        try:
            curves[name] = roc.roc_curve(np.where(s_valid, s, np.nan), targets, background)
        except InputError as exc:
            raise InputError(f"{truth}: {exc}") from None
        progress.update((i + 1) / len(paths), f"ROC {name}")
    save_figure(roc.roc_figure(curves, title=title, pfa_marker=pfa), output)
    if csv:
        write_roc_csv(csv, curves)
    result = {"output": output, "csv": csv}
    for name, c in curves.items():
        result[f"auc_{name}"] = round(c.auc, 6)
        result[f"pd_at_pfa_{name}"] = round(c.pd_at(pfa), 6)
        progress.info(
            f"{name}: AUC {c.auc:.4f}, Pd {c.pd_at(pfa):.3f} at Pfa {pfa:g} ({c.n_targets} target px)"
        )
    return result
