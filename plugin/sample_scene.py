"""*Plugins ▸ geoboresight ▸ Open the sample scene*: a first-run tour that puts the sample
scene's products on its orthophoto, with no file to find and no network.

The scene (a simulated AISA-Dual VNIR+SWIR line, ``docs/simulator.md``) comes, first found
wins, from:

1. a ``geoboresight_sample/`` folder shipped with the engine (in its site-packages) or put in
   the profile (``<profile>/geoboresight/geoboresight_sample/``), holding ``vnir.hdr``,
   ``swir.hdr`` and, when the scene has them, its IGM (``igm.tif``) and orthophoto
   (``ortho.tif``);
2. the engine itself: ``simulate`` with the sample recipe (``--preset mixed --lines 192 --seed 4
   --geometry large-squint --clouds 1 --navigation``, the recipe of ``sample_data/scene``, which
   writes the scene's own IGM and orthophoto) into the profile folder; for a scene without
   them, ``simulate-ortho`` (the same preset, lines and seed) for a simulated IGM and
   orthophoto in UTM.

Then, through the engine: the boresight ratio and the shadow map of the raw line, each put on
the map with ``geolocate`` and the IGM, and the orthophoto and both products are added as
layers in the orthophoto's CRS (the shadow classes over it, their "no shadow" class
transparent). Everything is cached in ``<profile>/geoboresight/sample``: a second tour only
loads the layers.
"""

from __future__ import annotations

import glob
import os

from qgis.core import QgsProcessingFeedback, QgsTask

from . import engine_client
from .styles import write_style

FOLDER_NAME = "geoboresight_sample"
#: The sample scene's recipe (sample_data/README.md).
RECIPE = {
    "preset": "mixed",
    "lines": 192,
    "seed": 4,
    "geometry": "large-squint",
    "clouds": 1,
    "navigation": True,  # igm.tif and ortho.tif: the scene's own map placement
}
#: A simulated IGM and orthophoto for a scene that comes without its own.
ORTHO_RECIPE = {"preset": "mixed", "lines": 192, "seed": 4}
#: The layers of the tour, bottom to top: (key, layer name, opacity).
LAYERS = (
    ("orthophoto", "orthophoto", 1.0),
    ("ratio", "boresight ratio", 0.75),
    ("shadow", "shadow classes", 1.0),
    ("dem", "relative DEM", 0.6),
)


def work_folder() -> str:
    """Where the tour simulates and writes: ``<profile>/geoboresight/sample``."""
    return os.path.join(engine_client.engine_home(), "sample")


def site_packages(engine_path: str) -> list[str]:
    """The site-packages folders of the venv an engine command lives in."""
    venv = os.path.dirname(os.path.dirname(os.path.abspath(engine_path)))
    found = glob.glob(os.path.join(venv, "lib", "python3*", "site-packages"))
    found += glob.glob(os.path.join(venv, "Lib", "site-packages"))
    return sorted(found)


def shipped_scene(engine_path: str | None) -> str | None:
    """A ``geoboresight_sample/`` folder with the scene's VNIR and SWIR, in the profile or
    beside the engine's library; None when there is none."""
    places = [os.path.join(engine_client.engine_home(), FOLDER_NAME)]
    if engine_path:
        places += [os.path.join(sp, FOLDER_NAME) for sp in site_packages(engine_path)]
    for place in places:
        if all(os.path.isfile(os.path.join(place, f)) for f in ("vnir.hdr", "swir.hdr")):
            return place
    return None


def _first(folder: str, names) -> str | None:
    for name in names:
        path = os.path.join(folder, name)
        if os.path.isfile(path):
            return path
    return None


def _run(engine, name: str, values: dict, feedback, done: str) -> None:
    """Run ``name`` in the engine unless its output ``done`` exists (a cached tour)."""
    if os.path.exists(done):
        return
    if feedback.isCanceled():
        raise engine_client.EngineError("cancelled")
    feedback.setProgressText(f"geoboresight {name}")
    feedback.pushInfo(f"{name}: {values}")
    engine_client.run(engine, name, values, feedback, overwrite=True)


def _flight_geometry(scene: str) -> dict:
    """The DEM's flight geometry from the scene's truth.json (empty when it has none)."""
    import json

    try:
        with open(os.path.join(scene, "truth.json"), encoding="utf-8") as f:
            truth = json.load(f)
    except (OSError, ValueError):
        return {}
    keys = {
        "squint_deg": "squint_deg",
        "flying_height": "flying_height_m",
        "ifov_mrad": "ifov_mrad",
    }
    if not all(truth.get(k) for k in keys.values()):
        return {}
    return {name: truth[key] for name, key in keys.items()}


