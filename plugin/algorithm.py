"""One generic QGIS Processing algorithm that wraps any geoboresight spec.

Nothing here knows about a particular operation: parameters, groups and help come from the
:class:`geoboresight.algorithms.spec.Algorithm` it wraps, and the work is done by
:func:`geoboresight.algorithms.execute`, which validates (bands against their raster included,
since QGIS does not check them), refuses to overwrite inputs and removes a failed run's outputs.
"""

from __future__ import annotations

import html
import os
import re
import sys

from qgis.core import (
    QgsProcessing,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingParameterBand,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterMultipleLayers,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterDestination,
    QgsProcessingParameterRasterLayer,
    QgsProcessingParameterString,
    QgsProcessingParameterVectorDestination,
    QgsProviderRegistry,
)

from geoboresight.algorithms import execute
from geoboresight.errors import Cancelled, GeoboresightError
from geoboresight.progress import Progress

from .styles import style_output


def group_id(group: str) -> str:
    """A stable lowercase id for a toolbox group ("Relative DEM" -> "relative_dem")."""
    return re.sub(r"[^a-z0-9]+", "_", group.lower()).strip("_")


def _described(p) -> str:
    unit = getattr(p, "unit", "")
    if unit and f"({unit}" not in p.description and f"{unit})" not in p.description:
        return f"{p.description} ({unit})"
    return p.description


def _file_filter(extensions) -> str:
    exts = [e.lstrip(".").lower() for e in extensions if e]
    if not exts:
        return "All files (*.*)"
    patterns = " ".join(f"*.{e}" for e in exts)
    return f"{'/'.join(e.upper() for e in exts)} files ({patterns});;All files (*.*)"


