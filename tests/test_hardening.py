"""Hardening: the pieces behind "no silent data loss, no silently wrong result, no traceback".

Atomic writes and their litter, folder outputs, wavelength parsing, the one error path of the
command line, the troubleshooting page kept in step with the code, and the checks the
refactor already made (finite numbers, CRS checks in open_cube, unmix's FWHM column).
"""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from hostile import (
    COLS,
    FACE_CASES,
    ROWS,
    cli,
    error_line,
    face_values,
    make_face_inputs,
    make_inputs,
    make_products,
    snapshot,
)
from synth import VNIR_WL, cube, write_envi, write_gtiff

import geoboresight as gb
from geoboresight import errors, io
from geoboresight.algorithms.spec import Number
from geoboresight.cli import main
from geoboresight.errors import InputError, OutputError, ParameterError
from geoboresight.io import wavelengths as wlmod
from geoboresight.io import write as wmod
from geoboresight.operations._guard import translate_error

ROOT = Path(__file__).resolve().parents[1]


# --- atomic writes, temporary names and the sweep -------------------------------------------


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_temporary_names_follow_the_swept_pattern(tmp_path):
    tmp = wmod.temp_name(str(tmp_path / "ratio.tif"))
    name = os.path.basename(tmp)
    assert name.startswith(".ratio.") and name.endswith(".tmp.tif")
    assert wmod._TEMP.match(name)
    assert f".{os.getpid()}-" in name
    assert os.path.dirname(tmp) == str(tmp_path)  # beside the output: same file system


def test_sweep_removes_only_our_litter_whose_writer_is_gone(tmp_path):
    host = wmod._HOST
    dead = _dead_pid()
    names = {
        "dead": f".ratio.{dead}-{host}-ab12cd34.tmp.tif",
        "dead_side": f".ratio.{dead}-{host}-ab12cd34.tmp.tif.aux.xml",
        "alive": f".ratio.{os.getppid()}-{host}-ab12cd35.tmp.tif",
        "mine": f".ratio.{os.getpid()}-{host}-ab12cd36.tmp.tif",
        "other_host": f".ratio.{dead}-{'0000' if host != '0000' else '0001'}-ab12cd37.tmp.tif",
        "old_style_young": ".ratio.x8k2j3_q.tmp.tif",
        "old_style_old": ".stats.p0o9i8u7.tmp.json",
        "user_hidden": ".ratio.tif.notes",
        "user_tmp": "ratio.tmp.tif",
    }
    for n in names.values():
        (tmp_path / n).write_text("x")
    (tmp_path / f".scene.{dead}-{host}-ab12cd38.tmp").mkdir()
    (tmp_path / f".scene.{dead}-{host}-ab12cd38.tmp" / "vnir.img").write_text("x")
    day_old = time.time() - wmod.STALE_AGE_S - 60
    os.utime(tmp_path / names["old_style_old"], (day_old, day_old))
    removed = {os.path.basename(p) for p in wmod.sweep_stale(str(tmp_path))}
    assert removed == {
        names["dead"],
        names["dead_side"],
        names["old_style_old"],
        f".scene.{dead}-{host}-ab12cd38.tmp",
    }
    left = set(os.listdir(tmp_path))
    for key in ("alive", "mine", "other_host", "old_style_young", "user_hidden", "user_tmp"):
        assert names[key] in left
    # A day later even a writer that may be alive elsewhere is given up on.
    later = time.time() + wmod.STALE_AGE_S + 60
    removed = {os.path.basename(p) for p in wmod.sweep_stale(str(tmp_path), now=later)}
    assert names["other_host"] in removed and names["old_style_young"] in removed
    assert names["user_hidden"] in os.listdir(tmp_path)


def test_interrupted_folder_swap_is_undone_by_the_sweep(tmp_path):
    """Killed between moving the old folder aside and renaming the new one in: the sweep puts
    the old folder back rather than deleting the only copy."""
    dead = _dead_pid()
    backup = tmp_path / f".scene.{dead}-{wmod._HOST}-ab12cd34.tmp.old"
    backup.mkdir()
    (backup / "vnir.img").write_text("previous scene")
    wmod.sweep_stale(str(tmp_path))
    assert (tmp_path / "scene" / "vnir.img").read_text() == "previous scene"
    assert not backup.exists()


