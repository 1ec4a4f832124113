"""File-level operations of the shadow application (paper §3.1) on the boresight ratio: Table 2
classes and mask, the scene-adaptive shadow cluster (Figure 4), the shadow-fraction model
(Figure 5B: fit and apply) and shadow polygons. Each streams a flight line strip by strip.

The references the boresight shadow is compared with (ground truth from a surface model, the
dark-pixel baseline) are in :mod:`geoboresight.operations.shadow_truth`.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np

from .. import io
from ..errors import ParameterError
from ..io.checks import check_fraction, no_valid_error
from ..io.dual import TOLERANCE_NM
from ..io.wavelengths import nearest_band, wavelengths_of
from ..io.windows import Sample
from ..shadow.classes import (
    MASK_FRACTION,
    MASK_SHADOW,
    MODE_BINS,
    NO_SHADOW,
    NODATA_CLASS,
    histogram_mode,
    ratio_histogram,
    table_warnings,
)
from ..shadow.cluster import NIR_NM, PROBABILITY, fit_shadow_cluster, shadow_mask
from ..shadow.fraction import PAPER_INTERCEPT, PAPER_SLOPE, FractionAccumulator, FractionModel
from ..shadow.polygons import MIN_PIXELS
from ._shadow_masks import mask_raster, masked_reader
from ._shadow_tables import class_polygons, class_table, class_table_csv, read_fraction_model

#: Points drawn at most for a scatter plot.
PLOT_POINTS = 20000


@dataclass(frozen=True)
class NirBand:
    """The VNIR band ``shadow-cluster`` reads as its near-infrared axis: the band nearest
    ``nir_nm`` (nm; the paper's 941), at most ``tolerance_nm`` from it, among the VNIR file's
    band centres (``vnir_wavelengths``, nm comma-separated, when the file has none)."""

    nir_nm: float = NIR_NM
    tolerance_nm: float = TOLERANCE_NM
    vnir_wavelengths: str | None = None


# ------------------------------------------------------------------------------ shadow-classes


def shadow_classes_file(
    ratio,
    classes=None,
    *,
    output,
    mask=None,
    band=1,
    band_nm=None,
    mask_fraction=MASK_FRACTION,
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Classify a boresight ratio raster into shadow-fraction classes (Table 2), and a mask.

    Parameters
    ----------
    ratio : path
        Boresight ratio raster (output of ``ratio``).
    classes : path, optional
        Class table (CSV or JSON: class,min,max,fraction_min,fraction_max,name,colour);
        None = Table 2 of the paper.
    output : path
        Byte class raster (0 no shadow, class ids, 255 nodata) with a colour table and
        category names.
    mask : path, optional
        Binary shadow mask (1 shadow, 0 not, 255 nodata) of the classes whose shadow fraction
        starts at or above ``mask_fraction``.
    band : int
        Band of the ratio raster.
    band_nm : float, optional
        The band by its centre wavelength (nm) instead: the band nearest it becomes ``band``.
    mask_fraction : float
        Lowest shadow fraction (0–1) of a class in the mask.
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` (and ``mask``), the valid pixels and the pixels of each class.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Table 2).

    Examples
    --------
    Table 2's classes of the sample scene's boresight ratio:

    >>> import geoboresight as gb
    >>> _ = gb.ratio_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                   output="out/ratio.tif")
    >>> result = gb.shadow_classes_file("out/ratio.tif", output="out/classes.tif")
    >>> result["class_1_pixels"], result["no_shadow_pixels"]
    (7871, 4255)
    """
    table = class_table(classes)
    ids = table.shadow_ids(mask_fraction)
    if mask and not ids:
        raise ParameterError(
            f"parameter 'mask_fraction': no class reaches {mask_fraction:g} shadow fraction, so the "
            "mask would be empty; lower it or change the class table"
        )
    progress.info(f"classes: {table.describe()}")
    tags = {
        "product": "boresight shadow classes (Brook & Ben-Dor 2011, §3.1, Table 2)",
        "source": ratio,
        "classes": table.describe(),
        "class_table_csv": class_table_csv(table).replace("\n", " | "),
    }

    def kernel(values, valid):
        c = table.classify(values, valid)
        m = table.mask(c, mask_fraction) if mask else None
        return c, m, np.bincount(c.ravel(), minlength=256), ratio_histogram(values, valid)

    counts = np.zeros(256, dtype=np.int64)
    hist = np.zeros(len(MODE_BINS) - 1, dtype=np.int64)
    with contextlib.ExitStack() as stack:
        src = stack.enter_context(io.open_raster(ratio, "ratio raster"))
        grid = io.Grid.of(src)
        dst = stack.enter_context(
            io.create_class_raster(
                output,
                grid,
                tags=tags,
                band_name="shadow class",
                colormap=table.colormap(),
                category_names=table.names(),
                band_tags={f"CLASS_{k}": v for k, v in table.names().items()},
            )
        )
        mdst = None
        if mask:
            mdst = stack.enter_context(
                mask_raster(
                    mask,
                    grid,
                    {**tags, "mask": f"classes {list(ids)} (shadow fraction ≥ {mask_fraction:g})"},
                    f"shadow mask (fraction ≥ {mask_fraction:g})",
                )
            )
        for win, (c, m, n, h) in io.map_windows(
            io.band_reader(src, band),
            kernel,
            height=grid.height,
            width=grid.width,
            block_rows=block_rows,
            progress=progress,
            message="classifying",
        ):
            dst.write(c, 1, window=win)
            if mdst is not None:
                mdst.write(m, 1, window=win)
            counts += n
            hist += h
        if counts[:NODATA_CLASS].sum() == 0:
            raise no_valid_error(ratio)
        rtags = src.tags()
    # Say when the fixed thresholds cannot mean what Table 2 says on this scene.
    bands_nm = {}
    with contextlib.suppress(KeyError, ValueError):
        bands_nm = {
            "vnir_nm": float(rtags["denominator_wavelength_nm"]),
            "swir_nm": float(rtags["numerator_wavelength_nm"]),
        }
    mode = histogram_mode(hist)
    warnings = table_warnings(table, mode, **bands_nm) if classes is None else []
    for w in warnings:
        progress.info(f"warning: {w}")
    result = {"output": output, "valid_pixels": int(counts[:NODATA_CLASS].sum())}
    if mask:
        result["mask"] = mask
    for c in table.classes:
        result[f"class_{c.id}_pixels"] = int(counts[c.id])
    result["no_shadow_pixels"] = int(counts[NO_SHADOW])
    result["ratio_mode"] = round(mode, 4)
    result["warnings"] = warnings
    return result


# ------------------------------------------------------------------------------ shadow-cluster


def _label_cluster(
    read, cluster, probability, grid, tags, output, probability_output, block_rows, progress
) -> int:
    """Write the shadow mask of the pixels whose shadow-component probability reaches
    ``probability`` (and the probability itself to ``probability_output``); the number of
    shadow pixels."""

    def kernel(pair, valid):
        p = cluster.probability(pair[0], pair[1], valid)
        return p, shadow_mask(p, probability)

    n_shadow = 0
    with contextlib.ExitStack() as stack:
        dst = stack.enter_context(mask_raster(output, grid, tags, "shadow mask"))
        pdst = None
        if probability_output:
            pdst = stack.enter_context(
                io.create_raster(
                    probability_output, grid, tags=tags, band_names=["shadow probability"]
                )
            )
        for win, (p, m) in io.map_windows(
            read,
            kernel,
            height=grid.height,
            width=grid.width,
            block_rows=block_rows,
            workers=io.windows.default_workers(),
            progress=progress,
            message="labelling",
        ):
            dst.write(m, 1, window=win)
            n_shadow += int((m == MASK_SHADOW).sum())
            if pdst is not None:
                pdst.write(np.where(np.isfinite(p), p, io.FLOAT_NODATA), 1, window=win)
    return n_shadow


def shadow_cluster_file(
    ratio,
    vnir,
    *,
    output,
    probability_output=None,
    plot=None,
    band=1,
    band_nm=None,
    nir=NirBand(),
    n_components=None,
    probability=PROBABILITY,
    sample=Sample(),
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Find the isolated shadow cluster in the (boresight ratio, 941 nm) scatter and map it.

    A Gaussian mixture (scikit-learn, BIC-selected) is fitted to a random sample of the whole
    flight line; every pixel gets the posterior probability of the shadow component.

    Parameters
    ----------
    ratio : path
        Boresight ratio raster.
    vnir : path
        VNIR image (or merged cube) on the ratio's grid, with wavelengths.
    output : path
        Shadow mask (byte: 1 shadow, 0 not, 255 nodata).
    probability_output : path, optional
        Shadow probability (0–1, float32, nodata −9999).
    plot : path, optional
        PNG scatter with the shadow cluster outlined (Figure 4).
    band : int
        Band of the ratio raster.
    band_nm : float, optional
        The band by its centre wavelength (nm) instead: the band nearest it becomes ``band``.
    nir : NirBand
        The VNIR band of the near-infrared axis: the band nearest ``nir_nm``, within
        ``tolerance_nm``, of the file's band centres (``vnir_wavelengths`` when it has none).
    n_components : int, optional
        Mixture components; None = chosen by BIC among 2–5.
    probability : float
        Posterior probability of the shadow component that makes a pixel shadow.
    sample : Sample
        The random sample the mixture is fitted to: ``sample_size`` pixels (default 50,000)
        and ``seed`` (same seed, same result; it also seeds the mixture).
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the number of components, the cluster's isolation (Bhattacharyya distance),
        the shadow pixels and the 941 nm band used.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Figure 4).

    Examples
    --------
    >>> import geoboresight as gb
    >>> _ = gb.ratio_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                   output="out/ratio.tif")
    >>> result = gb.shadow_cluster_file("out/ratio.tif", "sample_data/scene/vnir.hdr",
    ...                                 output="out/cluster.tif")
    >>> result["components"], result["shadow_pixels"]
    (5, 11726)
    """
    with (
        io.open_raster(ratio, "ratio raster") as rsrc,
        io.open_raster(vnir, "VNIR image") as vsrc,
    ):
        io.require_same_grid(rsrc, vsrc, "ratio raster", "VNIR image")
        grid = io.Grid.of(rsrc)
        wl = wavelengths_of(
            vsrc, vnir, nir.vnir_wavelengths, "--vnir-wavelengths / vnir_wavelengths="
        )[0]
        nir_band = nearest_band(wl, nir.nir_nm, nir.tolerance_nm, vnir) + 1
        nir_found = float(wl[nir_band - 1])
        progress.info(f"941 nm axis: band {nir_band} of {vnir} ({nir_found:.1f} nm)")
        read = io.bands_reader([(rsrc, band), (vsrc, nir_band)])
        pixels, ok = io.sample_windows(
            read,
            height=grid.height,
            width=grid.width,
            size=sample.sample_size,
            seed=sample.seed,
            block_rows=block_rows,
            progress=progress.sub(0, 0.3),
        )
        good = ok & np.isfinite(pixels).all(axis=0)
        if not good.any():
            raise no_valid_error(ratio)
        cluster = fit_shadow_cluster(
            pixels[0], pixels[1], good, n_components=n_components, seed=sample.seed
        )
        progress.info(
            f"Gaussian mixture: {cluster.n_components} components on {cluster.n_sample} pixels; "
            f"shadow component holds {100 * cluster.shadow_share:.1f} % of them; isolation "
            f"(Bhattacharyya distance) {cluster.isolation:.2f}"
        )
        warning = cluster.warning()
        if warning:
            progress.info(f"warning: {warning}")
        tags = {
            "product": "scene-adaptive boresight shadow mask (Brook & Ben-Dor 2011, §3.1, Fig. 4)",
            "method": "scikit-learn GaussianMixture on (log ratio, log 941 nm), BIC-selected",
            "ratio": ratio,
            "vnir": vnir,
            "nir_band": nir_band,
            "components": cluster.n_components,
            "probability_threshold": probability,
        }

        n_shadow = _label_cluster(
            read,
            cluster,
            probability,
            grid,
            tags,
            output,
            probability_output,
            block_rows,
            progress.sub(0.3, 0.95),
        )
        if plot:
            _cluster_plot(plot, pixels[:, good], cluster, probability, nir_found)
    out = {
        "output": output,
        "components": cluster.n_components,
        "isolation": round(cluster.isolation, 4),
        "shadow_pixels": n_shadow,
        "nir_band": nir_band,
        "warnings": [warning] if warning else [],
    }
    out.update((k, v) for k, v in (("probability_output", probability_output), ("plot", plot)) if v)
    return out


def _cluster_plot(plot, pixels, cluster, probability, nir_found) -> None:
    """The cluster figure of at most :data:`PLOT_POINTS` of the sampled (ratio, NIR) pairs."""
    from ..io.write import save_figure
    from ..shadow.plots import cluster_figure

    x, y = pixels[0, :PLOT_POINTS], pixels[1, :PLOT_POINTS]
    shaded = cluster.probability(x, y) >= probability
    save_figure(cluster_figure(x, y, shaded, cluster, nir_found), plot)


# ------------------------------------------------------------------------- shadow-fraction-fit


def shadow_fraction_fit_file(
    ratio,
    truth,
    mask=None,
    *,
    report=None,
    plot=None,
    band=1,
    band_nm=None,
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Fit ``ratio = a · fraction + b`` over detected shadow against a ground-truth fraction.

    Exact least squares over every selected pixel, streamed strip by strip.

    Parameters
    ----------
    ratio : path
        Boresight ratio raster.
    truth : path
        Ground-truth shadow fraction (0–1) on the ratio's grid (e.g. from ``sun-shadow``).
    mask : path, optional
        Detected shadow mask (1 = shadow) on the same grid; without it, the pixels whose ground
        truth is above 0 are fitted.
    report : path, optional
        The fitted model as JSON (the input of ``shadow-fraction-apply``).
    plot : path, optional
        PNG of the regression (Figure 5B).
    band : int
        Band of the ratio raster.
    band_nm : float, optional
        The band by its centre wavelength (nm) instead: the band nearest it becomes ``band``.
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``slope``, ``intercept``, ``r2`` and ``n`` (pixels fitted), and the outputs written.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Figure 5B:
    a = −0.74, b = 1.31, R² = 0.913).

    Examples
    --------
    The fraction model of the sample scene's ratio against its true shadow fraction:

    >>> import geoboresight as gb
    >>> _ = gb.ratio_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                   output="out/ratio.tif")
    >>> fit = gb.shadow_fraction_fit_file(
    ...     "out/ratio.tif", "sample_data/scene/truth_shadow_fraction.tif", report="out/fit.json"
    ... )
    >>> round(fit["slope"], 3), round(fit["intercept"], 3), fit["n"]
    (1.778, 1.812, 17534)
    """
    rng = np.random.default_rng(0)
    with contextlib.ExitStack() as stack:
        rsrc = stack.enter_context(io.open_raster(ratio, "ratio raster"))
        tsrc = stack.enter_context(io.open_raster(truth, "shadow-fraction raster"))
        io.require_same_grid(rsrc, tsrc, "ratio raster", "shadow-fraction raster")
        sources = [(rsrc, band), (tsrc, 1)]
        if mask:
            msrc = stack.enter_context(io.open_raster(mask, "shadow mask"))
            io.require_same_grid(rsrc, msrc, "ratio raster", "shadow mask")
            sources.append((msrc, 1))
        grid = io.Grid.of(rsrc)
        share = PLOT_POINTS / max(1, grid.height * grid.width) * 4

        def kernel(r, okr, f, okf, m=None, okm=None):
            check_fraction(f, okf, truth, "shadow-fraction raster")
            # Drawn in strip order in the calling thread: the plot's points are reproducible.
            sel = okr & okf & ((okm & (m == 1)) if m is not None else (f > 0))
            pick = None
            if plot and sel.any():
                pick = sel & (rng.random(sel.shape) < share)
            return r, f, sel, bool(okr.any()), pick

        acc = FractionAccumulator()
        any_valid = False
        keep_x, keep_y = [], []
        for _, (r, f, sel, any_r, pick) in io.map_windows(
            masked_reader(sources),
            kernel,
            height=grid.height,
            width=grid.width,
            block_rows=block_rows,
            progress=progress,
            message="fitting",
        ):
            acc.add(r, f, sel)
            any_valid |= any_r
            if pick is not None:
                keep_x.append(f[pick])
                keep_y.append(r[pick])
        if not any_valid:
            raise no_valid_error(ratio)
    model = acc.model()
    progress.info(
        f"ratio = {model.slope:.4g} · fraction + {model.intercept:.4g}; R² = {model.r2:.3f} "
        f"on {model.n} pixels (paper, Figure 5B: −0.74, 1.31, R² 0.913)"
    )
    if report:
        io.write_json(report, {**model.as_dict(), "ratio": ratio, "truth": truth, "mask": mask})
    if plot:
        from ..io.write import save_figure
        from ..shadow.plots import regression_figure

        x = np.concatenate(keep_x) if keep_x else np.zeros(0)
        y = np.concatenate(keep_y) if keep_y else np.zeros(0)
        save_figure(
            regression_figure(x, y, model, FractionModel(PAPER_SLOPE, PAPER_INTERCEPT)), plot
        )
    out = {"slope": model.slope, "intercept": model.intercept, "r2": model.r2, "n": model.n}
    if report:
        out["report"] = report
    if plot:
        out["plot"] = plot
    return out


