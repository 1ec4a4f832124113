"""One place for the QGIS enums whose names changed: scoped enums (``Qgis.ProcessingSourceType.Raster``,
QGIS >= 3.36 and required by QGIS 4) where the running QGIS has them, the old unscoped names
(``QgsProcessing.TypeRaster``) on older versions such as Debian's 3.22. QGIS 4 drops the old
names, so nothing else in the plugin may spell them.

:func:`pick` does the lookup and is tested on both branches with stand-in objects.
"""

from __future__ import annotations

from qgis.core import (
    Qgis,
    QgsColorRampShader,
    QgsProcessing,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterFile,
    QgsProcessingParameterNumber,
    QgsRaster,
)

_MISSING = object()


def _dotted(root, path: str):
    obj = root
    for part in path.split("."):
        obj = getattr(obj, part, _MISSING)
        if obj is _MISSING:
            return _MISSING
    return obj


def pick(root, scoped: str, legacy_owner, legacy: str):
    """``root.<scoped>`` (e.g. ``Qgis`` + ``"ProcessingSourceType.Raster"``) when it exists,
    else ``legacy_owner.<legacy>``; a clear error when neither does."""
    value = _dotted(root, scoped)
    if value is not _MISSING:
        return value
    value = _dotted(legacy_owner, legacy)
    if value is not _MISSING:
        return value
    raise AttributeError(f"this QGIS has neither Qgis.{scoped} nor {legacy}")


# Processing source types
TYPE_RASTER = pick(Qgis, "ProcessingSourceType.Raster", QgsProcessing, "TypeRaster")
TYPE_VECTOR_ANY = pick(
    Qgis, "ProcessingSourceType.VectorAnyGeometry", QgsProcessing, "TypeVectorAnyGeometry"
)
# Parameter flags
FLAG_ADVANCED = pick(
    Qgis, "ProcessingParameterFlag.Advanced", QgsProcessingParameterDefinition, "FlagAdvanced"
)
FLAG_OPTIONAL = pick(
    Qgis, "ProcessingParameterFlag.Optional", QgsProcessingParameterDefinition, "FlagOptional"
)
# Number and file parameter types
NUMBER_INTEGER = pick(
    Qgis, "ProcessingNumberParameterType.Integer", QgsProcessingParameterNumber, "Integer"
)
NUMBER_DOUBLE = pick(
    Qgis, "ProcessingNumberParameterType.Double", QgsProcessingParameterNumber, "Double"
)
FILE_BEHAVIOR_FILE = pick(
    Qgis, "ProcessingFileParameterBehavior.File", QgsProcessingParameterFile, "File"
)
# Raster colour interpretation and shaders (styles)
PALETTE_INDEX = pick(Qgis, "RasterColorInterpretation.PaletteIndex", QgsRaster, "PaletteIndex")
SHADER_INTERPOLATED = pick(
    Qgis, "ShaderInterpolationMethod.Linear", QgsColorRampShader, "Interpolated"
)
SHADER_CONTINUOUS = pick(
    Qgis, "ShaderClassificationMethod.Continuous", QgsColorRampShader, "Continuous"
)
# Message levels (Qgis.MessageLevel exists in 3.22 too, with the members on Qgis itself)
INFO = pick(Qgis, "MessageLevel.Info", Qgis, "Info")
WARNING = pick(Qgis, "MessageLevel.Warning", Qgis, "Warning")
CRITICAL = pick(Qgis, "MessageLevel.Critical", Qgis, "Critical")
SUCCESS = pick(Qgis, "MessageLevel.Success", Qgis, "Success")


def has_flag(flags, flag) -> bool:
    """``flag`` set in ``flags`` (works for old int-like flags and scoped enum flags)."""
    return bool(flags & flag)