def test_atomic_output_failure_keeps_the_previous_file_and_leaves_nothing(tmp_path):
    target = tmp_path / "out.json"
    target.write_text("previous")
    with pytest.raises(RuntimeError), wmod.atomic_output(target) as tmp:
        Path(tmp).write_text("half")
        raise RuntimeError("boom")
    assert target.read_text() == "previous"
    assert os.listdir(tmp_path) == ["out.json"]


def test_atomic_output_translates_os_errors_to_the_users_path(tmp_path):
    target = tmp_path / "out.json"

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device", a[0] if a else None)

    with pytest.raises(OutputError) as info, wmod.atomic_output(target) as tmp:
        full(tmp)
    message = str(info.value)
    assert str(target) in message and "full" in message and ".tmp" not in message
    assert os.listdir(tmp_path) == []


def test_atomic_output_refuses_an_empty_result(tmp_path):
    with pytest.raises(OutputError, match="was not written"), wmod.atomic_output(tmp_path / "a"):
        pass


def test_folder_output_is_swapped_never_emptied(tmp_path):
    allowed = ("vnir.img", "vnir.hdr")
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "vnir.img").write_text("old")
    with wmod.atomic_output(folder, folder_files=allowed) as tmp:
        os.makedirs(tmp)
        Path(tmp, "vnir.img").write_text("new")
    assert (folder / "vnir.img").read_text() == "new"
    assert sorted(os.listdir(tmp_path)) == ["scene"]
    # A failure while writing the new folder keeps the old one whole.
    with pytest.raises(RuntimeError), wmod.atomic_output(folder, folder_files=allowed) as tmp:
        os.makedirs(tmp)
        raise RuntimeError("boom")
    assert (folder / "vnir.img").read_text() == "new"
    assert sorted(os.listdir(tmp_path)) == ["scene"]
    # A folder with the user's own files is refused before anything is written.
    (folder / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="notes.txt"):
        with wmod.atomic_output(folder, folder_files=allowed):
            pytest.fail("must not be reached")
    assert (folder / "notes.txt").read_text() == "mine"


def test_simulate_refuses_a_file_or_a_foreign_folder_before_simulating(tmp_path):
    (tmp_path / "plain").write_text("a file")
    with pytest.raises(OutputError, match="not a folder"):
        gb.simulate_file(output=str(tmp_path / "plain"), lines=16, overwrite=True)
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "thesis.docx").write_text("irreplaceable")
    with pytest.raises(OutputError, match="thesis.docx"):
        gb.simulate_file(output=str(tmp_path / "mine"), lines=16, overwrite=True)
    assert (tmp_path / "mine" / "thesis.docx").read_text() == "irreplaceable"
    assert (tmp_path / "plain").read_text() == "a file"


def test_simulate_ortho_overwrites_its_own_folder(tmp_path):
    out = tmp_path / "o"
    gb.simulate_ortho_file(output=str(out), lines=16, ortho_cell=4.0)
    first = snapshot(out)
    gb.simulate_ortho_file(output=str(out), lines=16, ortho_cell=4.0, seed=1, overwrite=True)
    assert set(snapshot(out)) == set(first) and snapshot(out) != first
    assert sorted(os.listdir(tmp_path)) == ["o"]


# --- inputs protected by identity ---------------------------------------------------------


@pytest.mark.parametrize(
    "data, header, output",
    [
        ("scene.bsq", "scene.bsq.hdr", "scene.bsq.hdr"),  # GDAL's other header convention
        ("scene.bsq", "scene.hdr", "scene.hdr"),
        ("scene.img", "scene.hdr", "scene.img"),
    ],
)
def test_output_may_not_be_a_file_gdal_reads_with_an_input(tmp_path, data, header, output):
    write_envi(tmp_path / "w.img", cube(3, 5, 4), [500, 600, 700])
    os.replace(tmp_path / "w.img", tmp_path / data)
    os.replace(tmp_path / "w.hdr", tmp_path / header)
    with rasterio.open(tmp_path / data) as src:  # GDAL finds the header under that name
        assert src.count == 3
    with pytest.raises(OutputError):
        io.check_output_path(tmp_path / output, [str(tmp_path / data)], overwrite=True)


