"""``make demo``: the main job on the bundled sample scene, step by step, into one folder.

Run ``python -m geoboresight.demo --out out``. Each step is an ordinary algorithm spec run
through :func:`geoboresight.algorithms.execute`, exactly as the CLI or QGIS would run it, so
the demo doubles as a worked example (the equivalent ``geoboresight`` commands are printed).
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import time
from pathlib import Path

import click

from .algorithms import execute, registry
from .errors import GeoboresightError
from .progress import Progress
from .simulate.shadow import raw_grid_azimuth


def _grid_azimuth(sun: dict) -> float:
    """The scene's sun azimuth as sun-shadow takes it on the scene's grid."""
    if sun.get("azimuth_reference") == "flight direction":
        return raw_grid_azimuth(sun["azimuth_deg"])
    return float(sun["azimuth_deg"])


SAMPLE = Path(__file__).resolve().parents[1] / "sample_data" / "scene"


def _scene(out: Path, scene: str | None) -> Path:
    if scene:
        return Path(scene)
    if (SAMPLE / "vnir.hdr").exists():
        return SAMPLE
    # Not a source checkout (or no sample yet): simulate a small scene with the same recipe.
    target = out / "scene"
    if not (target / "vnir.hdr").exists():
        click.echo(f"no bundled sample scene found; simulating one into {target}")
        execute(
            registry()["simulate"],
            # the recipe of sample_data/README.md
            {
                "preset": "mixed",
                "lines": 192,
                "seed": 4,
                "geometry": "large-squint",
                "clouds": 1,
                "navigation": True,
                "capture": True,
                "output": str(target),
            },
            overwrite=True,
        )
    return target


def steps(scene: Path, out: Path) -> list[tuple[str, dict]]:
    """The demo's steps: (algorithm name, values). Steps whose algorithm is absent are skipped.

    Flight parameters (squint, flying height, IFOV, sun) are read from the scene's truth.json,
    as a user would take them from the flight log; truth rasters serve only for validation
    steps (fraction model fit, ROC). With the scene's navigation (``igm.tif``, as a
    processing chain gives it), the ratio, shadow map, DEM and anomaly products are put on
    the map (``geolocate --igm``: the IGM's CRS, the orthophoto's).
    """
    truth = (
        json.loads((scene / "truth.json").read_text()) if (scene / "truth.json").exists() else {}
    )
    s = _Scene(scene, out, truth)
    todo = [*_ratio_and_shadow(s), *_dem(s), *_anomaly(s)]
    return [
        *todo,
        *_on_the_map(s, todo),
        *_from_navigation(s),
        *_radiance(s),
        ("report", _report(s)),
    ]


class _Scene:
    """The demo's scene: its files (the truths only where they exist), its truth.json and
    the output folder."""

    def __init__(self, scene: Path, out: Path, truth: dict):
        self.scene, self.out, self.truth = scene, out, truth
        self.v, self.s = str(scene / "vnir.hdr"), str(scene / "swir.hdr")
        self.ratio = self.o("boresight_ratio.tif")
        cloud = scene / "truth_cloud_mask.tif"
        self.cloud_arg = {"cloud_mask": str(cloud)} if cloud.exists() else {}

    def o(self, name: str) -> str:
        """An output of the demo."""
        return str(self.out / name)

    def truth_file(self, name: str) -> str | None:
        """A truth raster of the scene, None when the scene has none."""
        path = self.scene / name
        return str(path) if path.exists() else None


def _ratio_and_shadow(s: _Scene) -> list[tuple[str, dict]]:
    v, o, ratio = s.v, s.o, s.ratio
    todo: list[tuple[str, dict]] = [
        ("ratio", {"vnir": v, "swir": s.s, "output": ratio}),
        (
            "stats",
            {
                "input": ratio,
                "output": o("ratio_stats.json"),
                "html": o("ratio_stats.html"),
                "histogram": o("ratio_histogram.png"),
            },
        ),
        (
            "shadow-map",
            {
                "vnir": v,
                "swir": s.s,
                "output": o("shadow_map_classes.tif"),
                "mask": o("shadow_map_mask.tif"),
            },
        ),
        (
            "shadow-classes",
            {"ratio": ratio, "output": o("shadow_classes.tif"), "mask": o("shadow_mask.tif")},
        ),
        (
            "shadow-cluster",
            {
                "ratio": ratio,
                "vnir": v,
                "output": o("shadow_cluster.tif"),
                "plot": o("shadow_cluster.png"),
            },
        ),
        (
            "shadow-polygons",
            {"classes_raster": o("shadow_classes.tif"), "output": o("shadow_classes.gpkg")},
        ),
    ]
    if s.truth_file("truth_shadow_fraction.tif"):
        todo.append(
            (
                "shadow-fraction-fit",
                {
                    "ratio": ratio,
                    "truth": s.truth_file("truth_shadow_fraction.tif"),
                    "report": o("shadow_fraction_fit.json"),
                    "plot": o("shadow_fraction_fit.png"),
                },
            )
        )
    if "sun" in s.truth and s.truth_file("truth_dsm.tif"):
        todo.append(
            (
                "sun-shadow",
                {
                    "dsm": s.truth_file("truth_dsm.tif"),
                    "sun_zenith": s.truth["sun"]["zenith_deg"],
                    "sun_azimuth": _grid_azimuth(s.truth["sun"]),
                    "cell_size": s.truth.get("gsd_m", 1.5),
                    "output": o("sun_shadow_fraction.tif"),
                    "hillshade": o("hillshade.tif"),
                },
            )
        )
    return todo


def _radiance(s: _Scene) -> list[tuple[str, dict]]:
    """The ratio in radiance beside the ratio in DN, on a raw AisaFENIX-like capture of both
    detectors with its calibration (``simulate --capture``): the scene's own, else a short one
    simulated with the sample's recipe; and the capture's radiance cube."""
    cap, cal = s.scene / "capture.hdr", s.scene / "capture_cal.cal"
    todo: list[tuple[str, dict]] = []
    if not cap.exists():
        folder = s.out / "capture_scene"
        todo.append(
            (
                "simulate",
                {"preset": "mixed", "lines": 64, "seed": 4, "capture": True, "output": str(folder)},
            )
        )
        cap, cal = folder / "capture.hdr", folder / "capture_cal.cal"
    return [
        *todo,
        ("radiance", {"input": str(cap), "calibration": str(cal), "output": s.o("radiance.img")}),
        ("ratio", {"vnir": str(cap), "output": s.o("capture_ratio_dn.tif")}),
        (
            "ratio",
            {
                "vnir": str(cap),
                "vnir_calibration": str(cal),
                "output": s.o("capture_ratio_radiance.tif"),
            },
        ),
    ]


def _flight(truth: dict) -> dict:
    """The flight geometry of the scene's truth.json, as the relative DEM takes it."""
    return {
        "squint_deg": truth["squint_deg"],
        "flying_height": truth["flying_height_m"],
        "ifov_mrad": truth["ifov_mrad"],
    }


