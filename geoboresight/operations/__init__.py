"""File-level operations: what a rasterio script calls to process a whole flight line.

Each function opens its inputs, picks bands, maps a kernel over block windows (with halos where
the kernel looks at neighbours), merges statistics exactly, and writes its outputs atomically.
The specs of :mod:`geoboresight.algorithms` declare these functions as their ``run`` and wrap
them: the command line, ``rio boresight``, QGIS and Dask batch run exactly what a script calls
as ``geoboresight.ratio_file`` (the function checked against its spec, with ``overwrite``).
"""