def test_gdal_family_covers_gdals_own_file_list(tmp_path):
    """Every file GDAL lists for an input (data, header, .aux.xml, world file) is protected."""
    path = write_gtiff(tmp_path / "dsm.tif", np.ones((1, 4, 5), "float32"), wavelengths=[500.0])
    (tmp_path / "dsm.tfw").write_text("1\n0\n0\n-1\n0\n0\n")
    with rasterio.open(path) as src:
        files = src.files
    assert len(files) >= 2
    family = wmod.gdal_family(path)
    assert {os.path.abspath(f) for f in files} <= family
    envi = write_envi(tmp_path / "c.img", cube(2, 3, 3), [500, 600])
    with rasterio.open(envi) as src:
        assert {os.path.abspath(f) for f in src.files} <= wmod.gdal_family(envi)


def test_an_unrelated_output_beside_an_input_is_allowed(tmp_path):
    """Identity, not a name prefix: vnir.tif beside the input vnir.img is a new file."""
    v = write_envi(tmp_path / "vnir.img", cube(2, 3, 3), [500, 600])
    io.check_output_path(tmp_path / "vnir.tif", [v])
    io.check_output_path(tmp_path / "vnir_ratio.img", [v])


# --- validation at open -------------------------------------------------------------------


@pytest.mark.parametrize(
    "text, bad",
    [("{400, 5l0, 600}", "5l0"), ("400,n/a,600", "n/a"), ("400 abc", "abc"), ("1,inf", "inf")],
)
def test_wavelength_lists_are_parsed_strictly(text, bad):
    with pytest.raises(InputError, match=repr(bad).replace("/", ".")) as info:
        wlmod.parse_list(text, "scene.hdr: ENVI header 'wavelength'")
    assert "scene.hdr" in str(info.value)


def test_wavelength_lists_in_every_accepted_syntax():
    for text in (
        "{400.1, 402.3}",
        "400.1,402.3",
        "400.1 402.3",
        " { 400.1 ,\n 402.3 } ",
        "4.001e2;402.3",
    ):
        np.testing.assert_allclose(wlmod.parse_list(text), [400.1, 402.3])


@pytest.mark.parametrize(
    "units, values, scale",
    [
        ("Nanometers", [400, 2500], 1.0),
        ("Micrometers", [0.4, 2.5], 1000.0),
        ("microns", [0.4, 2.5], 1000.0),
        ("", [0.4, 2.5], 1000.0),  # unambiguous: only micrometres fit
        (None, [400, 2500], 1.0),  # unambiguous: only nanometres fit
    ],
)
def test_units_are_inferred_only_when_unambiguous(units, values, scale):
    assert wlmod.unit_scale(units, np.array(values, float), "f.img") == scale


@pytest.mark.parametrize(
    "units, values", [(None, [1, 12]), ("", [10, 250]), ("Index", [1, 12]), ("parsecs", [400, 900])]
)
def test_ambiguous_or_unknown_units_name_the_file(units, values):
    with pytest.raises(InputError, match="f.img"):
        wlmod.unit_scale(units, np.array(values, float), "f.img")


def test_micrometre_files_still_read_in_nanometres(tmp_path):
    path = write_envi(tmp_path / "um.img", cube(len(VNIR_WL), 5, 4), VNIR_WL, units="Micrometers")
    with io.open_raster(path) as src:
        wl, _ = io.read_wavelengths(src)
    np.testing.assert_allclose(wl, VNIR_WL, rtol=1e-6)


def test_truncated_raw_file_is_refused_at_open_not_read_as_zeros(tmp_path):
    path = write_envi(tmp_path / "v.img", cube(3, 10, 8), [500, 600, 700])
    data = Path(path).read_bytes()
    Path(path).write_bytes(data[:-16])
    with rasterio.open(path) as src:  # GDAL alone opens it and reads zeros at the end
        assert (src.read(3)[-1, -8:] == 0).all()
    with pytest.raises(InputError, match="truncated"), io.open_raster(path):
        pass


