"""Styles for raster outputs, so they open readable in QGIS.

- A class raster (an embedded colour table and category names, e.g. the shadow classes) gets
  a paletted renderer listing only its named classes, with their names: QGIS alone would list
  all 256 entries of the table (5–255 in black). A background class (value 0 named "no
  shadow", "background", "none", ...) is transparent, so the class raster lies over a map
  instead of hiding it under opaque white.
- Every continuous raster (ratio, scores, heights; band 1 of a multi-band one such as the
  disparity or an IGM) gets a pseudocolour ramp stretched over its 2–98 % cumulative range. The style is saved as a ``.qml`` sidecar beside the output
  (QGIS reads it whenever the file is opened later) and applied by a layer post-processor when
  Processing loads the result into the project.
"""

from __future__ import annotations

import os
import re

from qgis.core import (
    QgsGradientColorRamp,
    QgsGradientStop,
    QgsPalettedRasterRenderer,
    QgsProcessingLayerPostProcessorInterface,
    QgsRasterLayer,
    QgsSingleBandPseudoColorRenderer,
)
from qgis.PyQt.QtGui import QColor

from . import compat

# Viridis (perceptually uniform, colour-blind safe), as gradient stops.
_VIRIDIS = ("#440154", "#3b528b", "#21918c", "#5ec962", "#fde725")


def viridis() -> QgsGradientColorRamp:
    colors = [QColor(c) for c in _VIRIDIS]
    n = len(colors) - 1
    stops = [QgsGradientStop(i / n, c) for i, c in enumerate(colors[1:-1], start=1)]
    return QgsGradientColorRamp(colors[0], colors[-1], False, stops)


def qml_path(path: str) -> str:
    return os.path.splitext(path)[0] + ".qml"


def pseudocolor_renderer(layer: QgsRasterLayer, band: int = 1):
    """A viridis ramp over the 2–98 % cumulative range of ``band`` (QGIS's own default cut)."""
    provider = layer.dataProvider()
    lo, hi = provider.cumulativeCut(band, 0.02, 0.98)
    if not (lo == lo and hi == hi) or hi <= lo:  # NaN or a constant raster
        stats = provider.bandStatistics(band)
        lo, hi = stats.minimumValue, stats.maximumValue
        if hi <= lo:
            hi = lo + 1.0
    renderer = QgsSingleBandPseudoColorRenderer(provider, band)
    renderer.setClassificationMin(lo)
    renderer.setClassificationMax(hi)
    renderer.createShader(viridis(), compat.SHADER_INTERPOLATED, compat.SHADER_CONTINUOUS, 5)
    return renderer


def is_paletted(layer: QgsRasterLayer) -> bool:
    return layer.dataProvider().colorInterpretation(1) == compat.PALETTE_INDEX


def needs_ramp(layer: QgsRasterLayer) -> bool:
    return layer.isValid() and layer.bandCount() >= 1 and not is_paletted(layer)


#: Names of a class that means "nothing here": drawn transparent.
_BACKGROUND = re.compile(
    r"^\s*(no\b|none\b|not\b|background|nodata|no[ -]?data|unclassified|clear\b|outside)", re.I
)


def is_background(value: int, label: str) -> bool:
    """Class 0 named as an absence ("no shadow", "background", "none", "no data"): the
    class a map shows through."""
    return int(value) == 0 and bool(_BACKGROUND.match(label or ""))


def class_label(label: str) -> str:
    """One name per class: "80–100 % shadow (80-100 % shadow)" becomes "80–100 % shadow"."""
    m = re.fullmatch(r"\s*(.*?)\s*\((.*)\)\s*", label or "")
    if m and _same_name(m.group(1), m.group(2)):
        return m.group(1)
    return (label or "").strip()


def _same_name(a: str, b: str) -> bool:
    def norm(t: str) -> str:
        return re.sub(r"\s+", " ", t.replace("–", "-").replace("—", "-")).strip().lower()

    return norm(a) == norm(b)


def class_renderer(layer: QgsRasterLayer):
    """A paletted renderer with only the named classes of the colour table, labelled. QGIS's
    GDAL provider labels each colour-table entry with its category name (the library writes
    them in the PAM sidecar) or, for an unnamed entry, with its bare number: those go."""
    classes = QgsPalettedRasterRenderer.colorTableToClassData(layer.dataProvider().colorTable(1))
    kept = [c for c in classes if c.label.strip() and c.label.strip() != str(int(c.value))]
    for c in kept:
        c.label = class_label(c.label)
        if is_background(c.value, c.label):
            color = QColor(c.color)
            color.setAlpha(0)
            c.color = color
    return QgsPalettedRasterRenderer(layer.dataProvider(), 1, kept) if kept else None


def write_style(path: str) -> str | None:
    """Write the ``.qml`` sidecar for the raster at ``path``; its path, or None if not needed."""
    layer = QgsRasterLayer(path, os.path.basename(path), "gdal")
    if not layer.isValid() or layer.bandCount() < 1:
        return None
    if is_paletted(layer):
        renderer = class_renderer(layer)
        if renderer is None:
            return None  # a colour table without names: QGIS's own paletted renderer
        layer.setRenderer(renderer)
    else:
        layer.setRenderer(pseudocolor_renderer(layer))
    qml = qml_path(path)
    _, ok = layer.saveNamedStyle(qml)
    return qml if ok and os.path.exists(qml) else None


class LoadStyle(QgsProcessingLayerPostProcessorInterface):
    """Apply a saved .qml to the layer Processing loads into the project."""

    def __init__(self, qml: str):
        super().__init__()
        self.qml = qml

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802 (QGIS's name)
        if layer is not None and layer.isValid():
            layer.loadNamedStyle(self.qml)
            layer.triggerRepaint()


def renderer_for(layer: QgsRasterLayer):
    """The renderer :func:`write_style` would save, for a layer (None: keep QGIS's own)."""
    if not layer.isValid() or layer.bandCount() < 1:
        return None
    return class_renderer(layer) if is_paletted(layer) else pseudocolor_renderer(layer)


class StyleOnLoad(QgsProcessingLayerPostProcessorInterface):
    """Style the layer Processing loads without writing a sidecar: for the rasters of a
    folder output (simulate's files stay exactly as the library writes them)."""

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802 (QGIS's name)
        if layer is not None and layer.isValid():
            renderer = renderer_for(layer)
            if renderer is not None:
                layer.setRenderer(renderer)
                layer.triggerRepaint()


def style_on_load(path: str, context) -> None:
    if context is not None and context.willLoadLayerOnCompletion(path):
        post = StyleOnLoad()
        _KEEP.append(post)
        del _KEEP[:-64]
        context.layerToLoadOnCompletionDetails(path).setPostProcessor(post)


# Post-processors must outlive the algorithm run (QGIS holds only a C++ pointer to them).
_KEEP: list = []


def style_output(path: str, context, feedback=None) -> str | None:
    """Style one raster output (see module docstring); returns the sidecar written, if any."""
    try:
        qml = write_style(path)
    except Exception as exc:  # a style is a convenience: never fail a finished run over it
        if feedback is not None:
            feedback.reportError(f"could not write a style for {path}: {exc}", False)
        return None
    if qml and context is not None and context.willLoadLayerOnCompletion(path):
        post = LoadStyle(qml)
        _KEEP.append(post)
        del _KEEP[:-32]
        context.layerToLoadOnCompletionDetails(path).setPostProcessor(post)
    return qml
