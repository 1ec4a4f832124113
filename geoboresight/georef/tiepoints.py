"""Automatic tie points between a raw pushbroom band and a reference orthophoto, and a
piecewise model that follows the attitude wobble of the line.

1. A rough placement (a few GCPs, or the corner coordinates: any image-to-map callable) puts
   the reference into the product's raw geometry: each raw pixel centre is mapped and the
   reference sampled there (bilinear), giving a *chip* that differs from the product only by
   the placement's error and the line's wobble.
2. Features (scikit-image's SIFT or ORB) are detected on both, matched by descriptor (cross
   check and Lowe's ratio) and kept within ``max_shift_px``.
3. RANSAC (scikit-image) with an affine model per block of lines rejects false matches: the
   wobble changes the displacement from block to block, so one global model would reject
   good matches where the line rolled.
4. The displacement field ``(d_pixel, d_line)`` from each raw pixel to where the rough
   placement must be evaluated is fitted to the inliers, either per block of lines (an affine
   function of column and line, weighted by a triangle over two blocks, so that it varies
   linearly from block to block: the line's roll, pitch and yaw change smoothly) or as a
   smoothed thin-plate spline. The product's map coordinates are then
   ``placement(pixel + d_pixel, line + d_line)``.

Residuals are cross-validated (5-fold: each tie point predicted by the model fitted without
its fold), in product pixels.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

DETECTORS = ("sift", "orb")
MODELS = ("blocks", "tps")
#: Lines per block of the piecewise model and of RANSAC (the wobble's shortest period to
#: follow is about two blocks). A model's resolution along the track, not how many lines are
#: read at a time (``block_rows`` elsewhere): it changes the result.
MODEL_BLOCK_LINES = 16
#: Largest displacement (product pixels) between the product and the placed reference.
MAX_SHIFT_PX = 30.0
#: RANSAC inlier threshold (product pixels).
RANSAC_PX = 1.5
#: Fewest inliers accepted.
MIN_INLIERS = 12
#: Largest cross-validated RMSE of the tie points accepted by default (product pixels).
MAX_RMSE_PX = 1.0
#: Thin-plate spline smoothing (pixels²): tie points carry sub-pixel matching noise.
TPS_SMOOTHING = 10.0
#: Lowe's ratio test for descriptor matches.
MAX_RATIO = 0.8
FOLDS = 5


@dataclass(frozen=True)
class TieMatching:
    """How automatic tie points are found and accepted: scikit-image's ``detector``
    ("sift", "orb"), the wobble ``model`` ("blocks": affine per block of
    ``model_block_lines`` lines, blended; "tps": thin-plate spline), the largest error of
    the rough placement ``max_shift_px``, and the acceptance test (at least ``min_inliers``
    tie points, cross-validated RMSE at most ``max_rmse_px``, both in product pixels);
    ``seed`` is RANSAC's.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.TieMatching()
    TieMatching(detector='sift', model='blocks', model_block_lines=16, max_shift_px=30.0,
        min_inliers=12, max_rmse_px=1.0, seed=0)
    >>> gb.TieMatching(detector="orb").detector  # --detector orb
    'orb'
    """

    detector: str = "sift"
    model: str = "blocks"
    model_block_lines: int = MODEL_BLOCK_LINES
    max_shift_px: float = MAX_SHIFT_PX
    min_inliers: int = MIN_INLIERS
    max_rmse_px: float = MAX_RMSE_PX
    seed: int = 0

    def matcher_options(self) -> dict:
        """The keyword arguments :func:`match_tie_points` takes from these settings."""
        return {
            "detector": self.detector,
            "model": self.model,
            "model_block_lines": int(self.model_block_lines),
            "max_shift_px": float(self.max_shift_px),
            "seed": int(self.seed),
        }


@dataclass(frozen=True)
class TiePoints:
    """Matched tie points and the fitted displacement model.

    ``pixel_line`` (n, 2): tie points in the product (continuous pixel, line); ``placed``
    (n, 2): where the rough placement must be evaluated for them (same coordinates);
    ``inlier`` (n,): RANSAC inliers; ``matches``: descriptor matches before RANSAC;
    ``residuals_px`` (inliers, 2): cross-validated residuals of the model, pixels;
    ``rmse_px``: their root mean square length. ``displacement(pixel, line)`` gives the fitted
    ``(d_pixel, d_line)`` anywhere in the product.
    """

    pixel_line: np.ndarray
    placed: np.ndarray
    inlier: np.ndarray
    matches: int
    residuals_px: np.ndarray
    rmse_px: float
    model: str
    detector: str
    displacement: Callable = field(repr=False, compare=False)

    @property
    def inliers(self) -> int:
        return int(self.inlier.sum())

    def report(self) -> dict:
        """JSON-ready summary: counts, RMSE and one row per inlier."""
        pl = self.pixel_line[self.inlier]
        pq = self.placed[self.inlier]
        return {
            "detector": self.detector,
            "model": self.model,
            "matches": int(self.matches),
            "inliers": self.inliers,
            "rmse_px": float(self.rmse_px),
            "residuals_are": "cross-validated (5-fold)",
            "points": [
                {
                    "pixel": float(a[0]),
                    "line": float(a[1]),
                    "placed_pixel": float(b[0]),
                    "placed_line": float(b[1]),
                    "residual_px": float(np.hypot(*r)),
                }
                for a, b, r in zip(pl, pq, self.residuals_px, strict=True)
            ],
        }


def place_reference(
    reference: np.ndarray,
    ref_transform,
    placement: Callable,
    shape: tuple[int, int],
    ref_valid: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The reference resampled into the product's raw geometry through ``placement``.

    Parameters
    ----------
    reference : 2-D array
        One band of the reference orthophoto (map grid).
    ref_transform : 6 numbers
        Its affine transform ``(a, b, c, d, e, f)``: ``x = a·col + b·row + c``,
        ``y = d·col + e·row + f`` (rasterio's order).
    placement : callable (pixel, line) -> (x, y)
        The rough image-to-map placement.
    shape : (lines, columns)
        The product's size.
    ref_valid : bool array, optional
        Valid reference cells.

    Returns
    -------
    chip : float32 (lines, columns)
        The reference seen in raw geometry (bilinear), NaN outside it.
    valid : bool (lines, columns)

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (Figure 10: products
    over the national orthophoto).
    """
    a, b, c, d, e, f = (float(v) for v in tuple(ref_transform)[:6])
    lines, cols = shape
    jj, ii = np.meshgrid(np.arange(cols) + 0.5, np.arange(lines) + 0.5)
    x, y = placement(jj, ii)
    det = a * e - b * d
    col = ((x - c) * e - (y - f) * b) / det - 0.5
    row = ((y - f) * a - (x - c) * d) / det - 0.5
    ref = np.asarray(reference, "float64")
    ok_ref = (
        np.isfinite(ref) if ref_valid is None else np.asarray(ref_valid, bool) & np.isfinite(ref)
    )
    filled = np.where(ok_ref, ref, np.nanmean(np.where(ok_ref, ref, np.nan)))
    chip = ndimage.map_coordinates(filled, [row, col], order=1, mode="nearest")
    inside = (row >= 0) & (row <= ref.shape[0] - 1) & (col >= 0) & (col <= ref.shape[1] - 1)
    ok = inside & (
        ndimage.map_coordinates(ok_ref.astype("float32"), [row, col], order=1, mode="constant")
        > 0.999
    )
    return np.where(ok, chip, np.nan).astype("float32"), ok


