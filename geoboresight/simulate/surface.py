"""The ground: a surface model (DSM) and a material map, described once and rasterised on demand.

A :class:`Surface` is a small description of a whole scene in metres (track frame: ``x``
across-track to the right of the flight, ``y`` along the flight direction, ``z`` up, ground
heights ≥ 0 with the lowest ground at 0):

* ``terrain``: a smooth height field on a coarse grid (interpolated with cubic splines);
* ``ground``: sub-pixel mixtures of ground materials, as weight fields on the same grid
  (e.g. grass and soil in varying proportions: this is the scene's fine texture);
* ``roads``: rectangles of one material (``asphalt``, ``concrete``, ...) painted on the ground;
* ``buildings``: boxes with flat roofs (height above the terrain at the box centre);
* ``trees``: crowns as ellipsoid caps on a trunk, of the ``tree`` material;
* ``brightness``: per material, a multiplicative reflectance factor field on the same grid
  (mean 1): the variation *within* a material that real ground always has at 1.5 m GSD —
  soil moisture and roughness, clods and stones, grass density, sand patches, stains on
  asphalt (see :func:`brightness_field` and ``presets.TEXTURE``). Spectrally flat: it scales
  a material's reflectance at every wavelength by the same factor.

:meth:`Surface.rasterize` turns a window of it into a fine grid (``dsm`` and per-material
area fractions); :meth:`Surface.brightness_on` gives the brightness factor of each fine cell. Everything is vectorised over grid cells; objects are looped over only to
find the few that touch a window.

Not modelled: sloping or pitched roofs, vertical wall materials (walls only occlude and cast
shadows), overhangs, water, moving objects.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from .spectra import MATERIAL_IDS


@dataclass(frozen=True)
class Window:
    """A fine raster window: cell centres at ``x0 + (j + 0.5) * cell``, ``y0 + (i + 0.5) * cell``."""

    x0: float
    y0: float
    nx: int
    ny: int
    cell: float

    def xy(self, i, j):
        """Map coordinates (x, y) of fractional cell indices (row i, col j)."""
        return self.x0 + (np.asarray(j) + 0.5) * self.cell, self.y0 + (
            np.asarray(i) + 0.5
        ) * self.cell

    def ij(self, x, y):
        """Fractional cell indices (row, col) of map coordinates."""
        return (np.asarray(y) - self.y0) / self.cell - 0.5, (
            np.asarray(x) - self.x0
        ) / self.cell - 0.5


@dataclass(frozen=True)
class Surface:
    """A scene's ground, in metres in the track frame (see the module docstring).

    ``x0, y0, cell`` locate the coarse grid of ``terrain`` and the ``ground`` weight fields:
    value ``[i, j]`` sits at ``(x0 + j*cell, y0 + i*cell)``.
    ``buildings``: (n, 6) array of x_min, x_max, y_min, y_max, height, roof material id.
    ``roads``: (n, 5) array of x_min, x_max, y_min, y_max, material id (later rows on top).
    ``trees``: (n, 4) array of x, y, crown radius, total height.
    ``brightness``: material name → reflectance factor field on the coarse grid (mean ≈ 1);
    materials without one keep their library reflectance everywhere.
    """

    x0: float
    y0: float
    cell: float
    terrain: np.ndarray
    ground: dict[str, np.ndarray]
    roads: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    buildings: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    trees: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    brightness: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def materials(self) -> list[str]:
        """Names of the materials this surface uses, in id order."""
        ids = {MATERIAL_IDS[n] for n in self.ground}
        ids.update(int(m) for m in self.roads[:, 4])
        ids.update(int(m) for m in self.buildings[:, 5])
        if len(self.trees):
            ids.add(MATERIAL_IDS["tree"])
        names = {v: k for k, v in MATERIAL_IDS.items()}
        return [names[i] for i in sorted(ids)]

    def max_height(self) -> float:
        """Highest point of the surface above the lowest ground (m), an upper bound."""
        tallest = 0.0
        if len(self.buildings):
            tallest = max(tallest, float(self.buildings[:, 4].max()))
        if len(self.trees):
            tallest = max(tallest, float(self.trees[:, 3].max()))
        return float(self.terrain.max()) + tallest

    def __post_init__(self):
        # Cubic-spline coefficients of the terrain, computed once (not per lookup).
        coef = ndimage.spline_filter(np.asarray(self.terrain, "float64"), order=3, mode="nearest")
        object.__setattr__(self, "_terrain_coef", coef)

    def _coarse(self, field_, x, y, order=1):
        i = np.atleast_1d((np.asarray(y, float) - self.y0) / self.cell)
        j = np.atleast_1d((np.asarray(x, float) - self.x0) / self.cell)
        return ndimage.map_coordinates(field_, [i, j], order=order, mode="nearest")

    def terrain_at(self, x, y) -> np.ndarray:
        """Terrain height (m) at points, cubic-spline interpolated."""
        shape = np.shape(x)
        i = np.atleast_1d((np.asarray(y, float) - self.y0) / self.cell).ravel()
        j = np.atleast_1d((np.asarray(x, float) - self.x0) / self.cell).ravel()
        z = ndimage.map_coordinates(
            self._terrain_coef, [i, j], order=3, mode="nearest", prefilter=False
        )
        return z.reshape(shape)

    def brightness_on(self, win: Window, frac: np.ndarray, materials: list[str]) -> np.ndarray:
        """(ny, nx) float32 reflectance factor of each fine cell: Σ_m fraction_m · factor_m.

        A cell mixing materials gets the area-weighted factor of its parts, applied to the
        cell's whole reflectance (exact for a pure cell; the cells are a third of a pixel).
        """
        out = np.ones((win.ny, win.nx), "float32")
        if not self.brightness:
            return out
        xs, ys = win.xy(np.arange(win.ny), np.arange(win.nx))
        X, Y = np.meshgrid(xs, ys)
        sampled: dict[int, np.ndarray] = {}  # one lookup per field shared by several materials
        for k, name in enumerate(materials):
            f = self.brightness.get(name)
            if f is None or k >= frac.shape[0]:
                continue
            if id(f) not in sampled:
                sampled[id(f)] = self._coarse(f, X, Y).reshape(X.shape).astype("float32")
            out += frac[k] * (sampled[id(f)] - 1.0)
        return out

    def rasterize(self, win: Window, materials: list[str]):
        """(dsm, fractions, ground) on ``win``: the surface (ny, nx), the material fractions
        (len(materials), ny, nx) and the bare terrain under objects (ny, nx), float32."""
        jj = np.arange(win.nx)
        ii = np.arange(win.ny)
        xs, ys = win.xy(ii, jj)  # 1-D: x per column, y per row
        X, Y = np.meshgrid(xs, ys)
        ground_z = self.terrain_at(X, Y).astype("float32")
        dsm = ground_z.copy()
        index = {name: k for k, name in enumerate(materials)}
        frac = np.zeros((len(materials), win.ny, win.nx), dtype="float32")
        weights = {n: np.clip(self._coarse(w, X, Y), 0, None) for n, w in self.ground.items()}
        total = sum(weights.values())
        total = np.where(total > 0, total, 1.0)
        for name, w in weights.items():
            frac[index[name]] = w / total

        def box(x_min, x_max, y_min, y_max):
            """Row/column slices of the cells whose centres fall in a rectangle (or None)."""
            j0 = int(np.ceil((x_min - win.x0) / win.cell - 0.5))
            j1 = int(np.floor((x_max - win.x0) / win.cell - 0.5)) + 1
            i0 = int(np.ceil((y_min - win.y0) / win.cell - 0.5))
            i1 = int(np.floor((y_max - win.y0) / win.cell - 0.5)) + 1
            j0, i0 = max(j0, 0), max(i0, 0)
            j1, i1 = min(j1, win.nx), min(i1, win.ny)
            if j0 >= j1 or i0 >= i1:
                return None
            return slice(i0, i1), slice(j0, j1)

        names = {v: k for k, v in MATERIAL_IDS.items()}
        for x_min, x_max, y_min, y_max, mat in self.roads:
            s = box(x_min, x_max, y_min, y_max)
            if s is not None:
                frac[(slice(None), *s)] = 0.0
                frac[(index[names[int(mat)]], *s)] = 1.0
        for x_min, x_max, y_min, y_max, height, mat in self.buildings:
            s = box(x_min, x_max, y_min, y_max)
            if s is None:
                continue
            base = float(self.terrain_at(0.5 * (x_min + x_max), 0.5 * (y_min + y_max)))
            dsm[s] = np.maximum(dsm[s], base + height)
            frac[(slice(None), *s)] = 0.0
            frac[(index[names[int(mat)]], *s)] = 1.0
        if len(self.trees):
            k = index["tree"]
            for x, y, radius, height in self.trees:
                s = box(x - radius, x + radius, y - radius, y + radius)
                if s is None:
                    continue
                d2 = ((X[s] - x) ** 2 + (Y[s] - y) ** 2) / radius**2
                inside = d2 < 1.0
                trunk = 0.35 * height
                crown = ground_z[s] + trunk + (height - trunk) * np.sqrt(np.clip(1.0 - d2, 0, 1))
                dsm[s] = np.where(inside, np.maximum(dsm[s], crown), dsm[s])
                # Crowns are opaque except a thin, gappy rim (canopy gaps at the edge).
                cover = np.clip((1.0 - d2) / 0.25, 0, 1)
                for m in range(len(materials)):
                    frac[(m, *s)] *= 1.0 - cover
                frac[(k, *s)] += cover
        return dsm, frac, ground_z


def smooth_field(rng: np.random.Generator, shape, sigma_cells: float) -> np.ndarray:
    """A zero-mean, unit-std Gaussian random field (white noise blurred by ``sigma_cells``)."""
    f = ndimage.gaussian_filter(rng.standard_normal(shape), sigma_cells, mode="wrap")
    return (f - f.mean()) / (f.std() + 1e-12)


def brightness_field(rng: np.random.Generator, shape, components, cell: float = 1.0):
    """A reflectance factor field ``1 + Σ std_i · field_i`` (float32, clipped to 0.6–1.4).

    ``components``: (correlation length in metres, standard deviation) pairs, each a Gaussian
    random field (:func:`smooth_field`) with that blur on a grid of ``cell`` metres; e.g.
    ``[(8.0, 0.06), (0.7, 0.05)]`` for moisture patches of ~10 m and clods/stones of ~1 m.
    """
    f = np.ones(shape, "float64")
    for length_m, std in components:
        f += std * smooth_field(rng, shape, max(length_m / cell, 0.3))
    return np.clip(f, 0.6, 1.4).astype("float32")
