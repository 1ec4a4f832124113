"""One generic Processing algorithm for any operation the engine describes.

Nothing here knows a particular operation: parameters, groups, help and declared results come
from the engine's operation list (``geoboresight engine describe``, a plain dict per operation),
and the work is done by the engine in its own process (:mod:`.engine_client`). The engine
validates everything again (bands against their raster included, since QGIS does not check
them), refuses to overwrite inputs and removes a failed or cancelled run's outputs.
"""

from __future__ import annotations

import html
import json
import os
import sys

from qgis.core import (
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingOutputBoolean,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
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
    QgsProcessingUtils,
    QgsProviderRegistry,
)
from qgis.PyQt.QtGui import QIcon

from . import compat, engine_client
from .formats import is_product_path, product_filter
from .styles import style_on_load, style_output

PLUGIN_DIR = os.path.dirname(os.path.abspath(__file__))
OUTPUT_KINDS = ("raster_out", "vector_out", "file_out", "folder_out")
#: ENVI data files GDAL opens for a header ``x.hdr`` (the engine applies the same rule,
#: geoboresight.io.raster.open_raster); only used so that QGIS's own check accepts a header.
_ENVI_DATA = ("", ".img", ".dat", ".raw", ".bsq", ".bil", ".bip")


def group_icon(group_id: str) -> QIcon:
    path = os.path.join(PLUGIN_DIR, "icons", f"{group_id}.svg")
    return QIcon(path if os.path.exists(path) else os.path.join(PLUGIN_DIR, "icon.svg"))


def _label(p: dict) -> str:
    """The field's label: a few words, as QGIS names its own parameters ("Input layer"); the
    sentence that explains it is the field's tooltip and the help pane's. An engine that
    describes no label gives its sentence (with the unit)."""
    if p.get("label"):
        return p["label"]
    unit = p.get("unit") or ""
    desc = p["description"]
    if unit and f"({unit}" not in desc and f"{unit})" not in desc:
        return f"{desc} ({unit})"
    return desc


def _file_filter(extensions) -> str:
    exts = [e.lstrip(".").lower() for e in extensions if e]
    if not exts:
        return "All files (*.*)"
    patterns = " ".join(f"*.{e}" for e in exts)
    return f"{'/'.join(e.upper() for e in exts)} files ({patterns});;All files (*.*)"


def _range_text(p: dict) -> str:
    lo, hi, unit = p.get("minimum"), p.get("maximum"), p.get("unit") or ""
    if lo is None and hi is None:
        return ""
    text = f"{'' if lo is None else f'{lo:g}'}–{'' if hi is None else f'{hi:g}'}"
    return f"{text} {unit}".strip()


class ProductRasterParameter(QgsProcessingParameterRasterLayer):
    """A raster input that also takes the sensor products the engine reads (Specim raw,
    HySpex, EnMAP L1B folder/zip/METADATA.XML, PRISMA L1 .he5): its file dialog offers them
    beside GDAL's rasters, and a product path is acceptable although QGIS cannot open it as a
    layer (the engine checks it). QGIS clones parameters for its widgets: ``clone`` keeps the
    class."""

    def __init__(self, name, description="", default=None, optional=False, formats=()):
        super().__init__(name, description, default, optional)
        self.formats = [tuple(f) for f in formats or ()]

    def clone(self):
        copy = ProductRasterParameter(
            self.name(), self.description(), self.defaultValue(), self.isOptional(), self.formats
        )
        copy.setFlags(self.flags())
        copy.setHelp(self.help())
        return copy

    def isOptional(self):  # noqa: N802
        return bool(self.flags() & compat.FLAG_OPTIONAL)

    def createFileFilter(self):  # noqa: N802
        return product_filter(self.formats, QgsProviderRegistry.instance().fileRasterFilters())

    def checkValueIsAcceptable(self, value, context=None):  # noqa: N802
        if is_product_path(value, self.formats):
            return True
        return super().checkValueIsAcceptable(value, context)


