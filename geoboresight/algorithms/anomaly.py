"""Specs: sub-pixel anomaly detection and unmixing (paper §3.3): RX, SVDD, the boresight
indicator, linear unmixing, ROC curves and anomaly polygons.

Kernel modules are imported inside the run functions: listing the operations (the registry)
and running RX then load neither scikit-learn, matplotlib, shapely nor SciPy's image module.
"""

from __future__ import annotations

import os

import numpy as np

from .. import io
from ..anomaly.bands import WATER_BANDS_NM, select_bands
from ..anomaly.indicator import TAILS
from ..anomaly.unmix import METHODS
from ..errors import InputError, ParameterError
from ..io.cube import open_cube
from ._common import block_rows, sample_size, seed
from .spec import (
    Algorithm,
    Enum,
    FileIn,
    FileOut,
    MultiRaster,
    Number,
    RasterIn,
    RasterOut,
    Text,
    VectorOut,
)

IMAGE_PARAMS = (
    RasterIn(
        name="image",
        description="Hyperspectral image (ENVI .hdr/.img or GeoTIFF): a merged cube, or the VNIR file",
    ),
    RasterIn(
        name="swir",
        description="SWIR file on the same pixel grid, stacked after the image's bands (optional)",
        optional=True,
    ),
    Text(
        name="include_nm",
        description="Use only bands in these wavelength ranges, e.g. '400-900,1000-1300' (empty: all)",
        default="",
        optional=True,
    ),
    Text(
        name="exclude_nm",
        description="Leave out bands in these wavelength ranges (default: water-vapour absorption)",
        default=WATER_BANDS_NM,
        optional=True,
    ),
)

# 16 lines of a 286-sample AISA line = 4,576 pixels: a strip's float buffers stay within a few
# MB (cache-friendly, and memory is a few strips per worker thread).
BLOCK_ROWS = block_rows(16)


def _open_image(values):
    paths = [values["image"]] + ([values["swir"]] if values.get("swir") else [])
    cube = open_cube(paths)
    bands = select_bands(
        cube.wavelengths, cube.count, values.get("include_nm"), values.get("exclude_nm")
    )
    wl = None if cube.wavelengths is None else cube.wavelengths[bands]
    return cube, bands, wl


def _strips(cube, bands, block_rows, dtype="float64"):
    buf = None
    for win in cube.windows(block_rows):
        r0, r1 = win.row_off, win.row_off + win.height
        data, valid = cube.read(r0, r1, bands, dtype, out=buf)
        if buf is None:
            buf = data
        yield win, data, valid


def _band_tags(wl, bands):
    return {
        "bands_used": ",".join(str(int(b) + 1) for b in bands),
        "wavelengths_used_nm": "" if wl is None else ",".join(f"{w:.1f}" for w in wl),
    }


# --- RX ----------------------------------------------------------------------------------


