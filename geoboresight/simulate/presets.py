"""Scene presets: the surfaces (urban, dunes, glade, mixed) and the flight geometries.

Each surface builder receives a seeded random generator and the extent to cover (track frame,
metres) and returns a :class:`~.surface.Surface`. Sun angles default to the paper's scenes.

Geometry presets (``geometry=``):

* ``"realistic"`` — squint 0.3°, flying height 1,500 m (1.5 m pixels with the 1 mrad IFOV),
  nominal co-registration altitude 6,000 ft (1,828.8 m): the paper's regime, a residual
  along-track offset of about +1.15 px on flat ground and 0.0035 px per metre of relief (30 m of
  relief moves a feature by 0.1 px: not measurable; σ_h = 286 m per pixel of matching error).
* ``"large-squint"`` — squint 3°, flying height 1,500 m and nominal altitude = flying height
  (the co-registration removes the flat-ground offset): 0.035 px per metre, about 1 px per
  30 m of relief (σ_h = 28.6 m per pixel), for relative-DEM experiments.

Sub-material texture (:data:`TEXTURE`, :func:`add_texture`): no real ground is uniform at
1.5 m GSD. Each material class gets a spatially correlated, spectrally flat reflectance
factor (mean 1) with components at ~1 m and at several to ~10 m, standard deviations of a few
per cent (built surfaces) to ~8 % (bare soil, grass): soil moisture and roughness, clods and
stones; grass and dry-vegetation density and tussocks; sand grain-size and colour patches
and megaripple trains (the 5–30 cm wind ripples average out in a pixel); stains, patches and
cracks on asphalt and concrete; weathering on roofs; leaf clumping in crowns. Without it,
green vegetation and soil have nearly the same reflectance near 920–1,010 nm (grass 0.42,
soil 0.37 in earthlib) and open ground would be featureless in the boresight bands, which
real fields are not. The factors are drawn from their own generator (seed, 303), so the
layout of a scene (terrain, buildings, trees, targets, clouds) does not depend on them.
"""

from __future__ import annotations

import numpy as np

from .geometry import NOMINAL_ALTITUDE_M
from .spectra import MATERIAL_IDS
from .surface import Surface, brightness_field, smooth_field

SCENES = ("urban", "dunes", "glade", "mixed")
GEOMETRIES = {
    "realistic": {
        "squint_deg": 0.3,
        "flying_height": 1500.0,
        "nominal_altitude": NOMINAL_ALTITUDE_M,
    },
    "large-squint": {"squint_deg": 3.0, "flying_height": 1500.0, "nominal_altitude": None},
}
#: (zenith, azimuth) defaults, from the paper's figures (azimuth relative to the flight line).
SUN = {
    "urban": (30.8, 161.0),  # Figure 7 (shadow masks)
    "dunes": (46.4, 164.6),  # Figure 9 (relative DEM)
    "glade": (30.2, 141.2),  # Figure 11 (anomaly detection)
    "mixed": (46.4, 137.6),
}
DEFAULT_TARGETS = {"urban": 0, "dunes": 0, "glade": 12, "mixed": 24}

COARSE_CELL = 1.0
M = MATERIAL_IDS


def _grid(extent, cell=COARSE_CELL):
    x0, x1, y0, y1 = extent
    nx = int(np.ceil((x1 - x0) / cell)) + 2
    ny = int(np.ceil((y1 - y0) / cell)) + 2
    x = x0 + np.arange(nx) * cell
    y = y0 + np.arange(ny) * cell
    return x, y, np.meshgrid(x, y)


def _normalise(z, relief, X=None, Y=None, core=None):
    """Scale heights so that the ``core`` area (the image) spans ``relief`` metres from 0.

    Outside the core, heights are clipped at 0: the lowest ground of the image is z = 0.
    """
    inside = np.ones(z.shape, bool)
    if core is not None:
        inside = (X >= core[0]) & (X <= core[1]) & (Y >= core[2]) & (Y <= core[3])
        if not inside.any():
            inside[:] = True
    lo, hi = z[inside].min(), z[inside].max()
    return np.clip((z - lo) * (relief / max(hi - lo, 1e-9)), 0.0, None)