def test_open_cube_and_open_dual_refuse_different_crs(tmp_path):
    """Done in the refactor (Grid.require_same): checked for open_cube (rx, svdd, unmix)."""
    d = make_inputs(tmp_path)
    with pytest.raises(InputError, match="EPSG:32637"):
        io.open_cube([str(d / "vg.img"), str(d / "sg37.img")])
    with pytest.raises(InputError, match="EPSG:32637"):
        io.open_dual(str(d / "vg.img"), str(d / "sg37.img"))


def test_number_parameters_refuse_nan_and_inf():
    p = Number(name="x", description="x", default=1.0, minimum=0.0, maximum=10.0)
    for bad in ("nan", float("nan"), "inf", float("-inf")):
        with pytest.raises(ParameterError, match="'x'.*finite"):
            p.coerce(bad)


def test_operations_refuse_nan_from_python_too(tmp_path):
    """Scripts bypass the spec's checks: the operation layer refuses NaN itself."""
    d = make_inputs(tmp_path / "in")
    with pytest.raises(ParameterError, match="'tolerance_nm'.*finite"):
        gb.ratio_file(
            str(d / "v.img"),
            str(d / "s.img"),
            output=str(tmp_path / "r.tif"),
            bands=gb.BandChoice(tolerance_nm=float("nan")),  # inside a group's value too
        )
    assert not (tmp_path / "r.tif").exists()


def test_unmix_does_not_take_the_fwhm_column_as_a_material(tmp_path):
    d = make_inputs(tmp_path / "in")
    out = tmp_path / "ab.tif"
    result = cli(
        [
            "unmix",
            "--vnir",
            str(d / "v.img"),
            "--swir",
            str(d / "s.img"),
            "--endmembers",
            str(d / "em.csv"),
            "-o",
            str(out),
        ]
    )
    assert result.exit_code == 0, result.output
    with rasterio.open(out) as src:
        names = [n for n in src.descriptions if n]
    assert not any("fwhm" in n.lower() for n in names), names
    assert any("grass" in n for n in names) and any("soil" in n for n in names)


# --- the one error path -------------------------------------------------------------------


def test_os_errors_escaping_an_operation_name_the_file():
    exc = OSError(errno.EIO, "Input/output error", "/data/v.img")
    err = translate_error(exc, ["/data/v.img"], ["/out/r.tif"])
    assert isinstance(err, InputError) and "/data/v.img" in str(err)
    err = translate_error(OSError(errno.ENOSPC, "No space left", "/out/r.tif"), [], ["/out/r.tif"])
    assert isinstance(err, OutputError) and "full" in str(err)
    err = translate_error(MemoryError(), [], [], ["vnir", "block_rows", "output"])
    assert isinstance(err, errors.ResourceError) and "lower block_rows" in str(err)
    assert "sample_size" not in str(err)
    err = translate_error(MemoryError(), [], [], ["input", "igm", "resolution", "output"])
    assert "coarser resolution" in str(err) and "block_rows" not in str(err)
    err = translate_error(MemoryError(), [], [], ["input", "output"])
    assert "block_rows" not in str(err) and "memory" in str(err)


def test_a_memory_refusal_names_only_the_operations_own_parameters(tmp_path, monkeypatch):
    """geolocate has neither block_rows nor sample_size: its refusal names its resolution."""
    from geoboresight import geolocate_file
    from geoboresight.io import georef as gio

    def no_memory(*args, **kwargs):
        raise MemoryError()

    monkeypatch.setattr(gio, "warp_geoloc", no_memory)
    from hostile import UTM36, make_inputs

    d = make_inputs(tmp_path / "in")
    with pytest.raises(errors.ResourceError) as info:
        geolocate_file(d / "ratio.tif", d / "igm.tif", igm_crs=UTM36, output=tmp_path / "o.tif")
    assert "resolution" in str(info.value) and "block_rows" not in str(info.value)
    assert not (tmp_path / "o.tif").exists()


