"""Specs of the shadow application (paper §3.1): classes, cluster, fraction model, ground truth,
dark-pixel baseline, polygons. Each ``run`` only wires files to the kernels in
:mod:`geoboresight.shadow`, streaming over blocks of lines."""

from __future__ import annotations

import contextlib
import json

import numpy as np
import rasterio

from .. import io
from ..errors import InputError, ParameterError
from ..io.wavelengths import nearest_band, wavelengths_of
from ..shadow import classes as cls
from ..shadow.cluster import fit_shadow_cluster
from ..shadow.darkpixel import DEFAULT_BANDS_NM, fit_dark_pixel
from ..shadow.fraction import (
    PAPER_INTERCEPT,
    PAPER_SLOPE,
    FractionAccumulator,
    FractionModel,
)
from ..shadow.illumination import check_sun, grid_matrix, halo_rows, hillshade, shadow_fraction
from ._common import BLOCK_ROWS, sample_size, seed
from .spec import (
    Algorithm,
    Band,
    Enum,
    FileIn,
    FileOut,
    Flag,
    Number,
    RasterIn,
    RasterOut,
    Text,
    VectorOut,
    Wavelength,
)

GROUP = "Shadow"
MASK_NODATA = 255

# ----------------------------------------------------------------------------------- helpers


def _mask_raster(path, grid, tags, band_name):
    return io.create_class_raster(
        path,
        grid,
        tags=tags,
        band_name=band_name,
        colormap={0: (255, 255, 255, 0), 1: (128, 0, 0, 255), MASK_NODATA: (0, 0, 0, 0)},
        category_names={0: "not shadow", 1: "shadow"},
    )


def _no_valid(path: str, what: str = "ratio raster") -> InputError:
    return InputError(
        f"{what} {path} has no valid pixel (every pixel is nodata or not finite): check the "
        "file and its nodata value"
    )


# ----------------------------------------------------------------------------- shadow-classes

RATIO = RasterIn(name="ratio", description="Boresight ratio raster (output of 'ratio')")
RATIO_BAND = Band(name="band", description="Band of the ratio raster", default=1, raster="ratio")


def _table(values) -> cls.ClassTable:
    path = values.get("classes")
    return cls.read_class_table(path) if path else cls.default_table()


def _run_classes(values, progress):
    table = _table(values)
    min_fraction = values["mask_fraction"]
    ids = table.shadow_ids(min_fraction)
    if values.get("mask") and not ids:
        raise ParameterError(
            f"parameter 'mask_fraction': no class reaches {min_fraction:g} shadow fraction, so the "
            "mask would be empty; lower it or change the class table"
        )
    progress.info(f"classes: {table.describe()}")
    tags = {
        "product": "boresight shadow classes (Brook & Ben-Dor 2011, §3.1, Table 2)",
        "source": values["ratio"],
        "classes": table.describe(),
        "class_table_csv": table.to_csv().replace("\n", " | "),
    }
    counts = np.zeros(256, dtype=np.int64)
    with contextlib.ExitStack() as stack:
        src = stack.enter_context(io.open_raster(values["ratio"], "ratio raster"))
        grid = io.grid_of(src)
        dst = stack.enter_context(
            io.create_class_raster(
                values["output"],
                grid,
                tags=tags,
                band_name="shadow class",
                colormap=table.colormap(),
                category_names=table.names(),
                band_tags={f"CLASS_{k}": v for k, v in table.names().items()},
            )
        )
        mdst = None
        if values.get("mask"):
            mdst = stack.enter_context(
                _mask_raster(
                    values["mask"],
                    grid,
                    {**tags, "mask": f"classes {list(ids)} (shadow fraction ≥ {min_fraction:g})"},
                    f"shadow mask (fraction ≥ {min_fraction:g})",
                )
            )
        windows = list(io.row_windows(src.height, src.width, values["block_rows"]))
        for i, win in enumerate(windows):
            ratio, ok = io.read_masked(src, values["band"], win)
            c = table.classify(ratio, ok)
            dst.write(c, 1, window=win)
            if mdst is not None:
                mdst.write(table.mask(c, min_fraction), 1, window=win)
            counts += np.bincount(c.ravel(), minlength=256)
            progress.update((i + 1) / len(windows), "classifying")
        if counts[: cls.NODATA_CLASS].sum() == 0:
            raise _no_valid(values["ratio"])
    valid = int(counts[: cls.NODATA_CLASS].sum())
    result = {"output": values["output"], "valid_pixels": valid}
    if values.get("mask"):
        result["mask"] = values["mask"]
    for c in table.classes:
        result[f"class_{c.id}_pixels"] = int(counts[c.id])
    result["no_shadow_pixels"] = int(counts[0])
    return result


