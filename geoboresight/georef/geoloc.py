"""Per-pixel map coordinates of raw-geometry products: checking an IGM, preparing it for GDAL's
geolocation-array warper, and reading a GLT.

An IGM (input geometry map: NERC-ARF APL, CaliGeoPRO, gref4hsi) holds the map coordinates of
the centre of every raw pixel. A GLT (geometry lookup table: AVIRIS, AVIRIS-NG, EMIT) is the
reverse: on a map grid, the sample and line of the raw pixel seen there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import InputError


@dataclass(frozen=True)
class CleanIGM:
    """An IGM with its unusable pixels masked and filled.

    ``x``, ``y`` (lines, columns) float64: coordinates, masked pixels filled by interpolation
    from their neighbours so that the geolocation array stays smooth (the product's value at
    those pixels must not be drawn); ``valid``: pixels whose own coordinates are usable;
    ``nan``: pixels without finite coordinates; ``non_monotonic``: finite pixels that fall
    back behind their neighbours along the line or along the track (fold-overs, spikes).
    """

    x: np.ndarray
    y: np.ndarray
    valid: np.ndarray
    nan: int
    non_monotonic: int


def _not_between(s: np.ndarray, ok: np.ndarray, axis: int) -> np.ndarray:
    """Pixels whose projected position along ``axis`` is not between their two neighbours'
    (or, at the first and last pixel, not on the right side of their one neighbour)."""
    s = np.moveaxis(s, axis, -1)
    ok = np.moveaxis(ok, axis, -1)
    bad = np.zeros(s.shape, bool)
    if s.shape[-1] < 2:
        return np.moveaxis(bad, -1, axis)
    if s.shape[-1] == 2:
        bad[..., 0] = ok[..., 0] & ok[..., 1] & (s[..., 0] >= s[..., 1])
        return np.moveaxis(bad, -1, axis)
    prev, cur, nxt = s[..., :-2], s[..., 1:-1], s[..., 2:]
    three = ok[..., :-2] & ok[..., 1:-1] & ok[..., 2:]
    # Neighbours in order, the pixel not between them: a spike or a fold-over at the pixel.
    bad[..., 1:-1] = three & (prev < nxt) & ~((prev < cur) & (cur < nxt))
    # First and last pixels: on the wrong side of a neighbour that is itself in order.
    bad[..., 0] = ok[..., 0] & three[..., 0] & (s[..., 0] >= s[..., 1]) & (s[..., 1] < s[..., 2])
    bad[..., -1] = (
        ok[..., -1] & three[..., -1] & (s[..., -1] <= s[..., -2]) & (s[..., -3] < s[..., -2])
    )
    return np.moveaxis(bad, -1, axis)


def _direction(x, y, ok, axis: int) -> np.ndarray:
    """The median map step of one pixel along ``axis`` (unit vector)."""
    dx = np.diff(x, axis=axis)
    dy = np.diff(y, axis=axis)
    both = np.diff(ok.astype(np.int8), axis=axis) == 0
    both &= np.take(ok, range(1, ok.shape[axis]), axis=axis)
    if not both.any():
        return np.array([1.0, 0.0])
    v = np.array([np.median(dx[both]), np.median(dy[both])])
    n = np.hypot(*v)
    return v / n if n > 0 else np.array([1.0, 0.0])


def clean_igm(x: np.ndarray, y: np.ndarray, valid: np.ndarray | None = None) -> CleanIGM:
    """Mask the pixels of an IGM that cannot be placed, and fill them for the warper.

    Parameters
    ----------
    x, y : (lines, columns) arrays
        Easting and northing (or longitude and latitude) of every raw pixel's centre.
    valid : bool array, optional
        Pixels known to be usable (e.g. not the IGM's nodata value).

    Returns
    -------
    CleanIGM
        Coordinates with NaN and non-monotonic pixels masked (``valid`` False) and filled
        from their neighbours (first along the line, then along the track), and the counts of
        each. Along a pushbroom line the ground position advances with the column, and along
        the track with the line; a pixel that is not between its two neighbours' positions,
        projected on the median step direction, is a fold-over or a spike.

    Raises
    ------
    InputError
        When fewer than two lines and two columns of valid coordinates remain.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: pixel-by-pixel
    geo-location of AISA-Dual lines needs GPS/INS).
    Warren, M.A.; Taylor, B.H.; Grant, M.G.; Shutler, J.D. Data processing of remotely sensed
    airborne hyperspectral data using the Airborne Processing Library (APL): Geocorrection
    algorithm descriptions and spatial accuracy assessment. Comput. Geosci. 2014, 64, 24–34.
    https://doi.org/10.1016/j.cageo.2013.11.006
    """
    x = np.asarray(x, "float64")
    y = np.asarray(y, "float64")
    finite = np.isfinite(x) & np.isfinite(y)
    ok = finite if valid is None else finite & np.asarray(valid, bool)
    n_nan = int((~finite).sum())
    bad = np.zeros(x.shape, bool)
    for axis in (1, 0):
        u = _direction(x, y, ok, axis)
        s = x * u[0] + y * u[1]
        bad |= _not_between(np.where(ok, s, 0.0), ok, axis)
    usable = ok & ~bad
    if usable.any(axis=1).sum() < 2 or usable.any(axis=0).sum() < 2:
        raise InputError("fewer than two lines and two columns of usable coordinates")
    return CleanIGM(
        x=_fill(x, usable),
        y=_fill(y, usable),
        valid=usable,
        nan=n_nan,
        non_monotonic=int((bad & finite).sum()),
    )


def _fill(a: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """``a`` with masked entries interpolated linearly along each line from its valid pixels,
    then along each column for lines with no valid pixel; extrapolation takes the nearest."""
    out = np.array(a, "float64")
    if ok.all():
        return out
    cols = np.arange(a.shape[1])
    rows_ok = ok.any(axis=1)
    for i in np.flatnonzero(rows_ok & ~ok.all(axis=1)):
        out[i, ~ok[i]] = np.interp(cols[~ok[i]], cols[ok[i]], out[i, ok[i]])
    if not rows_ok.all():
        rows = np.arange(a.shape[0])
        good = np.flatnonzero(rows_ok)
        for j in range(a.shape[1]):
            out[~rows_ok, j] = np.interp(rows[~rows_ok], good, out[good, j])
    return out


def corner_geoloc(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The (2, lines + 1, columns + 1) pixel-corner coordinates, in GDAL's default
    top-left-corner convention, from pixel-centre coordinates.

    rasterio's ``src_geoloc_array`` hands the array to GDAL without a
    ``GEOREFERENCING_CONVENTION``, and GDAL then reads value ``[i, j]`` as the position of the
    point ``(pixel j, line i)``, the top-left corner of pixel ``[i, j]`` (measured: a
    half-pixel shift otherwise). A corner is the mean of the four surrounding centres; the
    outer corners are extrapolated linearly. The extra line and column are the bottom and
    right edges of the last pixels: warp a source padded with one line and one column of
    nodata, so that the last line and column are drawn whole.

    Parameters
    ----------
    x, y : (lines, columns) arrays
        Coordinates of the pixel centres (no NaN: see :func:`clean_igm`).

    Returns
    -------
    (2, lines + 1, columns + 1) float64 array

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2).
    GDAL RFC 4: Geolocation arrays. https://gdal.org/development/rfc/rfc4_geolocate.html
    """
    out = []
    for a in (np.asarray(x, "float64"), np.asarray(y, "float64")):
        p = a
        for axis in (0, 1):
            if p.shape[axis] > 1:
                p = np.pad(
                    p,
                    [(1, 1) if k == axis else (0, 0) for k in (0, 1)],
                    mode="reflect",
                    reflect_type="odd",
                )
            else:
                p = np.concatenate([p, p], axis=axis)
        out.append(0.25 * (p[:-1, :-1] + p[:-1, 1:] + p[1:, :-1] + p[1:, 1:]))
    return np.stack(out)


