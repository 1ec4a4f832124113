"""The I/O layer: files, bands, wavelengths, nodata and masks, CRS and transform, atomic writes.

Core kernels never see a file; everything about files lives here (DESIGN.md).
"""

from .dual import DualSensor, SensorFile, open_dual
from .raster import (
    DEFAULT_BLOCK_ROWS,
    FLOAT_NODATA,
    create_class_raster,
    create_raster,
    grid_of,
    is_georeferenced,
    open_raster,
    output_profile,
    quiet_georef,
    read_masked,
    require_same_grid,
    row_windows,
    sample_pixels,
    write_envi,
    write_raster,
)
from .wavelengths import nearest_band, read_wavelengths, wavelengths_of
from .write import atomic_output, check_output_path

__all__ = [
    "DEFAULT_BLOCK_ROWS",
    "FLOAT_NODATA",
    "DualSensor",
    "SensorFile",
    "atomic_output",
    "check_output_path",
    "create_class_raster",
    "create_raster",
    "grid_of",
    "is_georeferenced",
    "nearest_band",
    "open_dual",
    "open_raster",
    "output_profile",
    "quiet_georef",
    "read_masked",
    "read_wavelengths",
    "require_same_grid",
    "row_windows",
    "sample_pixels",
    "wavelengths_of",
    "write_envi",
    "write_raster",
]