CLASSES = Algorithm(
    name="shadow-classes",
    display_name="Shadow classes (Table 2)",
    group=GROUP,
    short_help="Classify the boresight ratio into shadow-fraction classes and a shadow mask.",
    help=(
        "Maps each boresight ratio value to a shadow-fraction class, by default Table 2 of "
        "Brook & Ben-Dor (2011): class 1 ratio 3.4–4 → 80–100 % shadow (maroon), class 2 "
        "2.5–3.4 → 50–80 % (magenta), class 3 2.1–2.5 → 20–50 % (cyan), class 4 1.9–2.1 → "
        "10–20 % (yellow); 0 = no shadow, 255 = nodata.\n\n"
        "The output is a byte raster with an embedded colour table and class names, so it opens "
        "styled in QGIS. The optional mask is 1 where the class means at least 'mask fraction' "
        "shadow.\n\n"
        "Table 2's thresholds were found on AISA-Dual DN; for other data give your own table "
        "(CSV with columns class,min,max,fraction_min,fraction_max,name,colour; intervals "
        "min ≤ ratio < max, listed in ratio order, not overlapping) or use 'Shadow cluster'."
    ),
    params=(
        RATIO,
        RATIO_BAND,
        FileIn(
            name="classes",
            description="Class table (CSV or JSON: class,min,max,fraction_min,fraction_max,name,colour); empty = Table 2",
            optional=True,
            extensions=("csv", "json"),
        ),
        Number(
            name="mask_fraction",
            description="The shadow mask holds classes whose shadow fraction starts at or above this (0–1)",
            default=0.5,
            minimum=0.0,
            maximum=1.0,
        ),
        BLOCK_ROWS,
        RasterOut(name="output", description="Shadow class raster (byte, colour table)"),
        RasterOut(name="mask", description="Binary shadow mask (1 shadow, 0 not)", optional=True),
    ),
    run=_run_classes,
)

# ----------------------------------------------------------------------------- shadow-cluster


def _run_cluster(values, progress):
    with (
        io.open_raster(values["ratio"], "ratio raster") as rsrc,
        io.open_raster(values["vnir"], "VNIR image") as vsrc,
    ):
        io.require_same_grid(rsrc, vsrc, "ratio raster", "VNIR image")
        wl = wavelengths_of(vsrc, values["vnir"], values.get("wavelengths"))[0]
        nir_band = nearest_band(wl, values["nir_nm"], values["tolerance_nm"], values["vnir"]) + 1
        nir_nm = float(wl[nir_band - 1])
        progress.info(f"941 nm axis: band {nir_band} of {values['vnir']} ({nir_nm:.1f} nm)")
        sample, ok = io.sample_pixels(
            [(rsrc, values["band"]), (vsrc, nir_band)],
            rsrc.height,
            rsrc.width,
            values["block_rows"],
            values["sample_size"],
            values["seed"],
            progress.sub(0, 0.3),
        )
        good = ok & np.isfinite(sample).all(axis=0)
        if not good.any():
            raise _no_valid(values["ratio"])
        cluster = fit_shadow_cluster(
            sample[0],
            sample[1],
            good,
            n_components=values.get("n_components"),
            seed=values["seed"],
        )
        progress.info(
            f"Gaussian mixture: {cluster.n_components} components on {cluster.n_sample} pixels; "
            f"shadow component holds {100 * cluster.shadow_share:.1f} % of them; isolation "
            f"(Bhattacharyya distance) {cluster.isolation:.2f}"
        )
        grid = io.grid_of(rsrc)
        tags = {
            "product": "scene-adaptive boresight shadow mask (Brook & Ben-Dor 2011, §3.1, Fig. 4)",
            "method": "scikit-learn GaussianMixture on (log ratio, log 941 nm), BIC-selected",
            "ratio": values["ratio"],
            "vnir": values["vnir"],
            "nir_band": nir_band,
            "components": cluster.n_components,
            "probability_threshold": values["probability"],
        }
        n_shadow = 0
        with contextlib.ExitStack() as stack:
            dst = stack.enter_context(_mask_raster(values["output"], grid, tags, "shadow mask"))
            pdst = None
            if values.get("probability_output"):
                pdst = stack.enter_context(
                    io.create_raster(
                        values["probability_output"],
                        grid,
                        tags=tags,
                        band_names=["shadow probability"],
                    )
                )
            windows = list(io.row_windows(rsrc.height, rsrc.width, values["block_rows"]))
            sub = progress.sub(0.3, 0.95)
            for i, win in enumerate(windows):
                r, okr = io.read_masked(rsrc, values["band"], win)
                v, okv = io.read_masked(vsrc, nir_band, win)
                p = cluster.probability(r, v, okr & okv)
                m = np.where(np.isfinite(p), (p >= values["probability"]).astype(np.uint8), 255)
                dst.write(m.astype(np.uint8), 1, window=win)
                n_shadow += int((m == 1).sum())
                if pdst is not None:
                    pdst.write(np.where(np.isfinite(p), p, io.FLOAT_NODATA), 1, window=win)
                sub.update((i + 1) / len(windows), "labelling")
            if values.get("plot"):
                from ..figures import save_figure
                from ..shadow.plots import cluster_figure

                keep = np.flatnonzero(good)[:20000]
                pr = cluster.probability(sample[0, keep], sample[1, keep])
                save_figure(
                    cluster_figure(
                        sample[0, keep],
                        sample[1, keep],
                        pr >= values["probability"],
                        cluster,
                        nir_nm,
                    ),
                    values["plot"],
                )
    out = {
        "output": values["output"],
        "components": cluster.n_components,
        "isolation": round(cluster.isolation, 4),
        "shadow_pixels": n_shadow,
        "nir_band": nir_band,
    }
    for k in ("probability_output", "plot"):
        if values.get(k):
            out[k] = values[k]
    return out