def _normalise(a: np.ndarray, ok: np.ndarray) -> np.ndarray:
    v = a[ok]
    lo, hi = np.percentile(v, [1, 99]) if v.size else (0.0, 1.0)
    out = (np.where(ok, a, lo) - lo) / (hi - lo if hi > lo else 1.0)
    return np.clip(out, 0, 1).astype("float64")


def _features(img: np.ndarray, detector: str, seed: int):
    from skimage.feature import ORB, SIFT

    if detector == "sift":
        ext = SIFT(upsampling=2, n_octaves=4)
    else:
        ext = ORB(n_keypoints=4000, fast_threshold=0.02, downscale=1.2, n_scales=4)
    try:
        ext.detect_and_extract(img)
    except RuntimeError:  # ORB on a featureless image
        return np.zeros((0, 2)), np.zeros((0, 1))
    return ext.keypoints.astype("float64"), ext.descriptors


def _matches(a_img, b_img, a_ok, b_ok, detector, max_shift, seed):
    from skimage.feature import match_descriptors

    ka, da = _features(a_img, detector, seed)
    kb, db = _features(b_img, detector, seed)
    if len(ka) < 3 or len(kb) < 3:
        return np.zeros((0, 2)), np.zeros((0, 2))
    pairs = match_descriptors(
        da,
        db,
        cross_check=True,
        max_ratio=MAX_RATIO,
        metric=None if detector == "sift" else "hamming",
    )
    pa, pb = ka[pairs[:, 0]], kb[pairs[:, 1]]
    near = np.hypot(*(pa - pb).T) <= max_shift
    ia = np.clip(np.rint(pa).astype(int), 0, np.array(a_ok.shape) - 1)
    ib = np.clip(np.rint(pb).astype(int), 0, np.array(b_ok.shape) - 1)
    inside = a_ok[ia[:, 0], ia[:, 1]] & b_ok[ib[:, 0], ib[:, 1]]
    keep = near & inside
    return pa[keep], pb[keep]  # (row, col)


