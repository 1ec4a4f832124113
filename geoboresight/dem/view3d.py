"""The image draped on the relative DEM, as Figure 9E of the paper (matplotlib ``plot_surface``).

Pixels without a height (a masked cloud, nodata) are drawn black, as the paper's black,
cloud-masked border, at the height of their nearest valid neighbours: dropped to the lowest
level they would show as a crater with striped walls that is not in the ground. The surface is decimated to at most ``max_facets`` facets per side:
a 3-D view is for looking, and matplotlib's 3-D renderer slows down with the facet count.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError, ParameterError

#: The RGB drawn on the DEM: VNIR bands nearest these wavelengths (nm).
RED_NM = 640.0
GREEN_NM = 550.0
BLUE_NM = 460.0
#: Vertical exaggeration (the paper's Figure 9E shows 30 m of relief over 1,500 × 500 m).
EXAGGERATION = 3.0
#: Viewing elevation and azimuth (degrees).
ELEVATION = 35.0
AZIMUTH = -60.0
#: Facets per side of the drawn surface at most.
MAX_FACETS = 200


def stretch_rgb(red: np.ndarray, green: np.ndarray, blue: np.ndarray, percent: float = 2.0):
    """(rows, cols, 3) float RGB in 0–1 with a ``percent``–``100 − percent`` linear stretch."""
    out = []
    for band in (red, green, blue):
        b = np.asarray(band, np.float64)
        ok = np.isfinite(b)
        if not ok.any():
            out.append(np.zeros(b.shape))
            continue
        lo, hi = np.percentile(b[ok], [percent, 100.0 - percent])
        out.append(np.clip((np.where(ok, b, lo) - lo) / max(hi - lo, 1e-12), 0.0, 1.0))
    return np.dstack(out)


def fill_holes(z: np.ndarray) -> np.ndarray:
    """``z`` with each NaN replaced by the nearest finite value (all NaN: unchanged), so a
    masked area is drawn flat at its surroundings' height, not as a pit."""
    from scipy import ndimage

    hole = ~np.isfinite(z)
    if not hole.any() or hole.all():
        return z
    near = ndimage.distance_transform_edt(hole, return_distances=False, return_indices=True)
    return z[tuple(near)]


def drape_figure(
    dem: np.ndarray,
    rgb: np.ndarray,
    exaggeration: float = EXAGGERATION,
    pixel_size: tuple[float, float] = (1.0, 1.0),
    unit: str = "m",
    max_facets: int = MAX_FACETS,
    elevation: float = ELEVATION,
    azimuth: float = AZIMUTH,
    title: str | None = None,
):
    """A matplotlib :class:`~matplotlib.figure.Figure` of ``rgb`` draped on ``dem`` with
    vertical exaggeration (object-oriented API: a Figure with its own Agg canvas).

    Parameters
    ----------
    dem : 2-D array (rows, cols), metres; NaN = no height (drawn black, flat at the height of
        the nearest valid pixels).
    rgb : (rows, cols, 3) floats in 0–1 (see :func:`stretch_rgb`).
    exaggeration : float
        Vertical exaggeration (the paper's Figure 9E: 30 m of relief over 1,500 × 500 m).
    pixel_size : (along-track, across-track) size of a pixel, metres (1 px in raw geometry
        when unknown, then ``unit`` should say "px").
    """
    from ..figures import blank_figure, decimated_shape

    dem = np.asarray(dem, np.float64)
    rgb = np.asarray(rgb, np.float64)
    if rgb.shape != dem.shape + (3,):
        raise InputError(
            f"the RGB image {rgb.shape[:2]} and the DEM {dem.shape} are not on the same grid"
        )
    if not exaggeration > 0:
        raise ParameterError(f"parameter 'exaggeration': must be > 0, got {exaggeration}")
    ok = np.isfinite(dem)
    if not ok.any():
        raise InputError("the DEM has no valid height to draw")
    step, _ = decimated_shape(*dem.shape, max_facets)
    z = dem[::step, ::step]
    colours = rgb[::step, ::step].copy()
    hole = ~np.isfinite(z)
    zmin, zmax = float(np.nanmin(dem)), float(np.nanmax(dem))
    z = fill_holes(z)
    z = np.where(np.isfinite(z), z, zmin)
    colours[hole] = 0.0
    rows, cols = np.mgrid[0 : dem.shape[0] : step, 0 : dem.shape[1] : step]
    y = rows * pixel_size[0]
    x = cols * pixel_size[1]
    fig = blank_figure(8.0, 6.0)
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(
        x,
        y,
        z,
        facecolors=colours,
        rstride=1,
        cstride=1,
        linewidth=0,
        antialiased=False,
        shade=False,
    )
    relief = max(zmax - zmin, 1e-6)
    ax.set_box_aspect((float(np.ptp(x)) or 1.0, float(np.ptp(y)) or 1.0, relief * exaggeration))
    ax.set_xlabel(f"across-track ({unit})")
    ax.set_ylabel(f"along-track ({unit})")
    ax.set_zlabel("relative height (m)")
    ax.view_init(elev=elevation, azim=azimuth)
    ax.set_title(title or f"Relative DEM, vertical exaggeration × {exaggeration:g}")
    return fig