CLUSTER = Algorithm(
    name="shadow-cluster",
    display_name="Shadow cluster (scene-adaptive)",
    group=GROUP,
    short_help="Find the isolated shadow cluster in the (boresight ratio, 941 nm) scatter (Figure 4).",
    help=(
        "Shadowed pixels form an isolated cluster in the scatter of the boresight ratio against "
        "the VNIR band at 941 nm: high ratio, dark near-infrared (Brook & Ben-Dor 2011, "
        "Figure 4). This tool finds it without fixed thresholds: a Gaussian mixture "
        "(scikit-learn GaussianMixture, full covariances, 2–5 components chosen by the "
        "Bayesian information criterion) is fitted to the logarithms of both values on a random "
        "sample of pixels, the component furthest towards high ratio and low 941 nm is the "
        "shadow, and each pixel is shadow when its posterior probability reaches the threshold.\n\n"
        "Outputs: a byte mask (1 shadow, 0 not, 255 nodata), optionally the probability and a PNG "
        "scatter with the cluster outlined."
    ),
    params=(
        RATIO,
        RATIO_BAND,
        RasterIn(
            name="vnir",
            description="VNIR image (or merged cube) on the ratio's grid, with wavelengths",
        ),
        Wavelength(
            name="nir_nm",
            description="Wavelength of the near-infrared axis (nm; paper: 941)",
            default=941.0,
        ),
        Number(
            name="tolerance_nm",
            description="Largest distance from the requested wavelength to a band centre (nm)",
            default=15.0,
            minimum=0.0,
            maximum=500.0,
            unit="nm",
            advanced=True,
        ),
        Text(
            name="wavelengths",
            description="Band centres of the VNIR file in nm (only if it has none)",
            optional=True,
            advanced=True,
        ),
        Number(
            name="n_components",
            description="Mixture components (empty = chosen by BIC among 2–5)",
            optional=True,
            minimum=2,
            maximum=10,
            integer=True,
            advanced=True,
        ),
        Number(
            name="probability",
            description="Posterior probability of the shadow component needed to call a pixel shadow",
            default=0.5,
            minimum=0.0,
            maximum=1.0,
        ),
        sample_size("Pixels sampled at random to fit the mixture", 50000, 500, 5_000_000),
        seed(),
        BLOCK_ROWS,
        RasterOut(name="output", description="Shadow mask (byte: 1 shadow, 0 not)"),
        RasterOut(name="probability_output", description="Shadow probability (0–1)", optional=True),
        FileOut(
            name="plot",
            description="Scatter plot with the shadow cluster outlined (PNG)",
            extension="png",
            optional=True,
        ),
    ),
    run=_run_cluster,
)

# ------------------------------------------------------------------------ shadow-fraction-fit


