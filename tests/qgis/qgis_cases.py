"""Inputs for running every registered algorithm: generic rules per parameter kind, plus a small
table for what the rules cannot guess. A new spec is covered without touching this file when
its inputs are scene files, rasters or defaults; otherwise the test says which entry to add.
"""

from __future__ import annotations

import json
import os
import re

#: Extra or overriding values per algorithm: {algorithm: {parameter: value or callable(inputs)}},
#: where ``inputs`` is the :class:`Inputs` of the test run (scene files, derived rasters).
CASES: dict[str, dict] = {
    "shadow-fraction-fit": {"truth": lambda i: i.raster("truth_shadow_fraction")},
    # The scene's DSM (matched by name) needs its sun, as for shadow-map below.
    "deshadow": {
        "shadow": lambda i: i.raster("truth_shadow_fraction"),
        "sun_zenith": lambda i: i.truth.get("sun", {}).get("zenith_deg", 45.0),
        "sun_azimuth": lambda i: i.truth.get("sun", {}).get("azimuth_deg", 135.0),
        "cell_size": lambda i: i.truth.get("gsd_m", 1.5),
    },
    # The scene's own DSM (matched by name) with its sun: the surface-model prior.
    "shadow-map": {
        "sun_zenith": lambda i: i.truth.get("sun", {}).get("zenith_deg", 45.0),
        "sun_azimuth": lambda i: i.truth.get("sun", {}).get("azimuth_deg", 135.0),
        "cell_size": lambda i: i.truth.get("gsd_m", 1.5),
    },
    "roc": {"truth": lambda i: i.raster("truth_target_abundance")},
    "anomaly-polygons": {"threshold": lambda i: i.percentile(i.ratio, 99.0)},
    "view-3d": {"dem": lambda i: i.raster("truth_dsm")},
    "sun-shadow": {
        "sun_zenith": lambda i: i.truth.get("sun", {}).get("zenith_deg", 45.0),
        "sun_azimuth": lambda i: i.truth.get("sun", {}).get("azimuth_deg", 135.0),
        "cell_size": lambda i: i.truth.get("gsd_m", 1.5),
    },
    "relative-dem": {
        "height_factor": lambda i: (
            abs(i.truth.get("disparity_px_per_m", {}).get("along", 0.05)) or 0.05
        ),
        "force": True,  # a small realistic squint: the product says so, but the wiring is tested
    },
    # keep the suite fast: fewer components / endmembers / lines than a real run would use
    "shadow-cluster": {"n_components": 2},
    "unmix": {"swir": None, "names": lambda i: ",".join(i.endmember_names()[:3])},
    "simulate": {"lines": 16},
    # A raw capture with its calibration file (the scene's ENVI cubes carry neither).
    "radiance": {
        "input": lambda i: i.capture("capture.hdr"),
        "calibration": lambda i: i.capture("capture_cal.cal"),
    },
    # The sample line with what its aircraft wrote (sample_data/scene/flight/): its navigation,
    # line times, sensor model and DEM; the calibration on GCPs where the true angles put pixels.
    "direct-georeference": {
        "input": lambda i: i.flight("../vnir.hdr"),
        "navigation": lambda i: i.flight("flight.out"),
        "line_times": lambda i: i.flight("line_times.txt"),
        "sensor_model": lambda i: i.flight("vnir_model.csv"),
        "dem": lambda i: i.flight("dem.tif"),
    },
    "boresight-calibrate": {
        "vnir": lambda i: i.flight("../vnir.hdr"),
        "swir": None,
        "reference": None,
        "navigation": lambda i: i.flight("flight.out"),
        "line_times": lambda i: i.flight("line_times.txt"),
        "sensor_model": lambda i: i.flight("vnir_model.csv"),
        "lever_arm": lambda i: i.flight_truth()["lever_arm_m"]["vnir"],
        "dem": lambda i: i.flight("dem.tif"),
        "gcps": lambda i: i.flight_gcps(),
    },
    "report": {"svdd": False},  # the DEM section then says it needs the sensor geometry
    # Georeferencing: a jittered raw line with its true IGM and orthophoto (simulate-ortho).
    "simulate-ortho": {"lines": 48},
    "geolocate": {"input": lambda i: i.ortho("raw.hdr"), "igm": lambda i: i.ortho("igm.img")},
    "georeference": {"input": lambda i: i.ortho("raw.hdr"), "gcps": lambda i: i.gcps()},
    "auto-georeference": {
        "input": lambda i: i.ortho("raw.hdr"),
        "reference": lambda i: i.ortho("orthophoto.tif"),
        "corners": lambda i: i.corners(),
        "reference_band": 4,  # NIR, as the raw band
    },
    "reproject-to": {
        "input": lambda i: i.derived("geolocate"),
        "reference": lambda i: i.ortho("orthophoto.tif"),
    },
}