def prepare(engine, feedback=None, folder: str | None = None) -> dict:
    """Make (or find) the tour's files; {key: path} for :data:`LAYERS`, plus ``"scene"``,
    ``"igm"`` and ``"own_igm"`` (False when the IGM and orthophoto were simulated apart from
    the scene: same preset, not the same ground)."""
    feedback = feedback or QgsProcessingFeedback()
    folder = folder or work_folder()
    os.makedirs(folder, exist_ok=True)
    scene = shipped_scene(engine.path)
    if scene is None:
        scene = os.path.join(folder, "scene")
        _run(
            engine,
            "simulate",
            {**RECIPE, "output": scene},
            feedback,
            os.path.join(scene, "vnir.hdr"),
        )
    igm = _first(scene, ("igm.hdr", "igm.tif"))
    ortho = _first(scene, ("ortho.tif", "orthophoto.tif"))
    own = igm is not None and ortho is not None
    if not own:
        place = os.path.join(folder, "ortho")
        _run(
            engine,
            "simulate-ortho",
            {**ORTHO_RECIPE, "output": place},
            feedback,
            os.path.join(place, "orthophoto.tif"),
        )
        igm, ortho = os.path.join(place, "igm.hdr"), os.path.join(place, "orthophoto.tif")
        feedback.pushInfo(
            "this scene has no IGM or orthophoto of its own: the products are placed with the "
            "IGM of a simulate-ortho line of the same preset"
        )
    raw, mapped = os.path.join(folder, "raw"), os.path.join(folder, "map")
    os.makedirs(raw, exist_ok=True)
    os.makedirs(mapped, exist_ok=True)
    vnir, swir = os.path.join(scene, "vnir.hdr"), os.path.join(scene, "swir.hdr")
    ratio_raw, shadow_raw = os.path.join(raw, "ratio.tif"), os.path.join(raw, "shadow_classes.tif")
    _run(engine, "ratio", {"vnir": vnir, "swir": swir, "output": ratio_raw}, feedback, ratio_raw)
    _run(
        engine,
        "shadow-map",
        {"vnir": vnir, "swir": swir, "output": shadow_raw},
        feedback,
        shadow_raw,
    )
    # The relative DEM with the scene's flight geometry (truth.json: squint, flying height,
    # IFOV of the simulated bench; the sample recipe's large-squint geometry).
    dem_raw = os.path.join(raw, "dem.tif")
    geometry = _flight_geometry(scene)
    sources = [("ratio", ratio_raw), ("shadow", shadow_raw)]
    if geometry:
        _run(
            engine,
            "relative-dem",
            {"vnir": vnir, "swir": swir, "output": dem_raw, **geometry},
            feedback,
            dem_raw,
        )
        sources.append(("dem", dem_raw))
    out = {"scene": scene, "igm": igm, "own_igm": own, "orthophoto": ortho}
    for key, source in sources:
        path = os.path.join(mapped, os.path.basename(source))
        _run(engine, "geolocate", {"input": source, "igm": igm, "output": path}, feedback, path)
        write_style(path)
        out[key] = path
    feedback.setProgress(100)
    return out


def add_layers(files: dict, project=None, canvas=None) -> list:
    """Add the tour's layers (a group "geoboresight sample scene"), the project in the
    orthophoto's CRS, the map on the orthophoto's extent. The layers added."""
    from qgis.core import QgsProject, QgsRasterLayer

    project = project or QgsProject.instance()
    root = project.layerTreeRoot()
    old = root.findGroup("geoboresight sample scene")
    if old is not None:
        project.removeMapLayers([layer.layerId() for layer in old.findLayers()])
        root.removeChildNode(old)
    group = root.insertGroup(0, "geoboresight sample scene")
    layers = []
    for key, name, opacity in LAYERS:
        if key not in files:  # a scene without flight geometry has no DEM
            continue
        layer = QgsRasterLayer(files[key], name, "gdal")
        if not layer.isValid():
            continue
        layer.loadDefaultStyle()  # the .qml beside the product
        layer.setOpacity(opacity)
        project.addMapLayer(layer, False)
        group.insertLayer(0, layer)  # each above the previous
        layers.append(layer)
    if layers and layers[0].crs().isValid():
        project.setCrs(layers[0].crs())
    if canvas is not None and layers:
        canvas.setDestinationCrs(layers[0].crs())
        canvas.setExtent(layers[0].extent())
        canvas.refresh()
    return layers


class SampleSceneTask(QgsTask):
    """:func:`prepare` in the background (a QGIS task: progress in the status bar, cancel
    stops the engine), then ``on_done(task)`` in the main thread."""

    def __init__(self, engine, on_done, folder: str | None = None):
        super().__init__("geoboresight: the sample scene", QgsTask.CanCancel)
        self.engine = engine
        self.on_done = on_done
        self.folder = folder
        self.feedback = QgsProcessingFeedback()
        self.feedback.progressChanged.connect(self.setProgress)
        self.files = None
        self.error = ""

    def run(self):
        try:
            self.files = prepare(self.engine, self.feedback, self.folder)
            return True
        except Exception as exc:  # shown to the user in finished()
            self.error = str(exc)
            return False

    def cancel(self):
        self.feedback.cancel()
        super().cancel()

    def finished(self, ok):
        self.on_done(self)
