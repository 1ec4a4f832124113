"""File-level operations: what a rasterio script calls to process a whole flight line.

Each function opens its inputs, picks bands, maps a kernel over block windows (with halos where
the kernel looks at neighbours), merges statistics exactly, and writes its outputs atomically.
The specs of :mod:`geoboresight.algorithms` declare these same functions as their ``run``, so
the command line, ``rio boresight``, QGIS and Dask batch call exactly what a script calls.
All of them are also importable from the top level: ``geoboresight.ratio_file``.
"""

from ._operation import operation

__all__ = ["operation"]