def _dem(s: _Scene) -> list[tuple[str, dict]]:
    o = s.o
    todo = [
        (
            "boresight-offset",
            {
                "vnir": s.v,
                "swir": s.s,
                **s.cloud_arg,
                "output": o("boresight_offset.json"),
                "plot": o("boresight_offset.png"),
            },
        )
    ]
    if "squint_deg" in s.truth:
        todo += [
            (
                "relative-dem",
                {
                    "vnir": s.v,
                    "swir": s.s,
                    **s.cloud_arg,
                    **_flight(s.truth),
                    "output": o("relative_dem.tif"),
                    "variance": o("relative_dem_variance.tif"),
                    "report": o("relative_dem.json"),
                },
            ),
            (
                "view-3d",
                {
                    "dem": o("relative_dem.tif"),
                    "vnir": s.v,
                    "swir": s.s,
                    "output": o("relative_dem_3d.png"),
                },
            ),
        ]
    return todo


def _anomaly(s: _Scene) -> list[tuple[str, dict]]:
    o = s.o
    todo = [
        ("rx", {"vnir": s.v, "swir": s.s, "output": o("rx.tif")}),
        ("boresight-indicator", {"ratio": s.ratio, "output": o("boresight_indicator.tif")}),
    ]
    if s.truth_file("truth_target_abundance.tif"):
        todo.append(
            (
                "roc",
                {
                    "scores": [o("rx.tif"), o("boresight_indicator.tif")],
                    "names": "RX,boresight",
                    "truth": s.truth_file("truth_target_abundance.tif"),
                    "output": o("roc.png"),
                    "csv": o("roc.csv"),
                },
            )
        )
    return todo


#: The products the demo puts on the map when the scene has its navigation (igm.tif).
MAPPED = ("boresight_ratio", "shadow_map_classes", "relative_dem", "rx", "boresight_indicator")


def _on_the_map(s: _Scene, todo: list[tuple[str, dict]]) -> list[tuple[str, dict]]:
    igm = s.truth_file("igm.tif")
    if not igm:
        return []
    made = [p for p in MAPPED if any(s.o(f"{p}.tif") in vals.values() for _, vals in todo)]
    return [
        (
            "geolocate",
            {"input": s.o(f"{p}.tif"), "igm": igm, "output": s.o(f"{p}_map.tif")},
        )
        for p in made
    ]


def _from_navigation(s: _Scene) -> list[tuple[str, dict]]:
    """With the aircraft's files (``flight/``: SBET, line times, sensor models, DEM and the
    boresight angles of ``flight.json``), each sensor's IGM by direct georeferencing, and the
    boresight ratio put on the map with the VNIR's."""
    flight = s.scene / "flight"
    if not (flight / "flight.json").is_file():
        return []
    known = json.loads((flight / "flight.json").read_text())
    todo = []
    for sensor, image in (("vnir", s.v), ("swir", s.s)):
        todo.append(
            (
                "direct-georeference",
                {
                    "input": image,
                    "navigation": str(flight / "flight.out"),
                    "line_times": str(flight / "line_times.txt"),
                    "sensor_model": str(flight / f"{sensor}_model.csv"),
                    "boresight": tuple(known["boresight_deg"][sensor]),
                    "lever_arm": tuple(known["lever_arm_m"][sensor]),
                    "dem": str(flight / "dem.tif"),
                    "output": s.o(f"{sensor}_igm.tif"),
                },
            )
        )
    todo.append(
        (
            "geolocate",
            {
                "input": s.ratio,
                "igm": s.o("vnir_igm.tif"),
                "output": s.o("boresight_ratio_from_navigation_map.tif"),
            },
        )
    )
    return todo