def test_unexpected_errors_are_one_line_with_exit_70_and_debug_shows_the_traceback(
    tmp_path, monkeypatch
):
    import geoboresight.cli as cli_module

    def broken(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(cli_module, "execute", broken)
    d = make_inputs(tmp_path)
    args = [
        "ratio",
        "--vnir",
        str(d / "v.img"),
        "--swir",
        str(d / "s.img"),
        "-o",
        str(tmp_path / "r.tif"),
    ]
    result = cli(args)
    assert result.exit_code == 70
    line = error_line(result)
    assert "ZeroDivisionError" in line and "--debug" in line
    result = cli([*args, "--debug"])
    assert isinstance(result.exception, ZeroDivisionError)  # raised: click prints the traceback
    from click.testing import CliRunner

    result = CliRunner().invoke(cli_module.main, ["--debug", *args])
    assert isinstance(result.exception, ZeroDivisionError)


def test_user_errors_print_one_line_and_debug_shows_the_traceback(tmp_path):
    args = ["ratio", "--vnir", str(tmp_path / "none.img"), "-o", str(tmp_path / "r.tif")]
    line = error_line(cli(args))
    assert "none.img" in line
    result = cli([*args, "--debug"])
    assert isinstance(result.exception, InputError)


def test_a_real_process_prints_no_traceback(tmp_path):
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "geoboresight.cli",
            "ratio",
            "--vnir",
            str(tmp_path / "x.img"),
            "-o",
            str(tmp_path / "r.tif"),
            "--tolerance-nm",
            "nan",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        "Error: --tolerance-nm: expected a finite number, got nan"
    ]


# --- report ---------------------------------------------------------------------------------


def test_report_never_touches_a_folder_named_like_its_work_folder(tmp_path, monkeypatch):
    import geoboresight.report.page as report

    d = make_inputs(tmp_path / "in")
    out = tmp_path / "r.html"
    user = tmp_path / "r.html.work"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    seen = {}

    def fake_build(values, work, progress):
        seen["work"] = work
        Path(work, "ratio.tif").write_text("product")
        return "<html></html>"

    monkeypatch.setattr(report, "build_report", fake_build)
    gb.report_file(str(d / "v.img"), str(d / "s.img"), output=str(out))
    assert (user / "notes.txt").read_text() == "mine"
    assert seen["work"] != str(user) and wmod._TEMP.match(os.path.basename(seen["work"]))
    assert sorted(os.listdir(tmp_path)) == ["in", "r.html", "r.html.work"]


def test_report_fails_when_its_primary_input_is_unreadable(tmp_path):
    d = make_inputs(tmp_path / "in")
    before = snapshot(tmp_path)
    result = cli(["report", "--vnir", str(d / "em.csv"), "-o", str(tmp_path / "r.html")])
    assert result.exit_code == 1
    assert "em.csv" in error_line(result)
    assert snapshot(tmp_path) == before


# --- docs/troubleshooting.md ----------------------------------------------------------------


def test_troubleshooting_lists_every_message_of_the_code():
    text = (ROOT / "docs" / "troubleshooting.md").read_text(encoding="utf-8")
    begin = text.index(errors.CATALOGUE_BEGIN)
    end = text.index(errors.CATALOGUE_END) + len(errors.CATALOGUE_END)
    assert text[begin:end] + "\n" == errors.catalogue_markdown(), (
        "docs/troubleshooting.md is out of date: run "
        "python -m geoboresight.errors --update docs/troubleshooting.md"
    )


def test_troubleshooting_explains_every_error_class():
    text = (ROOT / "docs" / "troubleshooting.md").read_text(encoding="utf-8")
    for cls in errors.error_classes():
        assert f"\n### {cls.__name__}\n" in text, cls.__name__
    used = {cls for _, _, cls, _ in errors.message_catalogue()}
    assert used <= {c.__name__ for c in errors.error_classes()}


def test_every_message_is_one_line():
    catalogue = errors.message_catalogue()
    assert len(catalogue) > 150
    for module, func, _cls, template in catalogue:
        assert "\n" not in template, (module, func, template)


def test_batch_with_a_garbled_jobs_file_is_one_line(tmp_path):
    jobs = tmp_path / "jobs.json"
    jobs.write_text("[{not json")
    from click.testing import CliRunner

    from geoboresight.cli import main

    result = CliRunner().invoke(main, ["batch", "ratio", str(jobs)])
    assert result.exit_code == 1
    assert error_line(result) == f"Error: jobs file {jobs} is not valid JSON " + (
        "(Expecting property name enclosed in double quotes: line 1 column 3 (char 2))"
    )