def glt_indices(
    sample: np.ndarray, line: np.ndarray, valid=None, *, width: int, height: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Zero-based (rows, columns) of the raw pixel each map cell of a GLT shows.

    Parameters
    ----------
    sample, line : 2-D integer arrays on the map grid
        One-based sample (column) and line indices into the raw product, as AVIRIS and EMIT
        ship them: 0 where no pixel is seen; a negative value (AVIRIS-NG) is a cell filled
        from its nearest neighbour, whose absolute value is the index.
    valid : bool array, optional
        Map cells to use (e.g. not the GLT's nodata).
    width, height : int
        Size of the raw product.

    Returns
    -------
    rows, cols : int arrays
        Zero-based indices (0 where not valid).
    valid : bool array
        Cells that show a raw pixel.
    outside : int
        Cells pointing beyond the product (the caller refuses the GLT when > 0).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2).
    Green, R.O. et al. EMIT L1B radiance data product user guide (GLT layer), NASA JPL, 2023.
    """
    s = np.abs(np.asarray(sample, "int64"))
    r = np.abs(np.asarray(line, "int64"))
    ok = (s > 0) & (r > 0)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    outside = ok & ((s > width) | (r > height))
    rows = np.where(ok & ~outside, r - 1, 0)
    cols = np.where(ok & ~outside, s - 1, 0)
    return rows, cols, ok & ~outside, int(outside.sum())


def footprint(valid: np.ndarray, erode: int = 0) -> np.ndarray:
    """The map cells inside a product's footprint: ``valid`` with holes filled, optionally
    eroded by ``erode`` cells (used to check that a warp leaves no gaps inside).

    Parameters
    ----------
    valid : 2-D bool array
        Cells that received a value.
    erode : int
        Cells removed along the border.

    Returns
    -------
    2-D bool array

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2).
    """
    filled = ndimage.binary_fill_holes(valid)
    return ndimage.binary_erosion(filled, iterations=erode) if erode else filled


def glt_coordinates(
    sample: np.ndarray,
    line: np.ndarray,
    valid,
    transform,
    *,
    width: int,
    height: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Map coordinates of every raw pixel from a GLT: the inverse of the lookup.

    Each raw pixel takes the mean centre of the map cells that show it directly (positive
    indices; a negative index is a cell filled from a neighbour, not where the pixel lies).
    A pixel no cell shows (gridding drops some where the map cell is larger or the line turns)
    takes the value of the affine fit of the others, so that a surface model can be read at
    every pixel.

    Parameters
    ----------
    sample, line : 2-D integer arrays on the map grid
        One-based indices into the raw product (:func:`glt_indices`).
    valid : bool array or None
        Map cells to use.
    transform : affine.Affine
        The GLT's geotransform.
    width, height : int
        Size of the raw product.

    Returns
    -------
    x, y : float64 arrays (height, width)
        Easting and northing (the GLT's CRS) of each raw pixel centre; NaN when the GLT shows
        fewer than three pixels.
    """
    s = np.asarray(sample, "int64")
    r = np.asarray(line, "int64")
    direct = (s > 0) & (r > 0)
    if valid is not None:
        direct &= np.asarray(valid, bool)
    rows, cols, ok, _ = glt_indices(s, r, direct, width=width, height=height)
    gy, gx = np.nonzero(ok)
    t = transform
    cx = t.c + t.a * (gx + 0.5) + t.b * (gy + 0.5)
    cy = t.f + t.d * (gx + 0.5) + t.e * (gy + 0.5)
    flat = rows[ok] * width + cols[ok]
    n = np.bincount(flat, minlength=width * height).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = np.bincount(flat, cx, minlength=width * height) / n
        y = np.bincount(flat, cy, minlength=width * height) / n
    x, y = x.reshape(height, width), y.reshape(height, width)
    seen = n.reshape(height, width) > 0
    if seen.sum() < 3:
        return np.full((height, width), np.nan), np.full((height, width), np.nan)
    pr, pc = np.nonzero(seen)
    design = np.column_stack([pc, pr, np.ones(pr.size)]).astype(np.float64)
    fx = np.linalg.lstsq(design, x[seen], rcond=None)[0]
    fy = np.linalg.lstsq(design, y[seen], rcond=None)[0]
    hr, hc = np.nonzero(~seen)
    holes = np.column_stack([hc, hr, np.ones(hr.size)]).astype(np.float64)
    x[~seen], y[~seen] = holes @ fx, holes @ fy
    return x, y