def _run_fraction_fit(values, progress):
    acc = FractionAccumulator()
    rng = np.random.default_rng(0)
    keep_x, keep_y = [], []
    with contextlib.ExitStack() as stack:
        rsrc = stack.enter_context(io.open_raster(values["ratio"], "ratio raster"))
        tsrc = stack.enter_context(io.open_raster(values["truth"], "shadow-fraction raster"))
        io.require_same_grid(rsrc, tsrc, "ratio raster", "shadow-fraction raster")
        msrc = None
        if values.get("mask"):
            msrc = stack.enter_context(io.open_raster(values["mask"], "shadow mask"))
            io.require_same_grid(rsrc, msrc, "ratio raster", "shadow mask")
        windows = list(io.row_windows(rsrc.height, rsrc.width, values["block_rows"]))
        any_valid = False
        for i, win in enumerate(windows):
            r, okr = io.read_masked(rsrc, values["band"], win)
            f, okf = io.read_masked(tsrc, 1, win)
            any_valid |= bool(okr.any())
            sel = okr & okf
            if msrc is not None:
                m, okm = io.read_masked(msrc, 1, win)
                sel &= okm & (m == 1)
            else:
                sel &= f > 0
            acc.add(r, f, sel)
            if values.get("plot") and sel.any():
                pick = sel & (rng.random(sel.shape) < 20000 / max(1, rsrc.height * rsrc.width) * 4)
                keep_x.append(f[pick])
                keep_y.append(r[pick])
            progress.update((i + 1) / len(windows), "fitting")
        if not any_valid:
            raise _no_valid(values["ratio"])
    model = acc.model()
    progress.info(
        f"ratio = {model.slope:.4g} · fraction + {model.intercept:.4g}; R² = {model.r2:.3f} "
        f"on {model.n} pixels (paper, Figure 5B: −0.74, 1.31, R² 0.913)"
    )
    if values.get("report"):
        with io.atomic_output(values["report"]) as tmp, open(tmp, "w") as fh:
            json.dump(
                {
                    **model.as_dict(),
                    "ratio": values["ratio"],
                    "truth": values["truth"],
                    "mask": values.get("mask"),
                },
                fh,
                indent=2,
            )
    if values.get("plot"):
        from ..figures import save_figure
        from ..shadow.plots import regression_figure

        x = np.concatenate(keep_x) if keep_x else np.zeros(0)
        y = np.concatenate(keep_y) if keep_y else np.zeros(0)
        save_figure(
            regression_figure(x, y, model, FractionModel(PAPER_SLOPE, PAPER_INTERCEPT)),
            values["plot"],
        )
    out = {"slope": model.slope, "intercept": model.intercept, "r2": model.r2, "n": model.n}
    for k in ("report", "plot"):
        if values.get(k):
            out[k] = values[k]
    return out


FRACTION_FIT = Algorithm(
    name="shadow-fraction-fit",
    display_name="Shadow fraction model: fit (Figure 5B)",
    group=GROUP,
    short_help="Fit ratio = a · fraction + b over detected shadow against a ground-truth shadow fraction.",
    help=(
        "Fits the straight line of Figure 5(B) of Brook & Ben-Dor (2011) between the boresight "
        "ratio and a ground-truth shadow fraction (e.g. from 'Sun shadow'), over the detected "
        "shadow pixels (the mask from 'Shadow classes' or 'Shadow cluster'; without a mask, over "
        "pixels whose ground truth is above 0). Reports slope a, intercept b and R² (paper: "
        "a = −0.74, b = 1.31, R² = 0.913); optionally a JSON report for 'Shadow fraction model: "
        "apply' and a PNG of the regression. The fit is exact least squares over every pixel, "
        "streamed block by block."
    ),
    params=(
        RATIO,
        RATIO_BAND,
        RasterIn(
            name="truth", description="Ground-truth shadow fraction (0–1) on the ratio's grid"
        ),
        RasterIn(
            name="mask",
            description="Detected shadow mask (1 = shadow) on the same grid",
            optional=True,
        ),
        BLOCK_ROWS,
        FileOut(name="report", description="Fitted model (JSON)", extension="json", optional=True),
        FileOut(name="plot", description="Regression plot (PNG)", extension="png", optional=True),
    ),
    run=_run_fraction_fit,
)

# ---------------------------------------------------------------------- shadow-fraction-apply


