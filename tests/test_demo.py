"""``make demo``'s steps on the sample scene: every application the scene's inputs allow, the
products put on the map by the scene's IGM, commands that paste as printed."""

from __future__ import annotations

import os
import pathlib
import shlex

import pytest

from geoboresight.demo import SAMPLE, _command_line, steps

pytestmark = pytest.mark.skipif(
    not (SAMPLE / "igm.tif").exists(), reason="no sample scene with its navigation"
)


def test_demo_geolocates_its_products_and_gives_the_report_everything(tmp_path):
    todo = steps(SAMPLE, tmp_path)
    names = [n for n, _ in todo]
    geolocated = {os.path.basename(v["input"]) for n, v in todo if n == "geolocate" and "igm" in v}
    assert {"boresight_ratio.tif", "shadow_map_classes.tif", "relative_dem.tif", "rx.tif"} <= (
        geolocated
    )
    # Each product is made before it is geolocated.
    for i, (name, values) in enumerate(todo):
        if name == "geolocate":
            assert any(values["input"] in v.values() for _, v in todo[:i])
    report = dict(todo)["report"]
    for key in ("shadow_truth", "target_truth", "cloud_mask", "squint_deg", "flying_height"):
        assert report.get(key), key
    assert report["ifov_mrad"] == 1.0
    assert names[-1] == "report" and "shadow-map" in names


def test_printed_commands_paste_as_printed(tmp_path):
    name, values = steps(SAMPLE, tmp_path / "a b")[0]
    line = _command_line(name, values)
    words = shlex.split(line)
    assert words[:2] == ["geoboresight", name] and words[-1] == "--overwrite"
    assert str(pathlib.Path(tmp_path / "a b" / "boresight_ratio.tif")) in words


def test_the_demos_sun_shadow_is_the_scenes_shadow(tmp_path):
    # The simulator's azimuth is from the flight direction and its raw image is the ground
    # mirrored (rows along the flight from row 0, columns to the right of the track): the demo
    # must give sun-shadow 180° minus it. Checked against the scene's own truth shadow
    # fraction, which the simulator draws by its own ray casting, not sun-shadow's.
    import rasterio

    from geoboresight.algorithms import execute, registry

    values = dict(steps(SAMPLE, tmp_path))["sun-shadow"]
    with rasterio.open(SAMPLE / "truth_shadow_fraction.tif") as src:
        truth = src.read(1) >= 0.5

    def iou(azimuth):
        out = str(tmp_path / f"s{azimuth:.1f}.tif")
        execute(
            registry()["sun-shadow"],
            {**values, "sun_azimuth": azimuth, "output": out, "hillshade": None},
        )
        with rasterio.open(out) as src:
            cast = src.read(1) >= 0.5
        return (cast & truth).sum() / (cast | truth).sum()

    given = values["sun_azimuth"]
    assert iou(given) > 0.7
    # The azimuth as the simulator states it, unconverted, casts the shadows elsewhere.
    import json

    stated = json.loads((SAMPLE / "truth.json").read_text())["sun"]["azimuth_deg"]
    assert given != stated and iou(stated) < 0.4