def _ransac_blocks(
    src: np.ndarray, dst: np.ndarray, lines: int, block: int, threshold: float, seed: int
):
    """Inliers of an affine model fitted by RANSAC in each block of lines (each block's model
    sees its block and half a block either side; a point's verdict is its own block's)."""
    from skimage.measure import ransac
    from skimage.transform import AffineTransform

    inlier = np.zeros(len(src), bool)
    rows = src[:, 0]
    for start in range(0, lines, block):
        core = (rows >= start) & (rows < start + block)
        if not core.any():
            continue
        near = (rows >= start - block / 2) & (rows < start + 1.5 * block)
        if near.sum() < 6:
            continue
        _, ok = ransac(
            (src[near][:, ::-1], dst[near][:, ::-1]),
            AffineTransform,
            min_samples=3,
            residual_threshold=threshold,
            max_trials=500,
            rng=seed,
        )
        if ok is None:
            continue
        verdict = np.zeros(len(src), bool)
        verdict[np.flatnonzero(near)[ok]] = True
        inlier[core] = verdict[core]
    return inlier


def _fit_blocks(pl: np.ndarray, d: np.ndarray, lines: int, block: int) -> Callable:
    """Displacement as an affine function of (pixel, line) per block of lines, blended
    linearly between block centres (triangular weights over ±one block)."""
    centres = np.arange(block / 2, max(lines, 1) + block / 2, block, dtype="float64")
    coefs = []
    for tc in centres:
        half = float(block)
        while True:
            w = np.clip(1.0 - np.abs(pl[:, 1] - tc) / half, 0, None)
            sel = w > 0
            if sel.sum() >= 6 and np.ptp(pl[sel, 0]) > 0 or half > 4 * max(lines, block):
                break
            half *= 2.0  # too few tie points nearby: lean on a wider stretch of the line
        A = (
            np.column_stack([np.ones(sel.sum()), pl[sel, 0], pl[sel, 1] - tc])
            * np.sqrt(w[sel])[:, None]
        )
        if sel.sum() < 3:
            coefs.append(np.zeros((3, 2)))
            continue
        coef, *_ = np.linalg.lstsq(A, d[sel] * np.sqrt(w[sel])[:, None], rcond=None)
        coefs.append(coef)
    coefs = np.array(coefs)  # (blocks, 3, 2)

    def displacement(pixel, line):
        pixel = np.asarray(pixel, "float64")
        line = np.asarray(line, "float64")
        pos = np.clip((line - centres[0]) / block, 0, len(centres) - 1)
        k0 = np.floor(pos).astype(int)
        k1 = np.minimum(k0 + 1, len(centres) - 1)
        t = pos - k0
        out = []
        for k in (k0, k1):
            c = coefs[k]
            out.append(
                c[..., 0, :]
                + c[..., 1, :] * pixel[..., None]
                + c[..., 2, :] * (line - centres[k])[..., None]
            )
        v = out[0] * (1 - t)[..., None] + out[1] * t[..., None]
        return v[..., 0], v[..., 1]

    return displacement


def _fit_tps(pl: np.ndarray, d: np.ndarray, smoothing: float) -> Callable:
    from scipy.interpolate import RBFInterpolator

    rbf = RBFInterpolator(pl, d, kernel="thin_plate_spline", degree=1, smoothing=smoothing)

    def displacement(pixel, line):
        pixel = np.asarray(pixel, "float64")
        line = np.asarray(line, "float64")
        shape = np.broadcast(pixel, line).shape
        pts = np.column_stack(
            [np.broadcast_to(pixel, shape).ravel(), np.broadcast_to(line, shape).ravel()]
        )
        out = np.empty((len(pts), 2))
        for i in range(0, len(pts), 65536):
            out[i : i + 65536] = rbf(pts[i : i + 65536])
        return out[:, 0].reshape(shape), out[:, 1].reshape(shape)

    return displacement


def _fit(model, pl, d, lines, block, smoothing):
    return _fit_blocks(pl, d, lines, block) if model == "blocks" else _fit_tps(pl, d, smoothing)