def _run_fraction_apply(values, progress):
    slope, intercept = values["slope"], values["intercept"]
    if values.get("model"):
        path = values["model"]
        try:
            with open(path, encoding="utf-8") as fh:
                data = json.load(fh)
            slope, intercept = float(data["slope"]), float(data["intercept"])
        except FileNotFoundError:
            raise InputError(f"model {path} does not exist: check the path") from None
        except (ValueError, KeyError, TypeError):
            raise InputError(
                f"model {path} is not a report of 'shadow-fraction-fit' (JSON with 'slope' and "
                "'intercept')"
            ) from None
    model = FractionModel(slope, intercept)
    n_valid = 0
    with io.open_raster(values["ratio"], "ratio raster") as src:
        tags = {
            "product": "shadow fraction from the boresight ratio (Brook & Ben-Dor 2011, Fig. 5B)",
            "model": f"ratio = {slope:.6g} * fraction + {intercept:.6g}",
            "source": values["ratio"],
        }
        with io.create_raster(
            values["output"], io.grid_of(src), tags=tags, band_names=["shadow fraction"]
        ) as dst:
            windows = list(io.row_windows(src.height, src.width, values["block_rows"]))
            for i, win in enumerate(windows):
                r, ok = io.read_masked(src, values["band"], win)
                f = model.fraction(r, ok, clip=not values["no_clip"])
                dst.write(
                    np.where(np.isfinite(f), f, io.FLOAT_NODATA).astype("float32"), 1, window=win
                )
                n_valid += int(ok.sum())
                progress.update((i + 1) / len(windows), "applying")
            if n_valid == 0:
                raise _no_valid(values["ratio"])
    return {
        "output": values["output"],
        "slope": slope,
        "intercept": intercept,
        "valid_pixels": n_valid,
    }


FRACTION_APPLY = Algorithm(
    name="shadow-fraction-apply",
    display_name="Shadow fraction model: apply",
    group=GROUP,
    short_help="Turn the boresight ratio into a continuous shadow fraction with a fitted line.",
    help=(
        "Inverts ratio = a · fraction + b: fraction = (ratio − b) / a, limited to 0–1 unless "
        "'no clip' is set. Give a and b (default: the paper's Figure 5B, a = −0.74, b = 1.31, "
        "fitted on its own data) or the JSON report of 'Shadow fraction model: fit' on your "
        "scene, which takes precedence."
    ),
    params=(
        RATIO,
        RATIO_BAND,
        Number(
            name="slope", description="Slope a of ratio = a · fraction + b", default=PAPER_SLOPE
        ),
        Number(
            name="intercept",
            description="Intercept b of ratio = a · fraction + b",
            default=PAPER_INTERCEPT,
        ),
        FileIn(
            name="model",
            description="JSON report of 'shadow-fraction-fit' (overrides slope and intercept)",
            optional=True,
            extensions=("json",),
        ),
        Flag(name="no_clip", description="Do not limit the fraction to 0–1", advanced=True),
        BLOCK_ROWS,
        RasterOut(name="output", description="Shadow fraction (0–1, float32)"),
    ),
    run=_run_fraction_apply,
)

# --------------------------------------------------------------------------------- sun-shadow


