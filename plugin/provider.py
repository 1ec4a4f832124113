"""The geoboresight Processing provider: one QGIS algorithm per library spec."""

from __future__ import annotations

import os

from qgis.core import QgsProcessingProvider
from qgis.PyQt.QtGui import QIcon

import geoboresight
from geoboresight.algorithms import registry

from .algorithm import SpecAlgorithm

_ICON = os.path.join(os.path.dirname(__file__), "icon.svg")


class GeoboresightProvider(QgsProcessingProvider):
    """Algorithms generated from ``geoboresight.algorithms.registry()`` (or given ``specs``)."""

    def __init__(self, specs=None):
        super().__init__()
        self._specs = specs

    def id(self):
        return "geoboresight"

    def name(self):
        return "geoboresight"

    def longName(self):  # noqa: N802 (QGIS API names)
        return f"geoboresight {geoboresight.__version__} (boresight effect, Brook & Ben-Dor 2011)"

    def icon(self):
        return QIcon(_ICON)

    def specs(self):
        return list(self._specs) if self._specs is not None else list(registry().values())

    def loadAlgorithms(self):  # noqa: N802
        for spec in self.specs():
            self.addAlgorithm(SpecAlgorithm(spec))

    # The library writes GeoTIFF rasters and GeoPackage/GeoJSON vectors itself.
    def supportedOutputRasterLayerExtensions(self):  # noqa: N802
        return ["tif"]

    def supportedOutputVectorLayerExtensions(self):  # noqa: N802
        return ["gpkg", "geojson"]

    def defaultRasterFileExtension(self):  # noqa: N802
        return "tif"

    def defaultVectorFileExtension(self, hasGeometry=True):  # noqa: N802, N803
        return "gpkg"
