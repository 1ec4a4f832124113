"""QGIS plugin entry point: QGIS calls :func:`classFactory` with its interface object.

The plugin only adds a Processing provider (``hasProcessingProvider=yes`` in metadata.txt), so it
also works in ``qgis_process`` and other headless contexts where ``iface`` is None.
"""


def classFactory(iface):  # noqa: N802 (QGIS's name)
    from .plugin import GeoboresightPlugin

    return GeoboresightPlugin(iface)