def _run_rx(values, progress):
    from ..anomaly import rx as rxmod

    cube, bands, wl = _open_image(values)
    with cube:
        rows = values["block_rows"]
        nwin = -(-cube.height // rows)
        precision = values["precision"]
        # Pass 1: mean and covariance in one pass, strips in the files' own type (no float copy);
        # the shift comes from the first strip so that the sums do not depend on thread timing.
        first, first_valid = cube.read(0, min(rows, cube.height), bands, None)
        acc = rxmod.CovarianceAccumulator(
            len(bands), shift=rxmod.CovarianceAccumulator.strip_shift(first, first_valid)
        )
        del first, first_valid
        p1 = progress.sub(0.0, 0.5)
        for i, _ in enumerate(cube.map_strips(acc.add_cube, rows, bands)):
            p1.update((i + 1) / nwin, "RX: background statistics")
        stats = acc.stats()
        det = rxmod.RXDetector(stats, values["regularize"], wavelengths=wl, band_numbers=bands + 1)
        progress.info(f"RX on {len(bands)} bands, {stats.n} background pixels")
        tags = {
            "product": "RX anomaly score (squared Mahalanobis distance; paper §3.3)",
            **_band_tags(wl, bands),
        }
        local = values["mode"] == "local"
        if local:
            tags["window"] = f"inner {values['inner']} px, outer {values['outer']} px"
            h = values["outer"] // 2

            def local_score(win):
                a, b = win.row_off, win.row_off + win.height
                e0, e1 = max(0, a - h), min(cube.height, b + h)
                ext, ext_valid = cube.read(e0, e1, bands, "float64")
                return rxmod.local_rx(
                    ext,
                    det,
                    values["inner"],
                    values["outer"],
                    ext_valid,
                    first_row=e0,
                    height=cube.height,
                    rows=(a, b),
                    precision=precision,
                )

            scored = ((win, local_score(win)) for win in cube.windows(rows))
        else:
            scored = cube.map_strips(
                lambda data, valid: det.score_cube(data, valid, precision), rows, bands
            )
        p2 = progress.sub(0.5, 1.0)
        with io.create_raster(
            values["output"], cube.grid, tags=tags, band_names=["RX score"]
        ) as dst:
            for i, (win, score) in enumerate(scored):
                dst.write(
                    np.where(np.isfinite(score), score, io.FLOAT_NODATA).astype("float32"),
                    1,
                    window=win,
                )
                p2.update((i + 1) / nwin, "RX: scoring")
    return {"output": values["output"], "bands": len(bands), "background_pixels": stats.n}


RX = Algorithm(
    name="rx",
    display_name="RX anomaly detector",
    group="Anomaly",
    short_help="Reed–Xiaoli: squared Mahalanobis distance of each pixel to the scene background.",
    help=(
        "Global RX (Reed & Yu 1990), one of the paper's reference detectors (§3.3, Figure 11B): "
        "each pixel's score is (x − μ)ᵀ Σ⁻¹ (x − μ), its squared Mahalanobis distance to the "
        "scene mean μ under the scene covariance Σ. High scores are spectrally unusual pixels.\n\n"
        "The mean and covariance are accumulated in one pass over blocks of lines (float64), the "
        "scores in a second pass, so memory does not grow with the flight line. Water-vapour "
        "absorption bands are left out by default (exclude_nm); choose bands by wavelength with "
        "include_nm. Give the SWIR file to stack VNIR and SWIR bands.\n\n"
        "Local mode: the mean is taken from a window around each pixel (outer size, minus an inner "
        "guard window), the covariance is still the scene's.\n\n"
        "If the covariance is singular (constant or duplicated bands) the run stops and names the "
        "bands; exclude them, or set 'regularize' to add a small ridge (it changes the scores).\n\n"
        "Output: float32 GeoTIFF score map on the image grid, nodata -9999."
    ),
    params=(
        *IMAGE_PARAMS,
        Enum(
            name="mode",
            description="Global (scene mean) or local (windowed mean) RX",
            choices=("global", "local"),
            default="global",
        ),
        Number(
            name="inner",
            description="Local RX: inner guard window size (odd, pixels)",
            default=3,
            minimum=1,
            maximum=99,
            integer=True,
            advanced=True,
        ),
        Number(
            name="outer",
            description="Local RX: outer window size (odd, pixels)",
            default=17,
            minimum=3,
            maximum=301,
            integer=True,
            advanced=True,
        ),
        Number(
            name="regularize",
            description="Ridge added to the covariance diagonal, as a fraction of the mean band variance (0: none)",
            default=0.0,
            minimum=0.0,
            maximum=1.0,
            advanced=True,
        ),
        Enum(
            name="precision",
            description="Arithmetic of the scoring pass: float64 (exact) or float32 (about 2× faster)",
            choices=("float64", "float32"),
            default="float64",
            advanced=True,
        ),
        BLOCK_ROWS,
        RasterOut(name="output", description="RX score raster (GeoTIFF)"),
    ),
    run=_run_rx,
)


# --- SVDD --------------------------------------------------------------------------------


def _run_svdd(values, progress):
    from ..anomaly import svdd as svddmod

    cube, bands, wl = _open_image(values)
    with cube:
        nwin = -(-cube.height // values["block_rows"])
        # Random pixel positions over the whole image (extra, since some may be nodata).
        rng = np.random.default_rng(values["seed"])
        npix = cube.height * cube.width
        want = values["sample_size"]
        pos = np.sort(rng.choice(npix, min(npix, int(want * 1.5) + 10), replace=False))
        picked = []
        p1 = progress.sub(0.0, 0.2)
        for i, (win, data, valid) in enumerate(
            _strips(cube, bands, values["block_rows"], dtype=None)
        ):
            a = win.row_off * cube.width
            lo, hi = np.searchsorted(pos, [a, a + win.height * cube.width])
            local = pos[lo:hi] - a
            local = local[valid.ravel()[local]]
            picked.append(data.reshape(len(bands), -1)[:, local].T.astype(np.float64))
            p1.update((i + 1) / nwin, "SVDD: background sample")
        sample = np.concatenate(picked)
        if len(sample) > want:
            sample = sample[rng.permutation(len(sample))[:want]]
        sigma = values["sigma"] or None
        model = svddmod.fit_svdd(sample, sigma=sigma, nu=values["nu"])
        progress.info(
            f"SVDD: {len(sample)} training pixels, σ = {model.sigma:.4g}"
            f"{' (median pairwise distance)' if sigma is None else ''}, ν = {model.nu}, "
            f"{len(model.alpha)} support vectors"
        )
        tags = {
            "product": "SVDD anomaly score ||Φ(y)−a||² − R² (RBF kernel; paper Eq. 7–9)",
            "sigma": f"{model.sigma:.6g}",
            "nu": model.nu,
            "support_vectors": len(model.alpha),
            **_band_tags(wl, bands),
        }
        p2 = progress.sub(0.2, 1.0)
        with io.create_raster(
            values["output"], cube.grid, tags=tags, band_names=["SVDD score"]
        ) as dst:
            # Strips in the files' own type, scored in worker threads (thread-safe model).
            for i, (win, score) in enumerate(
                cube.map_strips(model.score_cube, values["block_rows"], bands)
            ):
                dst.write(
                    np.where(np.isfinite(score), score, io.FLOAT_NODATA).astype("float32"),
                    1,
                    window=win,
                )
                p2.update((i + 1) / nwin, "SVDD: scoring")
    return {"output": values["output"], "sigma": model.sigma, "support_vectors": len(model.alpha)}


SVDD = Algorithm(
    name="svdd",
    display_name="SVDD anomaly detector (RBF kernel)",
    group="Anomaly",
    short_help="Support Vector Data Description with a Gaussian kernel, trained on a random background sample.",
    help=(
        "SVDD (paper §3.3, Eq. 7–9, Figure 11C): the smallest hypersphere, in the feature space of "
        "a Gaussian radial-basis kernel, that encloses a random sample of the scene's pixels. The "
        "score is a pixel's squared distance to the centre minus the squared radius: positive "
        "outside the background description. Unlike RX it needs no covariance inverse and copes "
        "with multimodal backgrounds.\n\n"
        "Training uses scikit-learn's one-class SVM, which for this kernel gives the same decision "
        "function as SVDD (Tax & Duin 2004; Schölkopf et al. 2001). Scoring is done block by "
        "block with matrix products.\n\n"
        "sigma: kernel width in image units; 0 chooses it as the median distance between sample "
        "pixels. nu: the fraction of training pixels allowed outside the sphere.\n\n"
        "Output: float32 GeoTIFF score map on the image grid, nodata -9999."
    ),
    params=(
        *IMAGE_PARAMS,
        Number(
            name="sigma",
            description="Gaussian kernel width in image units (0: median pairwise distance of the sample)",
            default=0.0,
            minimum=0.0,
        ),
        Number(
            name="nu",
            description="Fraction of background pixels allowed outside the description (0–1)",
            default=0.01,
            minimum=1e-4,
            maximum=1.0,
        ),
        sample_size(
            "Background pixels drawn at random for training", 1000, 20, 20000, advanced=False
        ),
        seed("Random seed for the background sample"),
        BLOCK_ROWS,
        RasterOut(name="output", description="SVDD score raster (GeoTIFF)"),
    ),
    run=_run_svdd,
)


# --- boresight indicator -----------------------------------------------------------------


def _read_one(path, label):
    with io.open_raster(path, label) as src:
        data, valid = io.read_masked(src, 1)
        return data, valid, io.grid_of(src)


def _run_indicator(values, progress):
    from ..anomaly import indicator as ind

    ratio, valid, grid = _read_one(values["ratio"], "ratio raster")
    res = ind.boresight_indicator(
        ratio, valid, values["threshold"], values["tail"], values["window"]
    )
    progress.info(
        f"boresight ratio median {res.median:.5g}, robust σ {res.sigma:.4g}; "
        f"{res.count} pixel(s) beyond {res.threshold:g} σ"
    )
    tags = {
        "product": "boresight indicator: robust z-score of the boresight ratio (paper §3.3)",
        "median": f"{res.median:.8g}",
        "robust_sigma": f"{res.sigma:.8g}",
        "tail": values["tail"],
        "threshold": values["threshold"],
    }
    score = np.where(np.isfinite(res.score), res.score, io.FLOAT_NODATA).astype("float32")
    io.write_raster(values["output"], score, like=grid, tags=tags, band_names=["boresight z-score"])
    if values.get("anomalies"):
        mask = np.where(valid, res.anomalies, 255).astype("uint8")
        io.write_raster(
            values["anomalies"],
            mask,
            like=grid,
            nodata=255,
            dtype="uint8",
            tags=tags,
            band_names=["anomaly (1) / background (0)"],
        )
    return {
        "output": values["output"],
        "anomalies": values.get("anomalies"),
        "count": res.count,
        "median": res.median,
        "robust_sigma": res.sigma,
    }


INDICATOR = Algorithm(
    name="boresight-indicator",
    display_name="Boresight anomaly indicator",
    group="Anomaly",
    short_help="Pixels whose boresight ratio stands out: robust z-score (median/MAD) and a threshold.",
    help=(
        "The paper's proposal (§3.3, Figure 11D): the boresight band ratio as a sub-pixel anomaly "
        "indicator. A small target seen by the VNIR and SWIR optics at slightly different "
        "positions, and with a spectrum unlike its surroundings, makes the ratio of its pixel "
        "stand out. Input: the ratio raster (the 'ratio' operation).\n\n"
        "Each pixel gets z = (ratio − median) / (1.4826 × MAD), a z-score that the anomalies "
        "themselves cannot inflate. tail 'both' scores |z|, 'high' z, 'low' −z. Pixels above the "
        "threshold (default 3, the paper's 3σ rule) are anomalies. With a window (e.g. 5), the "
        "reference is the median ratio of each pixel's neighbours instead of the whole scene: "
        "better for sub-pixel targets on a varied background.\n\n"
        "Outputs: the score (float32 GeoTIFF, nodata -9999) and optionally a 0/1 anomaly mask."
    ),
    params=(
        RasterIn(
            name="ratio", description="Boresight ratio raster (output of the 'ratio' operation)"
        ),
        Number(
            name="threshold",
            description="Anomaly threshold on the robust z-score (σ units)",
            default=3.0,
            minimum=0.1,
            maximum=100.0,
        ),
        Enum(
            name="tail",
            description="Which side stands out: both, high or low ratios",
            choices=TAILS,
            default="both",
        ),
        Number(
            name="window",
            description="Local reference: median ratio in this odd window (pixels); 0 = whole scene",
            default=0,
            minimum=0,
            maximum=101,
            integer=True,
        ),
        RasterOut(name="output", description="Indicator score raster (GeoTIFF)"),
        RasterOut(
            name="anomalies", description="0/1 anomaly mask (GeoTIFF, optional)", optional=True
        ),
    ),
    run=_run_indicator,
)


# --- unmixing ----------------------------------------------------------------------------


def _run_unmix(values, progress):
    from ..anomaly import unmix as unmixmod

    wl_lib, spectra, names = unmixmod.read_library(values["endmembers"])
    wanted = [n.strip() for n in (values.get("names") or "").split(",") if n.strip()]
    if wanted:
        missing = [n for n in wanted if n not in names]
        if missing:
            raise InputError(
                f"endmember(s) {', '.join(missing)} not in {values['endmembers']} (it has: {', '.join(names)})"
            )
        spectra = spectra[[names.index(n) for n in wanted]]
        names = wanted
    cube, bands, wl = _open_image(values)
    with cube:
        if wl is None:
            raise InputError(
                f"{values['image']} has no wavelength metadata: endmembers cannot be resampled to its bands"
            )
        fwhm = None if cube.fwhm is None else cube.fwhm[bands]
        E = unmixmod.resample(wl_lib, spectra, wl, fwhm, names)
        unmixmod.check_endmembers(E, names)
        scale = values["image_scale"]
        nwin = -(-cube.height // values["block_rows"])
        tags = {
            "product": f"linear unmixing ({values['method']}; paper Eq. 10–11)",
            "endmembers": ",".join(names),
            "image_scale": scale,
            **_band_tags(wl, bands),
        }
        band_names = [f"abundance {n}" for n in names] + ["residual RMS (phi)"]
        with io.create_raster(
            values["output"], cube.grid, count=len(names) + 1, tags=tags, band_names=band_names
        ) as dst:
            for i, (win, data, valid) in enumerate(_strips(cube, bands, values["block_rows"])):
                flat = data.reshape(len(bands), -1)
                v = valid.ravel()
                out = np.full((len(names) + 1, flat.shape[1]), io.FLOAT_NODATA, dtype=np.float32)
                if v.any():
                    A, res = unmixmod.unmix(flat[:, v] * scale, E, values["method"])
                    out[:-1, v] = A
                    out[-1, v] = res
                dst.write(out.reshape(len(names) + 1, win.height, win.width), window=win)
                progress.update((i + 1) / nwin, "unmixing")
    return {"output": values["output"], "endmembers": names}


UNMIX = Algorithm(
    name="unmix",
    display_name="Linear spectral unmixing",
    group="Anomaly",
    short_help="Abundance of each endmember per pixel (fully constrained: ≥ 0, sum to 1), with the residual.",
    help=(
        "Linear unmixing (paper Eq. 10–11): each pixel spectrum is modelled as a sum of endmember "
        "spectra weighted by abundances, plus a residual φ. 'fcls' (fully constrained, the paper's "
        "choice) keeps abundances ≥ 0 summing to 1; 'nnls' only ≥ 0; 'ucls' unconstrained.\n\n"
        "Endmembers: a CSV (first column wavelength in nm, one column per material, e.g. the "
        "simulator's endmembers.csv or field spectra) or an ENVI spectral library (.sli + .hdr). "
        "They are resampled to the image's band centres with Gaussian responses of the image's "
        "FWHM. The library must cover the image's wavelengths (exclude bands it does not). The "
        "image must be in the library's units: use image_scale (e.g. 0.0001 for reflectance × "
        "10000).\n\n"
        "Output: one float32 band per endmember (abundance) and a last band with the residual RMS "
        "over bands; nodata -9999."
    ),
    params=(
        *IMAGE_PARAMS,
        FileIn(
            name="endmembers",
            description="Endmember spectra: CSV (wavelength_nm, one column per material) or ENVI .sli/.hdr",
            extensions=("csv", "sli", "hdr"),
        ),
        Text(
            name="names",
            description="Endmembers to use, comma-separated (empty: all in the file)",
            default="",
            optional=True,
        ),
        Enum(
            name="method",
            description="fcls: ≥ 0 and sum to 1 (Eq. 11); nnls: ≥ 0; ucls: unconstrained",
            choices=METHODS,
            default="fcls",
        ),
        Number(
            name="image_scale",
            description="Factor turning image values into the library's units (e.g. 0.0001)",
            default=1.0,
            minimum=0.0,
        ),
        BLOCK_ROWS,
        RasterOut(name="output", description="Abundances + residual raster (GeoTIFF)"),
    ),
    run=_run_unmix,
)


# --- ROC ---------------------------------------------------------------------------------


def _run_roc(values, progress):
    from ..anomaly import roc as rocmod

    paths = values["scores"]
    names = [n.strip() for n in (values.get("names") or "").split(",") if n.strip()]
    if names and len(names) != len(paths):
        raise ParameterError(
            f"parameter 'names': {len(names)} name(s) for {len(paths)} score raster(s)"
        )
    names = names or [os.path.splitext(os.path.basename(p))[0] for p in paths]
    truth, tvalid, grid = _read_one(values["truth"], "truth raster")
    truth = np.where(tvalid, truth, np.nan)
    thr = values.get("truth_threshold")
    targets, background = rocmod.truth_mask(truth, thr, values["guard_px"])
    curves = {}
    for i, (name, path) in enumerate(zip(names, paths, strict=True)):
        s, sv, g = _read_one(path, "score raster")
        if (g["width"], g["height"]) != (grid["width"], grid["height"]):
            raise InputError(
                f"score raster {path} is {g['width']} × {g['height']} but the truth {values['truth']} is "
                f"{grid['width']} × {grid['height']}: they must share one grid"
            )
        try:
            curves[name] = rocmod.roc_curve(np.where(sv, s, np.nan), targets, background)
        except InputError as exc:
            raise InputError(f"{values['truth']}: {exc}") from None
        progress.update((i + 1) / len(paths), f"ROC {name}")
    pfa = values["pfa"]
    with io.atomic_output(values["output"]) as tmp:
        rocmod.plot_roc(tmp, curves, title=values["title"], pfa_marker=pfa)
    if values.get("csv"):
        with io.atomic_output(values["csv"]) as tmp:
            rocmod.write_curves_csv(tmp, curves)
    result = {"output": values["output"], "csv": values.get("csv")}
    for name, c in curves.items():
        result[f"auc_{name}"] = round(c.auc, 6)
        result[f"pd_at_pfa_{name}"] = round(c.pd_at(pfa), 6)
        progress.info(
            f"{name}: AUC {c.auc:.4f}, Pd {c.pd_at(pfa):.3f} at Pfa {pfa:g} ({c.n_targets} target px)"
        )
    return result


ROC = Algorithm(
    name="roc",
    display_name="ROC curves of anomaly detectors",
    group="Anomaly",
    short_help="Probability of detection vs false alarm, and AUC, for several score maps against a truth raster.",
    help=(
        "ROC curves as in the paper's Figure 12: for each score map (RX, SVDD, boresight indicator, "
        "…), every threshold gives a probability of detection (share of target pixels above it) and "
        "of false alarm (share of background pixels above it). The area under the curve (AUC) and "
        "Pd at a chosen Pfa summarise each detector.\n\n"
        "Truth: a 0/1 mask, or an abundance raster (e.g. the simulator's truth_target_abundance.tif) "
        "with a threshold (default: any abundance > 0 is a target). guard_px leaves pixels next to "
        "targets out of the background, since a sub-pixel target spills into its neighbours.\n\n"
        "Outputs: one PNG figure (linear and logarithmic Pfa) and optionally a CSV of the curves."
    ),
    params=(
        MultiRaster(
            name="scores",
            description="Score rasters, higher = more anomalous (comma-separated paths)",
        ),
        Text(
            name="names",
            description="Detector names for the legend, comma-separated (default: file names)",
            default="",
            optional=True,
        ),
        RasterIn(
            name="truth", description="Truth: 0/1 target mask or abundance raster, on the same grid"
        ),
        Number(
            name="truth_threshold",
            description="Abundance at or above which a pixel is a target (empty: > 0)",
            optional=True,
            minimum=0.0,
        ),
        Number(
            name="guard_px",
            description="Leave pixels within this distance of a target out of the background",
            default=0,
            minimum=0,
            maximum=50,
            integer=True,
        ),
        Number(
            name="pfa",
            description="False-alarm rate at which Pd is reported",
            default=1e-3,
            minimum=1e-9,
            maximum=1.0,
        ),
        Text(
            name="title",
            description="Figure title",
            default="ROC: anomaly detectors",
            optional=True,
        ),
        FileOut(name="output", description="ROC figure (PNG)", extension="png"),
        FileOut(
            name="csv",
            description="ROC curves (CSV: detector, pfa, pd, threshold)",
            extension="csv",
            optional=True,
        ),
    ),
    run=_run_roc,
)


# --- polygons ----------------------------------------------------------------------------


def _run_polygons(values, progress):
    from ..anomaly import polygons as poly

    with io.open_raster(values["score"], "score raster") as src:
        s, sv = io.read_masked(src, 1)
        crs = src.crs
        transform = src.transform if io.is_georeferenced(src) else None
    geoms, table = poly.anomaly_features(
        np.where(sv, s, np.nan),
        values["threshold"],
        transform,
        values["geometry"],
        values["min_pixels"],
    )
    with io.atomic_output(values["output"]) as tmp:
        poly.write_gpkg(tmp, geoms, table, crs=crs)
    progress.info(f"{len(geoms)} anomaly feature(s) at score ≥ {values['threshold']:g}")
    return {"output": values["output"], "features": len(geoms)}


POLYGONS = Algorithm(
    name="anomaly-polygons",
    display_name="Anomaly score to polygons",
    group="Anomaly",
    short_help="Groups of pixels above a score threshold as GeoPackage polygons or points with score attributes.",
    help=(
        "Turns any anomaly score map (RX, SVDD, boresight indicator) into a vector layer: pixels "
        "with a score at or above the threshold are grouped (8-connected); each group becomes a "
        "polygon (its pixel outline) or a point (its highest-scoring pixel), with the number of "
        "pixels, the maximum and mean score and the peak's row and column.\n\n"
        "Coordinates follow the raster's CRS and geotransform; a raster in raw sensor geometry "
        "gives pixel coordinates (column, row) with an undefined CRS.\n\n"
        "Output: a GeoPackage layer 'anomalies'."
    ),
    params=(
        RasterIn(name="score", description="Anomaly score raster"),
        Number(name="threshold", description="Score at or above which a pixel is an anomaly"),
        Enum(
            name="geometry",
            description="Polygons (pixel outlines) or points (peak pixel centres)",
            choices=("polygon", "point"),
            default="polygon",
        ),
        Number(
            name="min_pixels",
            description="Drop groups smaller than this many pixels",
            default=1,
            minimum=1,
            integer=True,
        ),
        VectorOut(name="output", description="Anomaly layer (GeoPackage)", extension="gpkg"),
    ),
    run=_run_polygons,
)

ALGORITHMS = (RX, SVDD, INDICATOR, UNMIX, ROC, POLYGONS)
