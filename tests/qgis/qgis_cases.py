"""Inputs for running every registered algorithm: generic rules per parameter kind, plus a small
table for what the rules cannot guess. A new spec is covered without touching this file when
its inputs are scene files, rasters or defaults; otherwise the test says which entry to add.
"""

from __future__ import annotations

import os

#: Extra or overriding values per algorithm: {algorithm: {parameter: value or callable(inputs)}},
#: where ``inputs`` is the :class:`Inputs` of the session (scene files, derived rasters).
CASES: dict[str, dict] = {}

#: Rasters named like a scene file (simulator's truth files included) take that file.
_ALIASES = {
    "vnir": ("vnir",),
    "swir": ("swir",),
    "merged": ("merged",),
    "dsm": ("truth_dsm",),
    "truth": ("truth_shadow_fraction", "truth_target_abundance"),
    "shadow_fraction": ("truth_shadow_fraction",),
    "abundance": ("truth_target_abundance",),
    "target_abundance": ("truth_target_abundance",),
    "cloud_mask": ("truth_cloud_mask",),
    "clouds": ("truth_cloud_mask",),
    "material": ("truth_material",),
}


class Inputs:
    """The session's input files: the scene plus a boresight ratio raster made by the library."""

    def __init__(self, scene: dict, ratio: str):
        self.scene = scene
        self.ratio = ratio

    def raster(self, name: str) -> str:
        for key in _ALIASES.get(name, ()) + (name, f"truth_{name}"):
            if key in self.scene:
                return self.scene[key]
        for key, path in self.scene.items():
            if key.startswith("truth") and name.replace("truth_", "") in key:
                return path
        return self.ratio  # any other single-band raster input: the ratio is the product to use

    def file(self, name: str, extensions) -> str | None:
        exts = [e.lstrip(".").lower() for e in extensions]
        for path in self.scene.values():
            ext = os.path.splitext(path)[1].lstrip(".").lower()
            if (not exts or ext in exts) and (name in os.path.basename(path) or len(exts) == 1):
                return path
        return None


def values_for(spec, inputs: Inputs, out_dir: str) -> dict:
    """Library-style values (paths, enum strings) for one run of ``spec`` writing in ``out_dir``."""
    case = CASES.get(spec.name, {})
    values: dict = {}
    for p in spec.params:
        if p.name in case:
            v = case[p.name]
            values[p.name] = v(inputs) if callable(v) else v
        elif p.is_output:
            ext = f".{p.extension}" if p.extension else ""
            values[p.name] = os.path.join(out_dir, f"{p.name}{ext}")
        elif p.kind == "raster":
            if p.required or any(k in inputs.scene for k in _ALIASES.get(p.name, (p.name,))):
                values[p.name] = inputs.raster(p.name)
        elif p.kind == "multiraster":
            if p.required:
                values[p.name] = [inputs.ratio]
        elif p.kind == "file":
            if p.required:
                found = inputs.file(p.name, getattr(p, "extensions", ()))
                if found is None:
                    raise LookupError(
                        f"{spec.name}.{p.name}: no input file for this kind; add "
                        f"CASES[{spec.name!r}][{p.name!r}] in tests/qgis/qgis_cases.py"
                    )
                values[p.name] = found
        elif p.required:
            raise LookupError(
                f"{spec.name}.{p.name} ({p.kind}) is required and has no default; add "
                f"CASES[{spec.name!r}][{p.name!r}] in tests/qgis/qgis_cases.py"
            )
    return values


def to_qgis(spec, values: dict) -> dict:
    """The same values as QGIS parameters (enums as indexes, lists for multiple layers)."""
    out = {}
    for name, v in values.items():
        p = spec.param(name)
        out[name] = p.choices.index(v) if p.kind == "enum" else v
    return out