def test_the_demo_never_deletes_a_folder_it_did_not_write(tmp_path):
    """`make demo OUT=folder` on a folder of the user's: refused, the user's files intact,
    even when the scene is missing; its own earlier output is replaced."""
    from click.testing import CliRunner

    from geoboresight import demo

    user = tmp_path / "mine"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    for args in (["--out", str(user)], ["--out", str(user), "--scene", str(tmp_path / "none")]):
        r = CliRunner().invoke(demo.main, args)
        assert r.exit_code == 1
        assert "nothing was deleted" in r.output or "no vnir.hdr" in r.output
        assert (user / "notes.txt").read_text() == "mine"
    own = tmp_path / "own"
    demo.prepare_folder(own)
    (own / "ratio.tif").write_text("old product")
    demo.prepare_folder(own)
    assert sorted(p.name for p in own.iterdir()) == [demo.MARKER]


# --- warnings about a result go into the result, not Python's warnings ----------------------


def test_low_detectability_is_a_result_warning_not_a_python_warning(tmp_path):
    """A low d′ was a Python UserWarning: the command line printed the library's source file
    and line under the log. It is in the result's warnings now (shown by every face)."""
    import warnings

    from geoboresight.algorithms import registry

    d = make_inputs(tmp_path / "in")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        res = registry()["svdd"](
            vnir=str(d / "v.img"),
            swir=str(d / "s.img"),
            output=str(tmp_path / "svdd.tif"),
            coregister=False,
        )
    assert res["dprime_low"]  # random cubes: no target stands out
    assert any("d′" in w and "below 3" in w for w in res["warnings"])


# --- Every raster input through the product readers; the hostile cases on the command line ---


@pytest.fixture(scope="module")
def products(tmp_path_factory):
    return make_products(tmp_path_factory.mktemp("products"))


@pytest.mark.parametrize("kind", ["specim", "hyspex", "enmap", "prisma"])
def test_stats_reads_a_products_image_lines_its_bands_and_units(products, kind, tmp_path):
    """As ``ratio --vnir PRODUCT`` reads it: the image lines only (a Specim capture's dark
    frames, frame counter and zero pixel out), N = its valid pixels, the band by its number
    or by its wavelength, and the product's units; against the arrays the fixture wrote."""
    import json

    p = products[kind]
    band = 5  # a good band of every kind (PRISMA's first three VNIR slots are unused)
    out = tmp_path / "s.json"
    r = cli(["stats", "-i", p.path, "--band", str(band), "-o", str(out)])
    assert r.exit_code == 0, r.output
    got = json.loads(out.read_text())
    truth = p.image[band - 1][p.valid[band - 1]]
    assert got["n"] == truth.size
    assert got["mean"] == pytest.approx(truth.mean(), rel=1e-6)
    assert got["units"].startswith(p.units)
    assert got["band_wavelength_nm"] == pytest.approx(p.wavelengths[band - 1], abs=1e-3)
    if kind == "specim":  # band 1: the counter column and the zero pixel are masked
        cli(["stats", "-i", p.path, "-o", str(out), "--overwrite"])
        assert json.loads(out.read_text())["n"] == ROWS * (COLS - 2)
    r = cli(
        ["stats", "-i", p.path, "--band-nm", f"{p.wavelengths[band - 1] + 0.4:.3f}"]
        + ["-o", str(out), "--overwrite"]
    )
    assert r.exit_code == 0, r.output
    assert json.loads(out.read_text())["band"] == band
    r = cli(["stats", "-i", p.path, "--band-nm", "2590", "-o", str(out), "--overwrite"])
    line = error_line(r)
    assert "--band-nm" in line and "2590" in line and os.path.basename(p.path) in line