def to_qgis_parameter(p: dict) -> QgsProcessingParameterDefinition:
    """The QGIS parameter for one described parameter (by its ``kind``)."""
    desc = _label(p)
    kind, name, default = p["kind"], p["name"], p.get("default")
    optional = not p["required"]
    if kind == "raster" and p.get("formats"):
        q = ProductRasterParameter(name, desc, default, optional, p["formats"])
    elif kind == "raster":
        q = QgsProcessingParameterRasterLayer(name, desc, default, optional)
    elif kind == "multiraster":
        q = QgsProcessingParameterMultipleLayers(name, desc, compat.TYPE_RASTER, default, optional)
    elif kind == "file":
        q = QgsProcessingParameterFile(
            name,
            desc,
            compat.FILE_BEHAVIOR_FILE,
            "",
            default,
            optional,
            _file_filter(p.get("extensions", ())),
        )
    elif kind == "band":
        q = QgsProcessingParameterBand(name, desc, default, p["raster"], optional)
    elif kind in ("number", "wavelength"):
        lo, hi = p.get("minimum"), p.get("maximum")
        q = QgsProcessingParameterNumber(
            name,
            desc,
            compat.NUMBER_INTEGER if p.get("integer") else compat.NUMBER_DOUBLE,
            default,
            optional,
            -sys.float_info.max if lo is None else lo,
            sys.float_info.max if hi is None else hi,
        )
    elif kind == "enum":
        choices = list(p["choices"])
        index = choices.index(default) if default in choices else None
        q = QgsProcessingParameterEnum(name, desc, choices, False, index, optional)
    elif kind == "bool":
        q = QgsProcessingParameterBoolean(name, desc, bool(default), optional)
    elif kind == "string":
        q = QgsProcessingParameterString(name, desc, default, False, optional)
    elif kind == "numbers":
        # "X Y Z" in one text field (spaces or commas); the engine checks the count
        text = " ".join(f"{v:g}" for v in default) if default is not None else None
        q = QgsProcessingParameterString(name, desc, text, False, optional)
    elif kind == "raster_out":
        q = QgsProcessingParameterRasterDestination(name, desc, default, optional, not optional)
    elif kind == "vector_out":
        q = QgsProcessingParameterVectorDestination(
            name, desc, compat.TYPE_VECTOR_ANY, default, optional, not optional
        )
    elif kind == "file_out":
        q = QgsProcessingParameterFileDestination(
            name, desc, _file_filter([p.get("extension")]), default, optional, not optional
        )
    elif kind == "folder_out":
        q = QgsProcessingParameterFolderDestination(name, desc, default, optional, not optional)
    else:  # an engine newer than this plugin: fail loudly, not silently
        raise TypeError(f"geoboresight plugin: no QGIS parameter for kind {kind!r} ({name})")
    if p.get("advanced"):
        q.setFlags(q.flags() | compat.FLAG_ADVANCED)
    q.setHelp(p["description"])  # the field's tooltip
    return q


def _esc(text: str) -> str:
    return html.escape(str(text), quote=False)  # element text: quotes need no escaping


def help_html(spec: dict, engine_note: str = "") -> str:
    """The operation's help as simple HTML (paragraphs, then each parameter with its range
    and default, then the results)."""
    paras = [s.strip() for s in spec["help"].split("\n\n") if s.strip()]
    body = "".join(f"<p>{_esc(s)}</p>" for s in paras)
    items = []
    for p in spec["params"]:
        extra = []
        if p.get("choices"):
            extra.append("one of: " + ", ".join(p["choices"]))
        if _range_text(p):
            extra.append(f"range {_range_text(p)}")
        if p.get("default") is not None and not p["is_output"]:
            extra.append(f"default {p['default']}")
        if not p["required"] and p.get("default") is None:
            extra.append("optional")
        tail = f" <i>({_esc('; '.join(extra))})</i>" if extra else ""
        items.append(
            f"<li><b>{_esc(_label(p))}</b> ({_esc(p['name'])}): {_esc(p['description'])}{tail}</li>"
        )
    results = "".join(
        f"<li><b>{_esc(r['name'])}</b>: {_esc(r['description'])}</li>"
        for r in spec.get("results", ())
    )
    note = f"<p><i>{_esc(engine_note)}</i></p>" if engine_note else ""
    return (
        f"<p><b>{_esc(spec['short_help'])}</b></p>{note}{body}"
        f"<h3>Parameters</h3><ul>{''.join(items)}</ul>"
        + (f"<h3>Results</h3><ul>{results}</ul>" if results else "")
    )


def layer_path(layer, name: str) -> str:
    """The file behind a QGIS raster layer (the engine reads files, not layers)."""
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


def _is_header(value) -> bool:
    return isinstance(value, str) and value.lower().endswith(".hdr")


def _envi_data(header: str) -> str | None:
    stem = header[:-4]
    for ext in _ENVI_DATA:
        if os.path.isfile(stem + ext):
            return stem + ext
    return None


def _stem(path: str) -> str:
    return os.path.splitext(os.path.basename(str(path)))[0]


def _is_temporary_output(path: str) -> bool:
    temp = os.path.abspath(QgsProcessingUtils.tempFolder())
    return os.path.abspath(path).startswith(temp + os.sep)


#: Files of a folder output added as layers: GeoTIFFs, and ENVI data files (``.img``) that
#: have a header beside them.
_FOLDER_RASTERS = (".tif", ".tiff", ".img")


