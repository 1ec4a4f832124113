"""``rio boresight``: found by rasterio through its plugin entry point, the same commands as the
geoboresight CLI, and the same numbers as the library."""

from __future__ import annotations

import os
import subprocess
import sys
from importlib.metadata import entry_points

import click
import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.rio.main import main_group
from synth import SWIR_WL, TRANSFORM, UTM, VNIR_WL, cube, write_envi

from geoboresight import cli
from geoboresight.algorithms import registry
from geoboresight.io import quiet_georef
from geoboresight.rio import boresight


@pytest.fixture
def pair(tmp_path):
    vnir = write_envi(
        tmp_path / "v.img", cube(len(VNIR_WL), seed=1), VNIR_WL, crs=UTM, transform=TRANSFORM
    )
    swir = write_envi(
        tmp_path / "s.img", cube(len(SWIR_WL), seed=2), SWIR_WL, crs=UTM, transform=TRANSFORM
    )
    return vnir, swir


def _read(path):
    with quiet_georef(), rasterio.open(path) as src:
        return src.read(), src.crs, src.transform


def test_entry_point_is_registered():
    eps = [ep for ep in entry_points(group="rasterio.rio_plugins") if ep.name == "boresight"]
    assert len(eps) == 1
    assert eps[0].load() is boresight


def test_rio_lists_the_plugin():
    result = CliRunner().invoke(main_group, ["--help"])
    assert result.exit_code == 0, result.output
    line = next(ln for ln in result.output.splitlines() if ln.strip().startswith("boresight"))
    assert "†" not in line and "could not load" not in line.lower(), (
        line
    )  # click-plugins' broken mark


def test_same_commands_and_options_as_the_cli():
    ctx_cli = click.Context(cli.main)
    ctx_rio = click.Context(boresight)
    assert boresight.list_commands(ctx_rio) == cli.main.list_commands(ctx_cli)
    assert set(registry()) <= set(boresight.list_commands(ctx_rio))
    for name in registry():
        a = cli.main.get_command(ctx_cli, name)
        b = boresight.get_command(ctx_rio, name)
        opts = [(p.name, tuple(p.opts), p.required, p.default) for p in a.params]
        assert opts == [(p.name, tuple(p.opts), p.required, p.default) for p in b.params], name
        assert a.help == b.help


def test_rio_boresight_ratio_matches_the_library(pair, tmp_path):
    vnir, swir = pair
    out = tmp_path / "rio.tif"
    result = CliRunner().invoke(
        main_group,
        [
            "boresight",
            "ratio",
            "--vnir",
            vnir,
            "--swir",
            swir,
            "--band-mode",
            "edges",
            "-o",
            str(out),
            "-q",
        ],
    )
    assert result.exit_code == 0, result.output
    ref = tmp_path / "lib.tif"
    registry()["ratio"](vnir=vnir, swir=swir, band_mode="edges", output=str(ref))
    got, crs, transform = _read(out)
    want, want_crs, want_transform = _read(ref)
    np.testing.assert_array_equal(got, want)
    assert (crs, transform) == (want_crs, want_transform)
    # and the option really reached the library: edges (last VNIR band) differs from 920 nm
    default = tmp_path / "default.tif"
    registry()["ratio"](vnir=vnir, swir=swir, output=str(default))
    assert not np.array_equal(got, _read(default)[0])


def test_rio_errors_are_messages_not_tracebacks(pair, tmp_path):
    vnir, swir = pair
    out = tmp_path / "r.tif"
    result = CliRunner().invoke(
        main_group,
        [
            "boresight",
            "ratio",
            "--vnir",
            vnir,
            "--swir",
            swir,
            "--swir-nm",
            "9000",
            "-o",
            str(out),
        ],
    )
    assert result.exit_code != 0
    assert "--swir-nm" in result.output  # rio's option, as typed
    assert "Traceback" not in result.output
    assert not out.exists()


def test_rio_executable(pair, tmp_path):
    """The installed `rio` script finds the plugin too (a fresh process, real entry points)."""
    rio = os.path.join(os.path.dirname(sys.executable), "rio")
    if not os.path.exists(rio):
        pytest.skip("no rio script beside this Python")
    vnir, swir = pair
    out = tmp_path / "r.tif"
    run = subprocess.run(
        [rio, "boresight", "ratio", "--vnir", vnir, "--swir", swir, "-o", str(out), "--json", "-q"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    assert out.exists() and '"swir_band"' in run.stdout


def test_former_option_names_are_hidden_aliases(pair, tmp_path):
    """--numerator-nm (0.1) still works for one release, is not in --help, and cannot be given
    beside its new name --swir-nm."""
    vnir, swir = pair
    runner = CliRunner()
    base = ["ratio", "--vnir", vnir, "--swir", swir, "-q", "--json"]
    old = runner.invoke(cli.main, [*base, "--numerator-nm", "1100", "-o", str(tmp_path / "a.tif")])
    new = runner.invoke(cli.main, [*base, "--swir-nm", "1100", "-o", str(tmp_path / "b.tif")])
    assert old.exit_code == 0 and new.exit_code == 0, old.output + new.output
    assert (
        '"swir_wavelength_nm": 1100.0' in old.output
        and '"swir_wavelength_nm": 1100.0' in new.output
    )
    assert "--numerator-nm" not in runner.invoke(cli.main, ["ratio", "--help"]).output
    both = runner.invoke(
        cli.main,
        [*base, "--numerator-nm", "1100", "--swir-nm", "1040", "-o", str(tmp_path / "c.tif")],
    )
    assert both.exit_code != 0 and "not both" in both.output
    assert not (tmp_path / "c.tif").exists()
