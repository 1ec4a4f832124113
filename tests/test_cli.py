"""The click CLI generated from the specs: help, list, runs, and errors without tracebacks."""

import json

import numpy as np
import rasterio
from click.testing import CliRunner
from synth import SWIR_WL, VNIR_WL, cube, write_envi

from geoboresight.algorithms import registry
from geoboresight.cli import main


def test_list_shows_every_spec_grouped():
    res = CliRunner().invoke(main, ["list"])
    assert res.exit_code == 0
    for alg in registry().values():
        assert alg.name in res.output and alg.group in res.output


def test_every_spec_has_help_with_its_parameters():
    for alg in registry().values():
        res = CliRunner().invoke(main, [alg.name, "--help"])
        assert res.exit_code == 0, alg.name
        for p in alg.params:
            flag = "--" + p.name.replace("_", "-")
            assert flag in res.output, (alg.name, flag)


def test_ratio_then_stats_from_the_command_line(tmp_path):
    vn, sw = cube(len(VNIR_WL), seed=11), cube(len(SWIR_WL), seed=12)
    v = write_envi(tmp_path / "v.img", vn, VNIR_WL)
    s = write_envi(tmp_path / "s.img", sw, SWIR_WL)
    r = CliRunner().invoke(
        main, ["ratio", "--vnir", v, "--swir", s, "-o", str(tmp_path / "r.tif"), "--json"]
    )
    assert r.exit_code == 0, r.output
    with rasterio.open(tmp_path / "r.tif") as src:
        assert src.count == 1
    r = CliRunner().invoke(
        main,
        [
            "stats",
            "-i",
            str(tmp_path / "r.tif"),
            "-o",
            str(tmp_path / "s.json"),
            "--html",
            str(tmp_path / "s.html"),
            "-q",
        ],
    )
    assert r.exit_code == 0, r.output
    assert json.loads((tmp_path / "s.json").read_text())["n"] > 0


def test_errors_are_one_line_messages(tmp_path):
    r = CliRunner().invoke(
        main, ["ratio", "--vnir", str(tmp_path / "missing.img"), "-o", str(tmp_path / "r.tif")]
    )
    assert r.exit_code == 1
    assert "Error: merged cube" in r.output and "does not exist" in r.output
    assert "Traceback" not in r.output
    r = CliRunner().invoke(
        main, ["stats", "-i", "x.tif", "-o", str(tmp_path / "s.json"), "--bins", "1"]
    )
    # The CLI names the option as typed (--bins), not the Python parameter.
    assert r.exit_code == 1 and "--bins: 1 is below the minimum 2" in r.output
    # A missing required option is click's usage error (exit 2), naming it.
    r = CliRunner().invoke(main, ["ratio", "--vnir", "a.img"])
    assert r.exit_code == 2 and "--output" in r.output


def test_existing_output_and_overwrite(tmp_path):
    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL)), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL)), SWIR_WL)
    out = tmp_path / "r.tif"
    args = ["ratio", "--vnir", v, "--swir", s, "-o", str(out), "-q"]
    assert CliRunner().invoke(main, args).exit_code == 0
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 1 and "--overwrite" in r.output
    assert CliRunner().invoke(main, [*args, "--overwrite"]).exit_code == 0
    assert not np.isnan(rasterio.open(out).read(1)).all()


def test_help_keeps_bullets_as_paragraphs():
    """A spec's bulleted help prints one bullet a line (click would join them into one)."""
    from click.testing import CliRunner

    from geoboresight.cli import main

    out = CliRunner().invoke(main, ["shadow-map", "--help"], terminal_width=100).output
    bullets = [line for line in out.splitlines() if line.lstrip().startswith("•")]
    assert len(bullets) >= 4, out