def _report(s: _Scene) -> dict:
    report = {"vnir": s.v, "swir": s.s, **s.cloud_arg}
    if s.truth_file("truth_shadow_fraction.tif"):
        report["shadow_truth"] = s.truth_file("truth_shadow_fraction.tif")
    if s.truth_file("truth_target_abundance.tif"):
        report["target_truth"] = s.truth_file("truth_target_abundance.tif")
    if "squint_deg" in s.truth:
        report.update(_flight(s.truth))
    return {**report, "output": s.o("report.html")}


def _command_line(name: str, values: dict) -> str:
    """The step as a ``geoboresight`` command that pastes into a shell as printed (it replaces
    the demo's own outputs, as the demo does: ``--overwrite``)."""
    import shlex

    parts = ["geoboresight", name]
    for k, val in values.items():
        if isinstance(val, bool):
            parts.append(f"--{k.replace('_', '-')}" if val else f"--no-{k.replace('_', '-')}")
        elif isinstance(val, list):
            for item in val:
                parts += [f"--{k.replace('_', '-')}", str(item)]
        elif isinstance(val, tuple):  # three numbers after one option (--boresight R P H)
            parts += [f"--{k.replace('_', '-')}", *(f"{v:g}" for v in val)]
        else:
            parts += [f"--{k.replace('_', '-')}", str(val)]
    parts.append("--overwrite")
    return " ".join(shlex.quote(p) for p in parts)


#: The file that marks a folder as the demo's own output: only such a folder is replaced.
MARKER = ".geoboresight-demo"


def prepare_folder(out_dir: Path) -> None:
    """An empty ``out_dir`` for the demo. A folder the demo wrote before (it holds
    :data:`MARKER`) is replaced; any other folder that is not empty is refused, as every
    operation refuses to overwrite: the demo never deletes what it did not write."""
    if out_dir.exists() and not out_dir.is_dir():
        raise click.ClickException(f"--out {out_dir} is a file: give a folder")
    if out_dir.is_dir() and any(out_dir.iterdir()):
        if not (out_dir / MARKER).is_file():
            raise click.ClickException(
                f"--out {out_dir} is not empty and is not an earlier demo output: give a new "
                "or empty folder (nothing was deleted)"
            )
        shutil.rmtree(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / MARKER).write_text("written by python -m geoboresight.demo\n")


@click.command()
@click.option(
    "--out",
    default="out",
    show_default=True,
    help="Folder for the demo's outputs: new, empty, or an earlier demo output (replaced).",
)
@click.option(
    "--scene",
    default=None,
    help="Scene folder (vnir.hdr, swir.hdr, truth_*); default: sample_data/.",
)
def main(out: str, scene: str | None) -> None:
    """Run the boresight products on the sample scene and list what was written."""
    out_dir = Path(out)
    if scene and not (Path(scene) / "vnir.hdr").exists():
        raise click.ClickException(
            f"scene {scene} has no vnir.hdr: give a folder written by 'geoboresight simulate'"
        )
    prepare_folder(out_dir)
    scene_dir = _scene(out_dir, scene)
    click.echo(f"scene: {scene_dir}")
    algs = registry()
    t_start, ran = time.perf_counter(), 0
    for name, values in steps(scene_dir, out_dir):
        if name not in algs:
            click.echo(f"-- {name}: not available in this version, skipped")
            continue
        click.echo(f"\n$ {_command_line(name, values)}")
        t0 = time.perf_counter()
        with click.progressbar(length=1000, label=algs[name].display_name, file=sys.stderr) as bar:
            done = [0]

            def cb(f, _m, bar=bar, done=done):
                step = int(f * 1000) - done[0]
                if step > 0:
                    bar.update(step)
                    done[0] += step

            try:
                result = execute(algs[name], values, progress=Progress(cb), overwrite=True)
            except GeoboresightError as exc:
                raise click.ClickException(f"{name}: {exc}") from None
        ran += 1
        for k, val in result.items():
            click.echo(f"   {k}: {val}")
        click.echo(f"   ({time.perf_counter() - t0:.1f} s)")
    click.echo(f"\n{ran} operations in {time.perf_counter() - t_start:.0f} s")
    click.echo(f"\nOutputs in {os.path.abspath(out_dir)}:")
    for p in sorted(out_dir.rglob("*")):
        if p.is_file() and not p.name.startswith("."):
            click.echo(f"  {p.relative_to(out_dir)}  ({p.stat().st_size / 1024:.0f} KiB)")


if __name__ == "__main__":  # pragma: no cover
    main()