def to_qgis_parameter(p) -> QgsProcessingParameterDefinition:
    """The QGIS parameter for one spec parameter (by its ``kind``)."""
    desc = _described(p)
    kind = p.kind
    optional = not p.required
    if kind == "raster":
        q = QgsProcessingParameterRasterLayer(p.name, desc, p.default, optional)
    elif kind == "multiraster":
        q = QgsProcessingParameterMultipleLayers(
            p.name, desc, QgsProcessing.TypeRaster, p.default, optional
        )
    elif kind == "file":
        q = QgsProcessingParameterFile(
            p.name,
            desc,
            QgsProcessingParameterFile.File,
            "",
            p.default,
            optional,
            _file_filter(getattr(p, "extensions", ())),
        )
    elif kind == "band":
        q = QgsProcessingParameterBand(p.name, desc, p.default, p.raster, optional)
    elif kind in ("number", "wavelength"):
        integer = getattr(p, "integer", False)
        q = QgsProcessingParameterNumber(
            p.name,
            desc,
            QgsProcessingParameterNumber.Integer
            if integer
            else QgsProcessingParameterNumber.Double,
            p.default,
            optional,
            -sys.float_info.max if p.minimum is None else p.minimum,
            sys.float_info.max if p.maximum is None else p.maximum,
        )
    elif kind == "enum":
        default = p.choices.index(p.default) if p.default in p.choices else None
        q = QgsProcessingParameterEnum(p.name, desc, list(p.choices), False, default, optional)
    elif kind == "bool":
        q = QgsProcessingParameterBoolean(p.name, desc, bool(p.default), optional)
    elif kind == "string":
        q = QgsProcessingParameterString(p.name, desc, p.default, False, optional)
    elif kind == "raster_out":
        q = QgsProcessingParameterRasterDestination(p.name, desc, p.default, optional, not optional)
    elif kind == "vector_out":
        q = QgsProcessingParameterVectorDestination(
            p.name, desc, QgsProcessing.TypeVectorAnyGeometry, p.default, optional, not optional
        )
    elif kind == "file_out":
        q = QgsProcessingParameterFileDestination(
            p.name, desc, _file_filter([p.extension]), p.default, optional, not optional
        )
    elif kind == "folder_out":
        q = QgsProcessingParameterFolderDestination(p.name, desc, p.default, optional, not optional)
    else:  # a new kind in spec.py that this face does not know yet: fail loudly, not silently
        raise TypeError(f"geoboresight plugin: no QGIS parameter for kind {kind!r} ({p.name})")
    if p.advanced:
        q.setFlags(q.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
    return q


def help_html(spec) -> str:
    """The spec's help as simple HTML (paragraphs, then each parameter with range and default)."""
    paras = [s.strip() for s in spec.help.split("\n\n") if s.strip()]
    body = "".join(f"<p>{html.escape(s)}</p>" for s in paras)
    items = []
    for p in spec.params:
        extra = []
        if getattr(p, "choices", None):
            extra.append("one of: " + ", ".join(p.choices))
        lo, hi = getattr(p, "minimum", None), getattr(p, "maximum", None)
        if lo is not None or hi is not None:
            unit = getattr(p, "unit", "")
            extra.append(
                f"range {'' if lo is None else f'{lo:g}'}–{'' if hi is None else f'{hi:g}'} {unit}".strip()
            )
        if p.default is not None and not p.is_output:
            extra.append(f"default {p.default}")
        if not p.required and p.default is None:
            extra.append("optional")
        tail = f" <i>({html.escape('; '.join(extra))})</i>" if extra else ""
        items.append(f"<li><b>{html.escape(p.name)}</b>: {html.escape(p.description)}{tail}</li>")
    return f"<p><b>{html.escape(spec.short_help)}</b></p>{body}<h3>Parameters</h3><ul>{''.join(items)}</ul>"


def layer_path(layer, name: str) -> str:
    """The file behind a QGIS raster layer (the library reads files, not layers)."""
    if layer is None:
        raise QgsProcessingException(f"parameter '{name}': the raster layer could not be loaded")
    source = layer.source()
    if layer.providerType() == "gdal":
        parts = QgsProviderRegistry.instance().decodeUri("gdal", source)
        path = parts.get("path") or source
    else:
        path = source
    if not os.path.exists(path):
        raise QgsProcessingException(
            f"parameter '{name}': layer '{layer.name()}' is not a raster file on disk "
            f"({source}); save it as GeoTIFF first (Export > Save As...)"
        )
    return path


def _is_set(parameters, name) -> bool:
    value = parameters.get(name)
    if value is None:
        return False
    return not (isinstance(value, str) and value == "")


class SpecAlgorithm(QgsProcessingAlgorithm):
    """A QGIS algorithm generated from one geoboresight spec."""

    def __init__(self, spec):
        super().__init__()
        self.spec = spec

    def createInstance(self):  # noqa: N802 (QGIS API names)
        return SpecAlgorithm(self.spec)

    def name(self):
        return self.spec.name

    def displayName(self):  # noqa: N802
        return self.spec.display_name

    def group(self):
        return self.spec.group

    def groupId(self):  # noqa: N802
        return group_id(self.spec.group)

    def shortDescription(self):  # noqa: N802
        return self.spec.short_help

    def shortHelpString(self):  # noqa: N802
        return help_html(self.spec)

    def tags(self):
        return ["hyperspectral", "boresight", "dual sensor", "aisa", self.spec.group.lower()]

    def initAlgorithm(self, config=None):  # noqa: N802
        for p in self.spec.params:
            self.addParameter(to_qgis_parameter(p))

    def collect(self, parameters, context) -> dict:
        """Raw values for :func:`execute`: file paths for layers; unset optionals left out."""
        values = {}
        for p in self.spec.params:
            name, kind = p.name, p.kind
            if kind in ("raster_out", "vector_out", "file_out", "folder_out"):
                if kind in ("raster_out", "vector_out"):
                    path = self.parameterAsOutputLayer(parameters, name, context)
                else:
                    path = self.parameterAsFileOutput(parameters, name, context)
                if not path:
                    continue
                if kind == "vector_out" and (
                    "|" in path or path.startswith(("memory:", "ogr:", "postgres"))
                ):
                    raise QgsProcessingException(
                        f"output '{name}': only a GeoPackage or GeoJSON file can be written "
                        f"(got {path}); choose 'Save to File...'"
                    )
                values[name] = path
                continue
            if not _is_set(parameters, name):
                continue  # execute() fills the spec's default, or names the missing parameter
            if kind == "raster":
                values[name] = layer_path(
                    self.parameterAsRasterLayer(parameters, name, context), name
                )
            elif kind == "multiraster":
                layers = self.parameterAsLayerList(parameters, name, context)
                values[name] = [layer_path(layer, name) for layer in layers]
            elif kind == "file":
                values[name] = self.parameterAsFile(parameters, name, context)
            elif kind == "band":
                values[name] = self.parameterAsInt(parameters, name, context)
            elif kind in ("number", "wavelength"):
                if getattr(p, "integer", False):
                    values[name] = self.parameterAsInt(parameters, name, context)
                else:
                    values[name] = self.parameterAsDouble(parameters, name, context)
            elif kind == "enum":
                values[name] = p.choices[self.parameterAsEnum(parameters, name, context)]
            elif kind == "bool":
                values[name] = self.parameterAsBool(parameters, name, context)
            elif kind == "string":
                values[name] = self.parameterAsString(parameters, name, context)
            else:
                values[name] = parameters[name]
        return values

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        values = self.collect(parameters, context)

        def report(fraction, message=None):
            feedback.setProgress(100.0 * fraction)
            if message:
                feedback.setProgressText(message)

        progress = Progress(
            callback=report, is_cancelled=feedback.isCanceled, log=feedback.pushInfo
        )
        try:
            result = execute(self.spec, values, progress=progress, overwrite=True)
        except Cancelled:
            # execute() removed the partial outputs; QGIS reports the cancellation itself.
            raise QgsProcessingException("cancelled by the user: no output was written") from None
        except GeoboresightError as exc:
            raise QgsProcessingException(str(exc)) from None
        outputs = {}
        for key, value in result.items():
            if value is None or isinstance(value, bool | int | float | str):
                outputs[key] = value
            elif isinstance(value, list | tuple) and all(
                isinstance(v, int | float | str) for v in value
            ):
                outputs[key] = list(value)
            else:
                outputs[key] = str(value)
            if key not in {p.name for p in self.spec.outputs}:
                feedback.pushInfo(f"{key}: {outputs[key]}")
        for p in self.spec.outputs:
            if p.kind == "raster_out" and outputs.get(p.name):
                style_output(outputs[p.name], context, feedback)
        return outputs