def match_tie_points(
    image: np.ndarray,
    reference: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    ref_transform,
    placement: Callable,
    ref_valid: np.ndarray | None = None,
    detector: str = "sift",
    model: str = "blocks",
    model_block_lines: int = MODEL_BLOCK_LINES,
    max_shift_px: float = MAX_SHIFT_PX,
    ransac_px: float = RANSAC_PX,
    smoothing: float = TPS_SMOOTHING,
    seed: int = 0,
) -> TiePoints:
    """Find tie points between a raw band and a reference orthophoto and fit the wobble.

    Parameters
    ----------
    image : 2-D array (lines, columns)
        One band of the product in raw geometry (e.g. a NIR or red VNIR band).
    reference : 2-D array
        One band of the reference orthophoto on its map grid (a similar wavelength).
    valid : bool array, optional
        Valid product pixels.
    ref_transform : 6 numbers
        The reference's affine transform (rasterio's order ``a, b, c, d, e, f``).
    placement : callable (pixel, line) -> (x, y)
        Rough image-to-map placement (e.g. a :class:`~.transforms.Fit` on a few GCPs or the
        four corners), within ``max_shift_px`` of the truth.
    ref_valid : bool array, optional
        Valid reference cells.
    detector : {"sift", "orb"}
        scikit-image's feature detector and descriptor.
    model : {"blocks", "tps"}
        Displacement model: affine per block of lines, blended between blocks, or a smoothed
        thin-plate spline on the inliers.
    model_block_lines : int
        Lines per block (RANSAC and the ``blocks`` model).
    max_shift_px : float
        Largest displacement between the product and the placed reference (pixels).
    ransac_px : float
        RANSAC inlier threshold (pixels).
    smoothing : float
        ``tps`` only: smoothing of the spline (pixels²).
    seed : int
        RANSAC's random seed.

    Returns
    -------
    TiePoints
        Tie points, inliers, cross-validated residuals (pixels) and the displacement model.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: raw
    AISA-Dual lines without GPS/INS; Figure 10: overlay on the national orthophoto).
    Lowe, D.G. Distinctive image features from scale-invariant keypoints. Int. J. Comput.
    Vis. 2004, 60, 91–110. https://doi.org/10.1023/B:VISI.0000029664.99615.94
    Fischler, M.A.; Bolles, R.C. Random sample consensus. Commun. ACM 1981, 24, 381–395.
    https://doi.org/10.1145/358669.358692
    """
    img = np.asarray(image, "float64")
    ok = np.isfinite(img) if valid is None else np.asarray(valid, bool) & np.isfinite(img)
    lines, _ = img.shape
    chip, chip_ok = place_reference(reference, ref_transform, placement, img.shape, ref_valid)
    src, dst = _matches(
        _normalise(img, ok), _normalise(chip, chip_ok), ok, chip_ok, detector, max_shift_px, seed
    )
    inlier = (
        _ransac_blocks(src, dst, lines, model_block_lines, ransac_px, seed)
        if len(src) >= 6
        else np.zeros(len(src), bool)
    )
    # Keypoints are (row, col) of pixel centres: continuous (pixel, line) adds half a pixel.
    pl = src[:, ::-1] + 0.5
    placed = dst[:, ::-1] + 0.5
    pin, d = pl[inlier], (placed - pl)[inlier]
    residuals = np.zeros((len(pin), 2))
    if len(pin) >= 6:
        folds = np.random.default_rng(seed).permutation(len(pin)) % FOLDS
        for f in range(FOLDS):
            test = folds == f
            disp = _fit(model, pin[~test], d[~test], lines, model_block_lines, smoothing)
            pred = np.column_stack(disp(pin[test, 0], pin[test, 1]))
            residuals[test] = d[test] - pred
        displacement = _fit(model, pin, d, lines, model_block_lines, smoothing)
    else:

        def displacement(pixel, line):
            z = np.zeros(np.broadcast(np.asarray(pixel), np.asarray(line)).shape)
            return z, z

    rmse = float(np.sqrt(np.mean(np.sum(residuals**2, axis=1)))) if len(pin) else float("inf")
    return TiePoints(
        pixel_line=pl,
        placed=placed,
        inlier=inlier,
        matches=len(src),
        residuals_px=residuals,
        rmse_px=rmse,
        model=model,
        detector=detector,
        displacement=displacement,
    )


def corrected(placement: Callable, displacement: Callable) -> Callable:
    """The image-to-map model ``placement(pixel + d_pixel, line + d_line)``.

    Parameters
    ----------
    placement : callable (pixel, line) -> (x, y)
        The rough placement.
    displacement : callable (pixel, line) -> (d_pixel, d_line)
        A :class:`TiePoints` model.

    Returns
    -------
    callable (pixel, line) -> (x, y)

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2).
    """

    def model(pixel, line):
        dp, dl = displacement(pixel, line)
        return placement(np.asarray(pixel) + dp, np.asarray(line) + dl)

    return model