#: Rasters named like a scene file (simulator's truth files included) take that file.
_ALIASES = {
    "vnir": ("vnir",),
    "image": ("vnir",),
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
    """The test run's input files: the scene plus a boresight ratio raster made by the library."""

    def __init__(self, scene: dict, ratio: str, work_dir: str):
        self.scene = scene
        self.ratio = ratio
        self.work_dir = work_dir
        self.truth = {}
        if "truth" in scene and scene["truth"].endswith(".json"):
            with open(scene["truth"], encoding="utf-8") as f:
                self.truth = json.load(f)
        self._derived: dict = {}

    def derived(self, alg: str, output: str = "output") -> str:
        """``output`` of the library's ``alg`` run once on the generic inputs (e.g. the
        class raster of 'shadow-classes' for 'shadow-polygons')."""
        from geoboresight.algorithms import registry

        if alg not in self._derived:
            spec = registry()[alg]
            folder = os.path.join(self.work_dir, f"derived-{alg}")
            os.makedirs(folder, exist_ok=True)
            values = values_for(spec, self, folder)
            self._derived[alg] = values
            spec(**values)
        return self._derived[alg][output]

    def ortho(self, name: str) -> str:
        """A file of a small simulate-ortho scene made once by the library."""
        folder = os.path.join(self.work_dir, "ortho")
        if not os.path.isdir(folder):
            from geoboresight import simulate_ortho_file

            simulate_ortho_file(output=folder, lines=96, jitter_deg=0.05, seed=2)
        return os.path.join(folder, name)

    def capture(self, name: str) -> str:
        """A file of a small scene with its raw capture and calibration (simulate --capture),
        made once by the library."""
        folder = os.path.join(self.work_dir, "capture")
        if not os.path.isdir(folder):
            from geoboresight import simulate_file

            simulate_file(output=folder, lines=16, seed=2, capture=True)
        return os.path.join(folder, name)

    def _igm(self):
        import rasterio

        from geoboresight.io import quiet_georef

        with quiet_georef(), rasterio.open(self.ortho("igm.img")) as src:
            return src.read(), src.crs

    def corners(self) -> str:
        """The line's true corner coordinates, 5 m off: the rough placement a user gives."""
        from geoboresight.io.orthoscene import true_corners

        igm, _ = self._igm()
        return ",".join(f"{v:.3f}" for v in (true_corners(igm) + 5.0).ravel())

    def flight(self, name: str) -> str:
        """A file of the sample line's flight (``sample_data/scene/flight``)."""
        here = os.path.dirname(os.path.abspath(__file__))
        folder = os.path.join(here, os.pardir, os.pardir, "sample_data", "scene", "flight")
        return os.path.normpath(os.path.join(folder, name))

    def flight_truth(self) -> dict:
        with open(self.flight("flight.json"), encoding="utf-8") as f:
            return json.load(f)

    def flight_gcps(self) -> str:
        """GCPs on the sample's VNIR image where the flight's true angles put 12 of its pixels."""
        path = os.path.join(self.work_dir, "flight_gcps.csv")
        if os.path.exists(path):
            return path
        import numpy as np
        import rasterio

        from geoboresight.io.navigation import read_navigation, read_sensor_model
        from geoboresight.sensor.boresight import LeverArm
        from geoboresight.sensor.calibrate import tie_point_ground
        from geoboresight.sensor.georeference import Surface

        known = self.flight_truth()
        with rasterio.open(self.flight("dem.tif")) as src:
            dem = Surface(src.read(1).astype("float64"), src.transform, src.crs.to_wkt())
        times = np.loadtxt(self.flight("line_times.txt"))
        model = read_sensor_model(self.flight("vnir_model.csv"))
        lever = LeverArm(*known["lever_arm_m"]["vnir"])
        nav = read_navigation(self.flight("flight.out"))
        project = tie_point_ground(nav, times, model, lever, dem)
        pl = np.array([(p, q) for p in (20.5, 143.0, 265.5) for q in (10.5, 70.0, 120.0, 180.5)])
        xy = project(known["boresight_deg"]["vnir"], 0.0, pl)
        with open(path, "w", encoding="utf-8") as f:
            f.write(f"# CRS: {known['crs']}\npixel,line,x,y\n")
            f.writelines(
                f"{p},{q},{x:.4f},{y:.4f}\n" for (p, q), (x, y) in zip(pl, xy, strict=True)
            )
        return path

    def gcps(self) -> str:
        """A GCP CSV of 12 raw pixels with their true map coordinates from the IGM."""
        path = os.path.join(self.work_dir, "gcps.csv")
        if not os.path.exists(path):
            igm, crs = self._igm()
            rows, cols = igm.shape[1:]
            with open(path, "w", encoding="utf-8") as f:
                f.write(f"# CRS: {crs.to_string()}\npixel,line,x,y\n")
                for r in (2, rows // 3, 2 * rows // 3, rows - 3):
                    for c in (2, cols // 2, cols - 3):
                        x, y = igm[0, r, c], igm[1, r, c]
                        f.write(f"{c + 0.5},{r + 0.5},{x:.3f},{y:.3f}\n")
        return path

    def endmember_names(self) -> list[str]:
        from geoboresight.io.spectra import read_spectral_library

        return read_spectral_library(self.scene["endmembers"])[2]

    @staticmethod
    def percentile(path: str, q: float) -> float:
        import numpy as np
        import rasterio

        from geoboresight.io import quiet_georef

        with quiet_georef(), rasterio.open(path) as src:
            return float(np.percentile(src.read(1, masked=True).compressed(), q))

    def raster(self, name: str, description: str = "") -> str:
        made_by = re.search(r"output of (?:the )?'([\w-]+)'", description)
        if made_by and made_by.group(1) != "ratio":
            return self.derived(made_by.group(1))
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
                values[p.name] = inputs.raster(p.name, p.description)
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
        elif (
            p.required and p.kind in ("number", "wavelength") and None not in (p.minimum, p.maximum)
        ):
            values[p.name] = (p.minimum + p.maximum) / 2  # a value in range
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
