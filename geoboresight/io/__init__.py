"""The I/O layer: files, bands, wavelengths, nodata and masks, CRS and transform, windows and
atomic writes.

Core kernels never see a file; everything about files lives here (docs/DEVELOPING.md).
"""

from . import _pixel
from .cube import Cube, open_cube, open_sensors
from .dual import BandChoice, DualLayout, DualSensor, RatioBands, SensorFile, as_dual, open_dual
from .grid import FLOAT_NODATA, Grid, is_georeferenced, require_same_grid
from .image import RasterImage, band_at, band_count, dataset_path, open_raster, raster_image
from .raster import (
    create_class_raster,
    create_raster,
    quiet_georef,
    scratch_raster,
    write_envi,
    write_raster,
)
from .spill import Spill
from .wavelengths import nearest_band, read_wavelengths, wavelengths_of
from .windows import (
    DEFAULT_BLOCK_ROWS,
    Block,
    band_reader,
    bands_reader,
    map_windows,
    read_masked,
    read_pixels,
    reduce_windows,
    row_windows,
    sample_windows,
)
from .write import (
    atomic_output,
    check_output_path,
    save_figure,
    split_paths,
    write_json,
    write_text,
)

# GDAL may run this package's radiance pixel function (and only it) in a VRT this process,
# or a worker it hands a flight line to, opens.
_pixel.trust()

__all__ = [
    "DEFAULT_BLOCK_ROWS",
    "FLOAT_NODATA",
    "BandChoice",
    "Block",
    "Cube",
    "DualLayout",
    "DualSensor",
    "Grid",
    "RasterImage",
    "RatioBands",
    "Spill",
    "SensorFile",
    "as_dual",
    "atomic_output",
    "band_at",
    "band_count",
    "band_reader",
    "bands_reader",
    "check_output_path",
    "create_class_raster",
    "create_raster",
    "scratch_raster",
    "dataset_path",
    "is_georeferenced",
    "map_windows",
    "nearest_band",
    "open_cube",
    "open_dual",
    "open_raster",
    "open_sensors",
    "quiet_georef",
    "raster_image",
    "read_masked",
    "read_pixels",
    "read_wavelengths",
    "reduce_windows",
    "require_same_grid",
    "row_windows",
    "sample_windows",
    "save_figure",
    "split_paths",
    "wavelengths_of",
    "write_envi",
    "write_json",
    "write_raster",
    "write_text",
]
