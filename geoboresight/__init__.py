"""geoboresight: the boresight effect of dual pushbroom hyperspectral sensors as information.

Implements Brook & Ben-Dor, "Advantages of the boresight effect in hyperspectral data
analysis", Remote Sensing 3 (2011): the boresight band ratio b(1010 nm)/b(920 nm) (Eq. 3) and
its statistics, a shadow map, a relative DEM and a sub-pixel anomaly indicator.

Layers (DESIGN.md): core kernels (``ratio``, ``stats``, ...) on arrays; the I/O layer
(``geoboresight.io``) on files; algorithm specs (``geoboresight.algorithms``) from which the
CLI, the QGIS provider and the rio plugin are generated.
"""

__version__ = "0.1.0"