def folder_rasters(folder: str) -> list[str]:
    """The rasters a folder output holds, in name order."""
    found = []
    for entry in sorted(os.listdir(folder)):
        path = os.path.join(folder, entry)
        stem, ext = os.path.splitext(entry)
        if not os.path.isfile(path) or entry.startswith(".") or ext.lower() not in _FOLDER_RASTERS:
            continue
        if ext.lower() == ".img" and not os.path.isfile(os.path.join(folder, stem + ".hdr")):
            continue
        found.append(path)
    return found


def _warn_without_crs(path: str, feedback) -> None:
    """A raster in raw sensor geometry opens in a project that stays in EPSG:4326 (pixels read
    as degrees, the 3D view refuses it) and QGIS warns about nothing: say so once."""
    from qgis.core import QgsRasterLayer

    layer = QgsRasterLayer(path, "check", "gdal")
    if layer.isValid() and not layer.crs().isValid():
        feedback.pushWarning(
            f"{os.path.basename(path)} is in raw sensor geometry (no CRS): QGIS shows its "
            "pixels as if they were degrees and the 3D view refuses it; georeference the line "
            "(Georeferencing group) to place it on a map"
        )


class EngineAlgorithm(QgsProcessingAlgorithm):
    """A QGIS algorithm generated from one operation of the engine's list."""

    def __init__(self, spec: dict, engine_note: str = ""):
        super().__init__()
        self.spec = spec
        self.engine_note = engine_note
        self._params = {p["name"]: p for p in spec["params"]}

    def createInstance(self):  # noqa: N802 (QGIS API names)
        return EngineAlgorithm(self.spec, self.engine_note)

    def name(self):
        return self.spec["name"]

    def displayName(self):  # noqa: N802
        return self.spec["display_name"]

    def group(self):
        return self.spec["group"]

    def groupId(self):  # noqa: N802
        return self.spec["group_id"]

    def icon(self):
        return group_icon(self.spec["group_id"])

    def shortDescription(self):  # noqa: N802
        return self.spec["short_help"]

    def shortHelpString(self):  # noqa: N802
        return help_html(self.spec, self.engine_note)

    def tags(self):
        return ["hyperspectral", "boresight", "dual sensor", "aisa", self.spec["group"].lower()]

    def initAlgorithm(self, config=None):  # noqa: N802
        for p in self.spec["params"]:
            self.addParameter(to_qgis_parameter(p))
        # Scalar results as outputs, so the Graphical Modeler can chain them. A result named
        # like a parameter (e.g. unmix's 'endmembers') is returned and logged, not declared.
        for r in self.declared_results():
            cls = {
                "number": QgsProcessingOutputNumber,
                "boolean": QgsProcessingOutputBoolean,
            }.get(r["type"], QgsProcessingOutputString)
            self.addOutput(cls(r["name"], r["description"]))

    def declared_results(self) -> list[dict]:
        return [r for r in self.spec.get("results", ()) if r["name"] not in self._params]

    # ---------------------------------------------------------------- checks before the run
    def checkParameterValues(self, parameters, context):  # noqa: N802
        """Ranges with the range in the message, and ENVI headers (``.hdr``) accepted where
        QGIS alone would refuse them (it does not open a header as a raster)."""
        checked = dict(parameters)
        for name, p in self._params.items():
            value = parameters.get(name)
            if p["kind"] in ("number", "wavelength") and _is_set(parameters, name):
                message = self._range_error(p, value)
                if message:
                    return False, message
            if p["kind"] == "raster" and _is_header(value) and not os.path.isdir(value):
                if not os.path.exists(value):
                    return False, f"parameter '{name}': {value} does not exist: check the path"
                data = _envi_data(value)
                if data is None:
                    return False, (
                        f"parameter '{name}': {value} is an ENVI header but no data file sits "
                        "beside it (expected the same name without .hdr, or .img/.dat/.raw/"
                        ".bsq/.bil/.bip)"
                    )
                checked[name] = data
        return super().checkParameterValues(checked, context)

    @staticmethod
    def _range_error(p: dict, value) -> str | None:
        try:
            number = float(value)
        except (TypeError, ValueError):
            return None  # QGIS's own check names a value that is not a number
        lo, hi, unit = p.get("minimum"), p.get("maximum"), p.get("unit") or ""
        u = f" {unit}" if unit else ""
        if (lo is not None and number < lo) or (hi is not None and number > hi):
            return (
                f"parameter '{p['name']}': {number:g}{u} is outside the allowed range "
                f"{_range_text(p)} ({_label(p)})"
            )
        return None

    # ---------------------------------------------------------------- the run
    def collect(self, parameters, context) -> dict:
        """Values for the engine: file paths for layers, choices by name, outputs as paths;
        unset optionals left out (the engine fills its defaults)."""
        values = {}
        for p in self.spec["params"]:
            name, kind = p["name"], p["kind"]
            if kind in OUTPUT_KINDS:
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
                continue
            raw = parameters.get(name)
            if kind == "raster":
                if _is_header(raw) or is_product_path(raw, p.get("formats")):
                    values[name] = raw  # the engine opens the data file beside the header
                else:
                    layer = self.parameterAsRasterLayer(parameters, name, context)
                    values[name] = layer_path(layer, name)
            elif kind == "multiraster":
                items = raw if isinstance(raw, list | tuple) else None
                if items and all(_is_header(v) for v in items):
                    values[name] = list(items)
                else:
                    layers = self.parameterAsLayerList(parameters, name, context)
                    values[name] = [layer_path(layer, name) for layer in layers]
            elif kind == "file":
                values[name] = self.parameterAsFile(parameters, name, context)
            elif kind == "band":
                values[name] = self.parameterAsInt(parameters, name, context)
            elif kind in ("number", "wavelength"):
                if p.get("integer"):
                    values[name] = self.parameterAsInt(parameters, name, context)
                else:
                    values[name] = self.parameterAsDouble(parameters, name, context)
            elif kind == "enum":
                values[name] = p["choices"][self.parameterAsEnum(parameters, name, context)]
            elif kind == "bool":
                values[name] = self.parameterAsBool(parameters, name, context)
            elif kind == "string":
                values[name] = self.parameterAsString(parameters, name, context)
            elif kind == "numbers":
                if isinstance(raw, list | tuple):
                    # processing.run from Python (or a model) may give the numbers as a list,
                    # which QGIS's text parameter would turn into an empty string
                    text = " ".join(str(v) for v in raw)
                else:
                    text = self.parameterAsString(parameters, name, context)
                values[name] = text if text.strip() else None
            else:
                values[name] = raw
        return values

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        values = self.collect(parameters, context)
        outputs = [
            values[p["name"]]
            for p in self.spec["params"]
            if p["is_output"] and values.get(p["name"])
        ]
        try:
            engine = engine_client.locate(required=True)
            result = engine_client.run(
                engine, self.name(), values, feedback, overwrite=True, outputs=outputs
            )
        except engine_client.EngineError as exc:
            # QGIS shows a plain QgsProcessingException as its message alone (a Python
            # subclass would reach the user as a traceback)
            raise QgsProcessingException(str(exc)) from None
        declared = {r["name"]: r for r in self.declared_results()}
        outputs_by_name = {p["name"]: p for p in self.spec["params"] if p["is_output"]}
        outputs = {}
        for warning in result.get("warnings") or ():
            feedback.pushWarning(str(warning))
        for key, value in result.items():
            declared_string = key in declared and declared[key]["type"] == "string"
            if isinstance(value, list | dict) or (declared_string and not isinstance(value, str)):
                value = json.dumps(value)  # lists and tables as JSON text a model can parse
            outputs[key] = value
            if key not in outputs_by_name:
                feedback.pushInfo(f"{key}: {value}")
        for name, p in outputs_by_name.items():
            path = outputs.get(name)
            if not path:
                continue
            if p["kind"] == "raster_out":
                style_output(path, context, feedback)
                _warn_without_crs(path, feedback)
                self._name_layer(path, p, context)
            elif p["kind"] == "vector_out":
                self._name_layer(path, p, context)
            elif p["kind"] == "folder_out" and os.path.isdir(path):
                self._load_folder(path, context, feedback)
        return outputs

    @staticmethod
    def _name_layer(path: str, p: dict, context) -> None:
        """Layer names as QGIS core algorithms give them: a file the user named keeps its file
        name (``dem.tif`` loads as "dem", so the outputs of a batch run stay distinct), a
        temporary output gets the output's display name. QGIS alone would give a named file in
        a temporary folder (``/tmp``) the output's display name too: the file name is forced."""
        if context is None or not context.willLoadLayerOnCompletion(path):
            return
        details = context.layerToLoadOnCompletionDetails(path)
        details.name = _label(p) if _is_temporary_output(path) else _stem(path)
        details.forceName = True

    @staticmethod
    def _load_folder(folder: str, context, feedback) -> None:
        """An operation that writes a folder (simulate, simulate-ortho): its rasters are added
        as layers, each named by its file and styled (no sidecar written into the folder)."""
        from qgis.core import QgsProcessingContext

        if context is None or context.project() is None:
            return
        for path in folder_rasters(folder):
            details = QgsProcessingContext.LayerDetails(_stem(path), context.project(), "")
            details.forceName = True
            context.addLayerToLoadOnCompletion(path, details)
            style_on_load(path, context)  # no .qml written into the operation's folder