def _texture(rng, shape, pairs, scale=3.0):
    """Ground mixture weights: each (a, b) pair mixed by a smooth random field."""
    out = {}
    for a, b, share in pairs:
        f = 1.0 / (1.0 + np.exp(-1.8 * smooth_field(rng, shape, scale)))
        out[a] = out.get(a, 0) + share * f
        out[b] = out.get(b, 0) + share * (1 - f)
    return out


def _lots(rng, x_lo, x_hi, y_lo, y_hi, heights=(4.0, 25.0), roofs=None, fill=0.75):
    """Buildings packed in a block, with yards between them."""
    roofs = roofs or ["roof_shingle", "roof_tile", "roof_metal", "concrete"]
    out = []
    y = y_lo + rng.uniform(2, 5)
    while y < y_hi - 10:
        depth = rng.uniform(10, 30)
        x = x_lo + rng.uniform(2, 5)
        while x < x_hi - 10:
            width = rng.uniform(10, 35)
            if rng.uniform() < fill:
                bx1, by1 = min(x + width, x_hi - 2), min(y + depth, y_hi - 2)
                if bx1 - x > 6 and by1 - y > 6:
                    h = rng.uniform(*heights)
                    roof = M[roofs[rng.integers(len(roofs))]]
                    out.append((x, bx1, y, by1, h, roof))
            x += width + rng.uniform(4, 12)
        y += depth + rng.uniform(4, 12)
    return out


def _streets(extent, rng, spacing=(90, 130), width=10.0, walk=2.5):
    x0, x1, y0, y1 = extent
    roads, xs, ys = [], [], []
    x = x0 + rng.uniform(10, 60)
    while x < x1:
        xs.append(x)
        x += rng.uniform(*spacing)
    y = y0 + rng.uniform(10, 60)
    while y < y1:
        ys.append(y)
        y += rng.uniform(*spacing)
    for x in xs:  # along-track streets with sidewalks
        roads.append((x - width / 2 - walk, x + width / 2 + walk, y0, y1, M["concrete"]))
    for y in ys:
        roads.append((x0, x1, y - width / 2 - walk, y + width / 2 + walk, M["concrete"]))
    for x in xs:
        roads.append((x - width / 2, x + width / 2, y0, y1, M["asphalt"]))
    for y in ys:
        roads.append((x0, x1, y - width / 2, y + width / 2, M["asphalt"]))
    return roads, xs, ys, width / 2 + walk


def _blocks(extent, xs, ys, half):
    x0, x1, y0, y1 = extent
    ex = [x0 - 50, *xs, x1 + 50]
    ey = [y0 - 50, *ys, y1 + 50]
    for i in range(len(ex) - 1):
        for j in range(len(ey) - 1):
            yield ex[i] + half + 1, ex[i + 1] - half - 1, ey[j] + half + 1, ey[j + 1] - half - 1


def _trees(rng, candidates_xy, radius=(2.0, 4.5), height=(6.0, 14.0)):
    n = len(candidates_xy)
    if n == 0:
        return np.zeros((0, 4))
    r = rng.uniform(*radius, n)
    h = rng.uniform(*height, n)
    return np.column_stack([candidates_xy, r, h])


def _built_surface(x, y, terrain, ground, roads, buildings, rng, pts) -> Surface:
    """A surface with roads and buildings, and trees at the candidate sites ``pts`` that stay
    clear of roads (1 m) and buildings (3 m)."""
    pts = _free(pts, [r[:4] for r in roads], 1.0)
    pts = _free(pts, buildings[:, :4], 3.0)
    return Surface(
        x0=x[0],
        y0=y[0],
        cell=COARSE_CELL,
        terrain=terrain,
        ground=ground,
        roads=np.array(roads, float).reshape(-1, 5),
        buildings=buildings,
        trees=_trees(rng, pts),
    )


def _free(points, boxes, pad):
    """Points not inside any box (x_min, x_max, y_min, y_max) grown by ``pad``."""
    keep = np.ones(len(points), bool)
    for b in boxes:
        keep &= ~(
            (points[:, 0] > b[0] - pad)
            & (points[:, 0] < b[1] + pad)
            & (points[:, 1] > b[2] - pad)
            & (points[:, 1] < b[3] + pad)
        )
    return points[keep]


