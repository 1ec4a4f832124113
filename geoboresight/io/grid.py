"""The pixel grid of a raster, the one same-grid check and the one GeoTIFF profile builder.

Raw sensor geometry (no CRS, no geotransform) is common for pushbroom data: its grid has
``crs=None`` and ``transform=None``, and outputs on it stay raw (no Earth position is invented).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from rasterio.transform import Affine

from ..errors import InputError

#: Nodata written into float outputs.
FLOAT_NODATA = -9999.0
#: Tile size of every GeoTIFF output.
TILE = 256
#: DEFLATE level of every GeoTIFF output (zlib's default is 6). With the predictor, level 3
#: compresses a 20,000 × 286 float32 product in 55–75 % of level 6's time, 1–5 % larger
#: (relative DEM 9.4 → 9.9 MB, RX score 18.1 → 18.3 MB; a byte class map in a third of the
#: time, 4 % larger): compression is most of what writing a product costs. ``--co ZLEVEL=6``
#: trades time for size.
DEFLATE_LEVEL = 3


def is_local_crs(crs) -> bool:
    """True for an engineering (local) CRS: no Earth position, e.g. the metres-from-the-GSD
    CRS of raw-geometry outputs written with ``--raw-gsd`` (:data:`~.raster.RAW_LOCAL_WKT`)."""
    return crs is not None and not crs.is_geographic and not crs.is_projected


def is_georeferenced(src) -> bool:
    """True when the dataset has an Earth CRS or a non-identity geotransform; a local
    engineering CRS (raw geometry in metres from the GSD) is raw sensor geometry."""
    if is_local_crs(src.crs):
        return False
    return src.crs is not None or (src.transform != Affine.identity())


@dataclass(frozen=True)
class OutputGrid:
    """The map grid a raw-geometry product is warped onto: its ``crs`` (None: that of the
    coordinates), cell size ``resolution`` in the CRS's units (0: the product's median pixel
    spacing) and the ``resampling`` ("auto": nearest for class rasters, bilinear otherwise;
    "nearest", "bilinear", "cubic").

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.OutputGrid()  # the IGM's CRS, its pixel size, resampling chosen by the data type
    OutputGrid(crs=None, resolution=0.0, resampling='auto')
    >>> _ = gb.ratio_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                   output="out/ratio.tif")
    >>> result = gb.geolocate_file("out/ratio.tif", igm="sample_data/scene/igm.tif",
    ...                            output="out/ratio_3m.tif", grid=gb.OutputGrid(resolution=3))
    >>> result["resolution"], result["width"], result["height"], result["resampling"]
    (3.0, 174, 163, 'bilinear')
    """

    crs: str | None = None
    resolution: float = 0.0
    resampling: str = "auto"


@dataclass(frozen=True)
class Grid:
    """Size, CRS and geotransform of a raster; ``transform`` is None in raw sensor geometry.

    Examples
    --------
    >>> import geoboresight as gb
    >>> grid = gb.Grid(width=286, height=192)  # raw sensor geometry: no CRS, no transform
    >>> profile = grid.profile(count=1, dtype="float32", nodata=-9999.0)
    >>> profile["driver"], profile["compress"], profile["tiled"], "crs" in profile
    ('GTiff', 'deflate', True, False)
    """

    width: int
    height: int
    crs: Any = None
    transform: Any = None

    @classmethod
    def of(cls, src) -> Grid:
        """The grid of an open rasterio dataset (or of a :class:`Grid`, returned as is)."""
        if isinstance(src, Grid):
            return src
        georef = is_georeferenced(src)
        return cls(
            int(src.width),
            int(src.height),
            src.crs if georef else None,
            src.transform if georef else None,
        )

    @property
    def shape(self) -> tuple[int, int]:
        """(lines, columns), as NumPy arrays of one band are shaped."""
        return self.height, self.width

    @property
    def georeferenced(self) -> bool:
        return self.crs is not None or self.transform is not None

    def require_same(self, other: Grid, label: str, other_label: str) -> None:
        """Raise :class:`InputError` naming both rasters when ``other`` is on another grid.

        Size must match; CRS and geotransform must match where both rasters carry one (a raw
        raster may sit beside a georeferenced one of the same size: its pixels are the same).
        """
        if self.shape != other.shape:
            raise InputError(
                f"{label} is {self.width} × {self.height} pixels (columns × lines) but "
                f"{other_label} is {other.width} × {other.height}: both must be on the same "
                "pixel grid (crop or resample one of them onto the other first)"
            )
        if self.crs is not None and other.crs is not None and self.crs != other.crs:
            raise InputError(
                f"{label} is in {self.crs.to_string()} but {other_label} is in "
                f"{other.crs.to_string()}: reproject one onto the other's grid first"
            )
        if (
            self.transform is not None
            and other.transform is not None
            and not self.transform.almost_equals(other.transform)
        ):
            raise InputError(
                f"{label} and {other_label} have different geotransforms "
                f"({tuple(self.transform)[:6]} vs {tuple(other.transform)[:6]}): they must "
                "share one pixel grid"
            )

    def profile(
        self, *, count: int = 1, dtype: str = "float32", nodata=FLOAT_NODATA, **extra
    ) -> dict:
        """A GeoTIFF profile on this grid: tiled, deflate-compressed with the predictor that
        suits ``dtype``, BigTIFF when needed; no CRS or transform is invented for raw data."""
        profile = {
            "driver": "GTiff",
            "width": self.width,
            "height": self.height,
            "count": int(count),
            "dtype": str(np.dtype(dtype)),
            "compress": "deflate",
            "zlevel": DEFLATE_LEVEL,
            "predictor": 3 if np.dtype(dtype).kind == "f" else 2,
            "tiled": True,
            "blockxsize": TILE,
            "blockysize": TILE,
            "BIGTIFF": "IF_SAFER",
        }
        if count > 1:
            # Band-interleaved: a cube written strip by strip into pixel-interleaved tiles
            # (GDAL's default) recompresses every tile of all its bands for each strip once
            # the block cache is full (200 bands × 1,024 × 512: over 900 s against 15 s;
            # benchmarks/cube_write.py), and a viewer drawing 3 bands of 200 would
            # decompress all 200.
            profile["interleave"] = "band"
        if nodata is not None:
            profile["nodata"] = nodata
        if self.crs is not None:
            profile["crs"] = self.crs
        if self.transform is not None and self.transform != Affine.identity():
            profile["transform"] = self.transform
        profile.update(extra)
        return profile


def require_same_grid(a, b, label_a: str, label_b: str) -> None:
    """Raise :class:`InputError` naming both files when two rasters are on different grids.

    ``a`` and ``b`` are open datasets (their file names are added to the labels) or grids.
    """
    name_a = f"{label_a} {a.name}" if hasattr(a, "name") else label_a
    name_b = f"{label_b} {b.name}" if hasattr(b, "name") else label_b
    Grid.of(a).require_same(Grid.of(b), name_a, name_b)


def require_on_grid(src, grid: Grid, label: str) -> None:
    """Raise :class:`InputError` when ``src`` (a mask, a DEM) is not on the images' grid."""
    if (src.height, src.width) != grid.shape:
        raise InputError(
            f"{label} is {src.width} × {src.height} pixels but the images are {grid.width} × "
            f"{grid.height}: mismatched grids; give a raster on the image grid"
        )
    Grid.of(src).require_same(grid, label, "the images")