# ----------------------------------------------------------------------- shadow-fraction-apply


def shadow_fraction_apply_file(
    ratio,
    model=None,
    *,
    output,
    band=1,
    band_nm=None,
    slope=PAPER_SLOPE,
    intercept=PAPER_INTERCEPT,
    no_clip=False,
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Turn the boresight ratio into a shadow fraction: ``fraction = (ratio − b) / a``.

    Parameters
    ----------
    ratio : path
        Boresight ratio raster.
    model : path, optional
        JSON report of ``shadow-fraction-fit``; its slope and intercept take precedence.
    output : path
        Shadow fraction (float32, nodata −9999).
    band : int
        Band of the ratio raster.
    band_nm : float, optional
        The band by its centre wavelength (nm) instead: the band nearest it becomes ``band``.
    slope, intercept : float
        a and b of ``ratio = a · fraction + b`` (default: the paper's Figure 5B).
    no_clip : bool
        Do not limit the fraction to 0–1.
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the slope and intercept used and the number of valid pixels.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Figure 5B).

    Examples
    --------
    With the paper's model (Table 2's regression):

    >>> import geoboresight as gb
    >>> _ = gb.ratio_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                   output="out/ratio.tif")
    >>> result = gb.shadow_fraction_apply_file("out/ratio.tif", output="out/fraction.tif")
    >>> result["slope"], result["intercept"]
    (-0.74, 1.31)
    """
    if model:
        slope, intercept = read_fraction_model(model)
    line = FractionModel(slope, intercept)
    tags = {
        "product": "shadow fraction from the boresight ratio (Brook & Ben-Dor 2011, Fig. 5B)",
        "model": f"ratio = {slope:.6g} * fraction + {intercept:.6g}",
        "source": ratio,
    }

    def kernel(values, valid):
        f = line.fraction(values, valid, clip=not no_clip)
        out = np.where(np.isfinite(f), f, io.FLOAT_NODATA).astype("float32")
        return out, int(valid.sum()), line.clipped(values, valid)

    n_valid = 0
    below = above = 0
    with io.open_raster(ratio, "ratio raster") as src:
        grid = io.Grid.of(src)
        with io.create_raster(output, grid, tags=tags, band_names=["shadow fraction"]) as dst:
            for win, (f, n, (b, a, _)) in io.map_windows(
                io.band_reader(src, band),
                kernel,
                height=grid.height,
                width=grid.width,
                block_rows=block_rows,
                progress=progress,
                message="applying",
            ):
                dst.write(f, 1, window=win)
                n_valid += n
                below += b
                above += a
            if n_valid == 0:
                raise no_valid_error(ratio)
    warning = line.range_warning(below, above, n_valid)
    if warning:
        progress.info(f"warning: {warning}")
    return {
        "output": output,
        "slope": slope,
        "intercept": intercept,
        "valid_pixels": n_valid,
        "outside_line_pixels": below + above,
        "warnings": [warning] if warning else [],
    }


# ----------------------------------------------------------------------------- shadow-polygons


def shadow_polygons_file(
    classes_raster,
    classes=None,
    *,
    output,
    min_pixels=MIN_PIXELS,
    progress=None,
) -> dict:
    """Vectorise a shadow class raster: one polygon per 4-connected patch of one class.

    Parameters
    ----------
    classes_raster : path
        Shadow class raster (output of ``shadow-classes``).
    classes : path, optional
        The class table it was made with (CSV or JSON); None = Table 2.
    output : path
        GeoPackage (.gpkg) or GeoJSON (.geojson) with the class id, name, shadow-fraction
        interval, area and pixels of each polygon, in the raster's CRS (raw sensor geometry:
        pixel coordinates, x = column, y = −line, area in pixels).
    min_pixels : int
        Polygons smaller than this many pixels are dropped.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the number of polygons and the geometry ("map" or raw pixel geometry).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Table 2,
    Figures 6–7).

    Examples
    --------
    >>> import geoboresight as gb
    >>> _ = gb.ratio_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                   output="out/ratio.tif")
    >>> _ = gb.shadow_classes_file("out/ratio.tif", output="out/classes.tif")
    >>> result = gb.shadow_polygons_file("out/classes.tif", output="out/shadow.gpkg")
    >>> result["polygons"], result["geometry"]
    (6076, 'raw sensor (pixel) geometry')
    """
    from ..io.vector import vector_format, write_vector

    table = class_table(classes)
    vector_format(output)  # a clear error for an unsupported extension, before any work
    with io.open_raster(classes_raster, "class raster") as src:
        data, ok = io.read_masked(src, 1)
        if not ok.any():
            raise no_valid_error(classes_raster, "class raster")
        grid = io.Grid.of(src)
        c = np.where(ok, data, NODATA_CLASS).astype(np.uint8)
        polys = class_polygons(c, table, grid.transform, min_pixels=min_pixels)
    progress.update(0.7, "polygons")
    georef = grid.georeferenced
    units = (
        "square map units of the raster CRS"
        if grid.crs
        else ("square map units" if georef else "pixels")
    )
    desc = (
        "Boresight shadow classes (Brook & Ben-Dor 2011, Table 2) as polygons; area in "
        f"{units}. "
        + (
            "Raw sensor geometry: no CRS; x = column, y = −line (pixel coordinates)."
            if not georef
            else ""
        )
    )
    fields = {
        "class": np.array([p.class_id for p in polys], dtype=np.int32),
        "name": np.array([p.name for p in polys], dtype=object),
        "fraction_min": np.array([p.fraction_min for p in polys], dtype=np.float64),
        "fraction_max": np.array([p.fraction_max for p in polys], dtype=np.float64),
        "area": np.array([p.area for p in polys], dtype=np.float64),
        "pixels": np.array([p.pixels for p in polys], dtype=np.int64),
    }
    write_vector(
        output,
        [p.geometry for p in polys],
        fields,
        crs=grid.crs,
        layer="shadow_polygons",
        description=desc,
    )
    progress.update(1.0, "written")
    return {
        "output": output,
        "polygons": len(polys),
        "geometry": "map" if georef else "raw sensor (pixel) geometry",
    }