def _run_sun_shadow(values, progress):
    zen, az = check_sun(values["sun_zenith"], values["sun_azimuth"])
    interp = "nearest" if values["surface"] == "blocks" else "bilinear"
    with io.open_raster(values["dsm"], "surface model") as src:
        georef = io.is_georeferenced(src)
        transform = src.transform if georef else None
        if values.get("cell_size") and georef:
            progress.info(
                "the surface model has a geotransform: its cell size is used, not --cell-size"
            )
        matrix = grid_matrix(transform, values.get("cell_size"))
        band = values["band"]
        # Pass 1: the relief bounds how far a shadow can reach.
        lo, hi, n_valid = np.inf, -np.inf, 0
        windows = list(io.row_windows(src.height, src.width, values["block_rows"]))
        for win in windows:
            z, ok = io.read_masked(src, band, win)
            if ok.any():
                lo, hi = min(lo, float(z[ok].min())), max(hi, float(z[ok].max()))
                n_valid += int(ok.sum())
        if n_valid == 0:
            raise _no_valid(values["dsm"], "surface model")
        relief = hi - lo
        above, below = halo_rows(relief, zen, az, matrix, (src.height, src.width))
        above, below = above + 1, below + 1  # Horn's 3 × 3 window needs one more line
        tags = {
            "product": "ground-truth shadow fraction from a surface model (Brook & Ben-Dor 2011, §3.1)",
            "method": f"ray march towards the sun ({values['surface']} surface), "
            f"{values['supersample']}×{values['supersample']} sub-cells",
            "sun_zenith_deg": zen,
            "sun_azimuth_deg": az,
            "dsm": values["dsm"],
        }
        if not georef:
            tags["geometry"] = (
                f"raw grid, cell size {values['cell_size']} m, row 0 = north edge, columns run east"
            )
        grid = io.grid_of(src)
        n_shadow = 0
        with contextlib.ExitStack() as stack:
            fdst = stack.enter_context(
                io.create_raster(values["output"], grid, tags=tags, band_names=["shadow fraction"])
            )
            mdst = hdst = None
            if values.get("mask"):
                mdst = stack.enter_context(
                    _mask_raster(values["mask"], grid, tags, "shadow mask (fraction ≥ 0.5)")
                )
            if values.get("hillshade"):
                hdst = stack.enter_context(
                    io.create_raster(
                        values["hillshade"],
                        grid,
                        tags={**tags, "product": "cosine of the solar incidence angle"},
                        band_names=["cos(incidence)"],
                    )
                )
            for i, win in enumerate(windows):
                r0 = max(0, win.row_off - above)
                r1 = min(src.height, win.row_off + win.height + below)
                big = rasterio.windows.Window(0, r0, src.width, r1 - r0)
                z, ok = io.read_masked(src, band, big)
                inner = slice(win.row_off - r0, win.row_off - r0 + win.height)
                frac = shadow_fraction(
                    z,
                    zen,
                    az,
                    transform=matrix,
                    valid=ok,
                    supersample=values["supersample"],
                    relief=relief,
                    interpolation=interp,
                )[inner]
                okw = ok[inner]
                fdst.write(np.where(okw, frac, io.FLOAT_NODATA).astype("float32"), 1, window=win)
                n_shadow += int((frac[okw] >= 0.5).sum())
                if mdst is not None:
                    m = np.where(okw, (frac >= 0.5).astype(np.uint8), MASK_NODATA)
                    mdst.write(m.astype(np.uint8), 1, window=win)
                if hdst is not None:
                    filled = np.where(ok, z, np.float32(np.mean(z[ok])) if ok.any() else 0)
                    h = hillshade(filled, zen, az, transform=matrix, z_factor=values["z_factor"])[
                        inner
                    ]
                    hdst.write(np.where(okw, h, io.FLOAT_NODATA).astype("float32"), 1, window=win)
                progress.update((i + 1) / len(windows), "marching towards the sun")
    out = {
        "output": values["output"],
        "shadow_pixels": n_shadow,
        "valid_pixels": n_valid,
        "relief_m": round(relief, 3),
    }
    for k in ("mask", "hillshade"):
        if values.get(k):
            out[k] = values[k]
    return out


SUN_SHADOW = Algorithm(
    name="sun-shadow",
    display_name="Sun shadow (ground truth from a surface model)",
    group=GROUP,
    short_help="Shadow fraction, shadow mask and hillshade of a surface model for a sun position.",
    help=(
        "Simulates the ground-truth shadow map of Brook & Ben-Dor (2011, §3.1) from a surface "
        "model (DSM/DTM with buildings) and the sun's zenith and azimuth.\n\n"
        "Cast shadows are found by ray marching: from each cell, step towards the sun one cell "
        "at a time; the cell is shadowed when the surface along the ray rises above the sun line "
        "(the method of GRASS r.sunmask, which this tool reproduces). Cells are split into "
        "n × n sub-cells and the fraction of shaded sub-cells is the shadow fraction (0–1). "
        "'blocks' treats cells as flat-topped (buildings); 'smooth' interpolates the surface "
        "(natural terrain). The optional hillshade is the cosine of the solar incidence angle "
        "from Horn's gradient, as gdaldem hillshade (GDAL's byte value is 1 + 254·max(cos i, 0)).\n\n"
        "The zenith is 0° (sun overhead) to 90° (horizon); the azimuth is clockwise from north "
        "towards the sun. A surface model without a geotransform needs a cell size; its row 0 is "
        "then taken as the northern edge."
    ),
    params=(
        RasterIn(
            name="dsm",
            description="Surface model (heights in metres; GeoTIFF or anything GDAL reads)",
        ),
        Band(name="band", description="Band of the surface model", default=1, raster="dsm"),
        Number(
            name="sun_zenith",
            description="Sun zenith angle (degrees from vertical, 0–90)",
            minimum=0.0,
            maximum=90.0,
            unit="°",
        ),
        Number(
            name="sun_azimuth",
            description="Sun azimuth (degrees clockwise from north, 0–360)",
            minimum=0.0,
            maximum=360.0,
            unit="°",
        ),
        Number(
            name="cell_size",
            description="Cell size in metres, for a surface model without a geotransform",
            optional=True,
            minimum=1e-6,
            unit="m",
        ),
        Number(
            name="supersample",
            description="Sub-cells per cell side for the shadow fraction",
            default=4,
            minimum=1,
            maximum=16,
            integer=True,
        ),
        Enum(
            name="surface",
            description="How the surface between cell centres is modelled",
            choices=("blocks", "smooth"),
            default="blocks",
        ),
        Number(
            name="z_factor",
            description="Vertical exaggeration of the hillshade (as gdaldem -z)",
            default=1.0,
            minimum=1e-6,
            advanced=True,
        ),
        BLOCK_ROWS,
        RasterOut(name="output", description="Shadow fraction (0–1, float32)"),
        RasterOut(name="mask", description="Shadow mask (fraction ≥ 0.5)", optional=True),
        RasterOut(
            name="hillshade",
            description="Hillshade: cosine of the solar incidence angle",
            optional=True,
        ),
    ),
    run=_run_sun_shadow,
)