def urban(rng: np.random.Generator, extent, core=None) -> Surface:
    """Flat-roofed buildings in blocks, asphalt streets with concrete sidewalks, trees, yards."""
    x, y, (X, Y) = _grid(extent)
    terrain = _normalise(smooth_field(rng, X.shape, 60.0), 4.0, X, Y, core)
    ground = _texture(rng, X.shape, [("grass", "soil", 0.7), ("dark_soil", "soil", 0.3)])
    roads, xs, ys, half = _streets(extent, rng)
    buildings = []
    for block in _blocks(extent, xs, ys, half):
        buildings += _lots(rng, *block)
    buildings = np.array(buildings, float).reshape(-1, 6)
    area = (extent[1] - extent[0]) * (extent[3] - extent[2])
    pts = np.column_stack(
        [
            rng.uniform(extent[0], extent[1], int(area / 250)),
            rng.uniform(extent[2], extent[3], int(area / 250)),
        ]
    )
    return _built_surface(x, y, terrain, ground, roads, buildings, rng, pts)


def dunes(rng: np.random.Generator, extent, core=None) -> Surface:
    """Sand dunes: asymmetric ridges (gentle windward, steep lee slope), ~30 m of relief."""
    x, y, (X, Y) = _grid(extent)
    angle = rng.uniform(0, np.pi)
    s = X * np.cos(angle) + Y * np.sin(angle)
    wobble = 25.0 * smooth_field(rng, X.shape, 40.0)
    phase = (s + wobble) / rng.uniform(140, 180)
    saw = phase - np.floor(phase)
    ridge = np.where(saw < 0.75, saw / 0.75, (1 - saw) / 0.25)  # 3:1 windward:lee
    ridge = ndimage_smooth(ridge, 3.0)
    terrain = ridge * (0.75 + 0.25 * smooth_field(rng, X.shape, 60.0)) + 0.25 * smooth_field(
        rng, X.shape, 80.0
    )
    terrain = _normalise(terrain, 30.0, X, Y, core)
    low = np.clip(1.0 - terrain / 8.0, 0, 1)  # interdune corridors: crusted soil and shrubs
    ground = _texture(rng, X.shape, [("sand", "soil", 0.15)], scale=4.0)
    ground["sand"] = ground["sand"] + (1 - low) * 1.0
    ground["soil"] = ground["soil"] + 0.5 * low
    ground["dry_vegetation"] = 0.35 * low * (smooth_field(rng, X.shape, 2.0) > 0.8)
    return Surface(x0=x[0], y0=y[0], cell=COARSE_CELL, terrain=terrain, ground=ground)


def ndimage_smooth(a, sigma):
    from scipy import ndimage

    return ndimage.gaussian_filter(a, sigma)


def glade(rng: np.random.Generator, extent, core=None) -> Surface:
    """A forest clearing: dense canopy around an open patch of grass, soil and litter."""
    x, y, (X, Y) = _grid(extent)
    terrain = _normalise(smooth_field(rng, X.shape, 50.0), 8.0, X, Y, core)
    ground = _texture(
        rng, X.shape, [("grass", "soil", 0.6), ("dry_vegetation", "dark_soil", 0.4)], scale=2.5
    )
    cx, cy = 0.5 * (extent[0] + extent[1]), 0.5 * (extent[2] + extent[3])
    rx, ry = 0.3 * (extent[1] - extent[0]), max(0.3 * (extent[3] - extent[2]), 60.0)
    n = int((extent[1] - extent[0]) * (extent[3] - extent[2]) / 14.0)
    pts = np.column_stack(
        [rng.uniform(extent[0], extent[1], n), rng.uniform(extent[2], extent[3], n)]
    )
    edge = 1.0 + 0.15 * np.sin(5 * np.arctan2(pts[:, 1] - cy, pts[:, 0] - cx))
    outside = ((pts[:, 0] - cx) / rx) ** 2 + ((pts[:, 1] - cy) / ry) ** 2 > edge**2
    trees = _trees(rng, pts[outside], radius=(2.0, 4.0), height=(10.0, 22.0))
    track = [(cx - 2.0 + 0.4 * rx, cx + 2.0 + 0.4 * rx, extent[2], extent[3], M["dark_soil"])]
    trees = trees[~(np.abs(trees[:, 0] - track[0][0] - 2) < 2 + trees[:, 2])]
    return Surface(
        x0=x[0],
        y0=y[0],
        cell=COARSE_CELL,
        terrain=terrain,
        ground=ground,
        roads=np.array(track, float),
        trees=trees,
    )