def test_a_product_given_from_python_as_an_open_dataset_or_a_dual_sensor(products, tmp_path):
    """rasterio's convention: an open dataset where a path goes gives the same outputs (read
    through its name: a Specim capture still without its dark frames); a DualSensor from
    open_dual reads as its product's VNIR then SWIR bands."""
    import json

    p = products["specim"]
    by_path = gb.stats_file(p.path, output=str(tmp_path / "a.json"), band=2)
    with rasterio.open(p.path) as src:
        by_dataset = gb.stats_file(src, output=str(tmp_path / "b.json"), band=2)
    assert by_dataset["n"] == by_path["n"] == ROWS * COLS
    assert json.loads((tmp_path / "a.json").read_text()) | {"input": ""} == json.loads(
        (tmp_path / "b.json").read_text()
    ) | {"input": ""}
    e = products["enmap"]
    dual = gb.open_dual(e.path)
    k = len(dual.vnir.bands) + 3  # a SWIR band
    a = gb.stats_file(dual, output=str(tmp_path / "c.json"), band=k)
    b = gb.stats_file(e.path, output=str(tmp_path / "d.json"), band=k)
    assert a["n"] == b["n"] == int(e.valid[k - 1].sum()) and a["mean"] == b["mean"]


def test_open_rasterio_datasets_give_what_their_paths_give(tmp_path):
    """A rasterio script passing open datasets (a file, an in-memory dataset) to the ratio,
    stats and ROC gets the outputs of one passing their paths."""
    from rasterio.io import MemoryFile

    d = make_inputs(tmp_path / "in")
    gb.ratio_file(str(d / "v.img"), str(d / "s.img"), output=str(tmp_path / "p.tif"))
    with rasterio.open(d / "v.img") as v, rasterio.open(d / "s.img") as s:
        gb.ratio_file(v, s, output=str(tmp_path / "q.tif"))
        a, b = gb.open_dual(v, s), gb.open_dual(str(d / "v.img"), str(d / "s.img"))
        assert (a.files, a.grid, a.ratio_bands()) == (b.files, b.grid, b.ratio_bands())
    with rasterio.open(tmp_path / "p.tif") as a, rasterio.open(tmp_path / "q.tif") as b:
        np.testing.assert_array_equal(a.read(), b.read())
    with MemoryFile((d / "ratio.tif").read_bytes()) as mem, mem.open() as src:
        in_memory = gb.stats_file(src, output=str(tmp_path / "m.json"))
    assert in_memory == {
        **gb.stats_file(str(d / "ratio.tif"), output=str(tmp_path / "n.json")),
        "output": str(tmp_path / "m.json"),
    }
    with rasterio.open(d / "score.tif") as s1, rasterio.open(d / "target.tif") as t:
        by_dataset = gb.roc_file([s1], t, output=str(tmp_path / "r1.json"))
    by_path = gb.roc_file(
        [str(d / "score.tif")], str(d / "target.tif"), output=str(tmp_path / "r2.json")
    )
    assert {k: v for k, v in by_dataset.items() if k != "output"} == {
        k: v for k, v in by_path.items() if k != "output"
    }


@pytest.fixture(scope="module")
def face_inputs(tmp_path_factory):
    return make_face_inputs(tmp_path_factory.mktemp("faces") / "in")


@pytest.mark.parametrize("case", FACE_CASES, ids=lambda c: c.id)
def test_the_hostile_cases_on_the_command_line(case, face_inputs, tmp_path):
    """Each case of hostile.FACE_CASES as the command line meets it: the exit status, one
    error line naming the file and the option (--vnir-dark), the warning of an accepted
    repeat, no raw library warning, inputs untouched."""
    before = snapshot(face_inputs)
    argv = [case.op]
    for k, v in face_values(case, face_inputs, tmp_path).items():
        argv += [errors.cli_option(k), str(v)]
    result = CliRunner().invoke(main, argv, catch_exceptions=True)
    assert result.exit_code == case.code, result.output
    assert "Warning:" not in result.stderr and "warnings.warn" not in result.stderr
    if case.code == 0:
        assert case.warning in result.output
    else:
        line = result.stderr.strip().splitlines()[-1]
        for expect in case.expect:
            assert expect in line, (expect, line)
        if case.param:
            assert errors.cli_option(case.param) in line, line
    assert snapshot(face_inputs) == before


def test_a_band_a_product_marks_bad_is_refused_naming_the_good_ones(products, tmp_path):
    """PRISMA's unused slots (centre 0, flag 0) hold no image: refused by number, never
    chosen by wavelength."""
    p = products["prisma"]
    r = cli(["stats", "-i", p.path, "--band", "2", "-o", str(tmp_path / "s.json")])
    line = error_line(r)
    assert "--band" in line and "marked bad" in line and "4–93" in line