# ------------------------------------------------------------------------- dark-pixel-shadow


def _parse_nm(text: str) -> list[float]:
    try:
        vals = [float(v) for v in str(text).replace(";", ",").split(",") if v.strip()]
    except ValueError:
        raise ParameterError(
            f"parameter 'bands_nm': {text!r} is not a comma-separated list of nm"
        ) from None
    if len(vals) < 2:
        raise ParameterError("parameter 'bands_nm': give at least two wavelengths (visible …, NIR)")
    return vals


def _run_dark_pixel(values, progress):
    bands_nm = _parse_nm(values["bands_nm"])
    with io.open_raster(values["image"], "image") as src:
        wl = wavelengths_of(src, values["image"], values.get("wavelengths"))[0]
        bands = [nearest_band(wl, b, values["tolerance_nm"], values["image"]) + 1 for b in bands_nm]
        nir_i = int(np.argmax(bands_nm))
        progress.info("dark-pixel bands: " + ", ".join(f"{b} ({wl[b - 1]:.0f} nm)" for b in bands))
        sample, ok = io.sample_pixels(
            [(src, b) for b in bands],
            src.height,
            src.width,
            values["block_rows"],
            values["sample_size"],
            values["seed"],
            progress.sub(0, 0.3),
        )
        if not ok.any():
            raise _no_valid(values["image"], "image")
        model = fit_dark_pixel(
            sample,
            nir_i,
            None,
            ok,
            dark_percentile=values["dark_percentile"],
            threshold=values["threshold"],
        )
        grid = io.grid_of(src)
        tags = {
            "product": "dark-pixel shadow mask (ATCOR-4-style statistical baseline)",
            "bands": ",".join(str(b) for b in bands),
            "dark_percentile": values["dark_percentile"],
            "threshold": values["threshold"],
        }
        n_shadow = 0
        with contextlib.ExitStack() as stack:
            dst = stack.enter_context(
                _mask_raster(values["output"], grid, tags, "dark-pixel shadow")
            )
            pdst = None
            if values.get("shadow_function"):
                pdst = stack.enter_context(
                    io.create_raster(
                        values["shadow_function"], grid, tags=tags, band_names=["shadow function"]
                    )
                )
            windows = list(io.row_windows(src.height, src.width, values["block_rows"]))
            sub = progress.sub(0.3, 1.0)
            for i, win in enumerate(windows):
                stack_, ok = [], None
                for b in bands:
                    v, okb = io.read_masked(src, b, win)
                    stack_.append(v)
                    ok = okb if ok is None else ok & okb
                x = np.stack(stack_)
                m = model.mask(x, ok)
                dst.write(m, 1, window=win)
                n_shadow += int((m == 1).sum())
                if pdst is not None:
                    phi = model.shadow_function(x, ok)
                    pdst.write(np.where(np.isfinite(phi), phi, io.FLOAT_NODATA), 1, window=win)
                sub.update((i + 1) / len(windows), "dark pixels")
    out = {"output": values["output"], "shadow_pixels": n_shadow, "candidates": model.n_candidates}
    if values.get("shadow_function"):
        out["shadow_function"] = values["shadow_function"]
    return out