def mixed(rng: np.random.Generator, extent, core=None) -> Surface:
    """~30 m of relief (a hill), a village of flat-roofed houses, trees, an open target field."""
    x, y, (X, Y) = _grid(extent)
    core = core or extent
    cx = core[0] + 0.85 * (core[1] - core[0])
    cy = core[2] + 0.6 * (core[3] - core[2])
    r = 0.3 * (core[1] - core[0])
    hill = np.exp(-0.5 * (((X - cx) / r) ** 2 + ((Y - cy) / (1.3 * r)) ** 2))
    terrain = _normalise(hill + 0.12 * smooth_field(rng, X.shape, 40.0), 30.0, X, Y, core)
    ground = _texture(rng, X.shape, [("grass", "soil", 0.5), ("dry_vegetation", "dark_soil", 0.5)])
    # The village: the left third of the swath; a gravel road along the track.
    vx0, vx1 = extent[0], core[0] + 0.33 * (core[1] - core[0])
    village = (vx0, vx1, extent[2], extent[3])
    roads, xs, ys, half = _streets(village, rng, spacing=(70, 100), width=8.0, walk=2.0)
    buildings = []
    for block in _blocks(village, xs, ys, half):
        bx0, bx1 = max(block[0], vx0), min(block[1], vx1 - 4)
        if bx1 - bx0 > 12:
            buildings += _lots(rng, bx0, bx1, block[2], block[3], heights=(4.0, 15.0), fill=0.6)
    gx = vx1 + 12.0
    roads.append((gx - 3.0, gx + 3.0, extent[2], extent[3], M["gravel"]))
    buildings = np.array(buildings, float).reshape(-1, 6)
    area = (extent[1] - extent[0]) * (extent[3] - extent[2])
    n = int(area / 120)
    pts = np.column_stack(
        [rng.uniform(extent[0], extent[1], n), rng.uniform(extent[2], extent[3], n)]
    )
    # Trees: in the village and on the hill, not in the open field between them.
    field_lo, field_hi = gx + 6.0, gx + 0.3 * (core[1] - core[0])
    pts = pts[(pts[:, 0] < field_lo - 8) | (pts[:, 0] > field_hi)]
    return _built_surface(x, y, terrain, ground, roads, buildings, rng, pts)


BUILDERS = {"urban": urban, "dunes": dunes, "glade": glade, "mixed": mixed}

_SOIL = ((8.0, 0.06), (0.7, 0.05))  # moisture/roughness patches; clods and stones
_VEGETATION = ((4.0, 0.06), (0.7, 0.05))  # cover density, vigour; tussocks and gaps
#: Material group → (correlation length m, standard deviation) components of its reflectance
#: factor; materials of one group share one field (e.g. the moisture pattern of soil and dark
#: soil). Typical within-field variation at metre scales: a few to ~10 % (see the module doc).
TEXTURE = {
    ("soil", "dark_soil"): _SOIL,
    ("grass", "dry_vegetation"): _VEGETATION,
    ("sand",): ((6.0, 0.04), (1.0, 0.03)),  # grain-size/colour patches; megaripple trains
    ("gravel",): ((5.0, 0.03), (0.7, 0.06)),  # patches; single stones
    ("asphalt", "concrete"): ((2.0, 0.03), (0.7, 0.02)),  # patches and stains; cracks
    ("roof_shingle", "roof_tile", "roof_metal"): ((3.0, 0.02),),  # weathering
    ("tree",): ((0.7, 0.04),),  # leaf clumping (crown shading comes from the DSM)
}


def add_texture(surface: Surface, rng: np.random.Generator, texture=None) -> Surface:
    """``surface`` with sub-material brightness fields (:data:`TEXTURE`) on its coarse grid."""
    from dataclasses import replace

    texture = TEXTURE if texture is None else texture
    shape = surface.terrain.shape
    fields = {}
    for group, components in texture.items():
        f = brightness_field(rng, shape, components, surface.cell)
        for name in group:
            fields[name] = f
    return replace(surface, brightness=fields)