DARK_PIXEL = Algorithm(
    name="dark-pixel-shadow",
    display_name="Dark-pixel shadow (ATCOR-4-style baseline)",
    group=GROUP,
    short_help="Statistical dark-pixel shadow mask of the ATCOR-4 kind, for comparison.",
    help=(
        "The kind of shadow detector ATCOR-4 uses (Richter & Müller 2005), the baseline Brook & "
        "Ben-Dor (2011) compare the boresight shadow map with. Core-shadow candidates are the "
        "pixels darkest in the near infrared and in the visible (below the 'dark percentile' of "
        "the scene in both); a matched filter built from the scene mean and covariance and the "
        "candidates' mean spectrum gives each pixel a shadow function Φ (0 = scene average, "
        "1 = like the dark candidates); the mask is Φ ≥ threshold.\n\n"
        "It uses only image statistics, so dark materials (asphalt, dark roofs, water) look like "
        "shadow to it: that is the failure the paper's boresight method avoids. Not included: "
        "ATCOR's atmospheric correction, cloud and water masks and the de-shadowing itself."
    ),
    params=(
        RasterIn(name="image", description="VNIR image or merged cube with wavelength metadata"),
        Text(
            name="bands_nm",
            description="Wavelengths of the bands used (nm, comma-separated; the longest is the NIR)",
            default=",".join(f"{b:g}" for b in DEFAULT_BANDS_NM),
        ),
        Text(
            name="wavelengths",
            description="Band centres of the file in nm (only if it has none)",
            optional=True,
            advanced=True,
        ),
        Number(
            name="tolerance_nm",
            description="Largest distance from a requested wavelength to a band centre (nm)",
            default=15.0,
            minimum=0.0,
            maximum=500.0,
            unit="nm",
            advanced=True,
        ),
        Number(
            name="dark_percentile",
            description="Core-shadow candidates: darker than this percentile of the scene (NIR and visible)",
            default=10.0,
            minimum=0.1,
            maximum=50.0,
        ),
        Number(
            name="threshold",
            description="Shadow where the shadow function Φ reaches this value",
            default=0.5,
            minimum=0.0,
            maximum=2.0,
        ),
        sample_size("Pixels sampled at random for the statistics", 50000, 500, 5_000_000),
        seed(),
        BLOCK_ROWS,
        RasterOut(name="output", description="Dark-pixel shadow mask (byte: 1 shadow, 0 not)"),
        RasterOut(name="shadow_function", description="Shadow function Φ (float32)", optional=True),
    ),
    run=_run_dark_pixel,
)

# ---------------------------------------------------------------------------- shadow-polygons


def _run_polygons(values, progress):
    from ..io.vector import vector_format, write_vector
    from ..shadow.polygons import shadow_polygons

    table = _table(values)
    path = values["output"]
    vector_format(path)  # a clear error for an unsupported extension, before any work
    with io.open_raster(values["classes_raster"], "class raster") as src:
        data, ok = io.read_masked(src, 1)
        if not ok.any():
            raise _no_valid(values["classes_raster"], "class raster")
        c = np.where(ok, data, cls.NODATA_CLASS).astype(np.uint8)
        georef = io.is_georeferenced(src)
        crs = src.crs
        polys = shadow_polygons(
            c, table, src.transform if georef else None, min_pixels=values["min_pixels"]
        )
    progress.update(0.7, "polygons")
    units = (
        "square map units of the raster CRS"
        if crs
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
        path,
        [p.geometry for p in polys],
        fields,
        crs=crs,
        layer="shadow_polygons",
        description=desc,
    )
    progress.update(1.0, "written")
    return {
        "output": path,
        "polygons": len(polys),
        "geometry": "map" if georef else "raw sensor (pixel) geometry",
    }


POLYGONS = Algorithm(
    name="shadow-polygons",
    display_name="Shadow polygons",
    group=GROUP,
    short_help="Vectorise a shadow class raster into polygons with class and area attributes.",
    help=(
        "Turns the output of 'Shadow classes' into polygons (GeoPackage or GeoJSON): each "
        "4-connected patch of one class becomes a polygon with the class id, its name, the "
        "shadow-fraction interval, its area and its number of pixels, in the raster's CRS. A "
        "raster in raw sensor geometry (no CRS) gives polygons in pixel coordinates "
        "(x = column, y = −line) with the area in pixels; the layer description says so."
    ),
    params=(
        RasterIn(
            name="classes_raster", description="Shadow class raster (output of 'shadow-classes')"
        ),
        FileIn(
            name="classes",
            description="Class table used for it (empty = Table 2)",
            optional=True,
            extensions=("csv", "json"),
        ),
        Number(
            name="min_pixels",
            description="Drop polygons smaller than this many pixels",
            default=1,
            minimum=1,
            integer=True,
        ),
        VectorOut(name="output", description="Shadow polygons (.gpkg or .geojson)"),
    ),
    run=_run_polygons,
)

ALGORITHMS = (CLASSES, CLUSTER, FRACTION_FIT, FRACTION_APPLY, SUN_SHADOW, DARK_PIXEL, POLYGONS)
