"""The bad-input catalogue: a hostile user's inputs, parameters and output paths for every
operation, through the command line.

Each case asserts the exit status, one error line naming the file, band or parameter at fault
(no traceback), that no file was left behind, and that every input (and any previous output)
is byte-identical afterwards. Generic cases are generated from the registry, so a new
operation joins the catalogue (and must be given valid arguments in ``BASE`` below).
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
import rasterio
from hostile import (
    COLS,
    GRID,
    ROWS,
    UTM36,
    cli,
    error_line,
    make_inputs,
    read_only_folder,
    snapshot,
)
from rasterio.transform import Affine
from synth import write_gtiff

from geoboresight.algorithms import registry
from geoboresight.errors import cli_option

#: The catalogue's inputs (hostile.make_inputs) for the file names of the specs' examples.
FIXTURES = {
    "vnir.hdr": "v.img",
    "swir.hdr": "s.img",
    "ratio.tif": "ratio.tif",
    "truth_shadow_fraction.tif": "truth.tif",
    "shadow_classes.tif": "classes.tif",
    "dsm.tif": "dem_g.tif",
    "dem.tif": "dem.tif",
    "rx.tif": "score.tif",
    "truth_target_abundance.tif": "target.tif",
    "endmembers.csv": "em.csv",
    "ortho.tif": "ratio_g.tif",
    "igm.tif": "igm.tif",
    "gcps.csv": "gcps.csv",
    "ratio_map.tif": "ratio_g.tif",
    "shadow_fraction.tif": "truth.tif",
    "capture.hdr": "specim_capture.hdr",
    "calibration.cal": "specim_calibration.cal",
    "line_vnir.hdr": "v.img",
    "line.out": "flight.out",
    "line_times.txt": "line_times.txt",
    "vnir_model.csv": "vnir_model.csv",
}
#: Where the catalogue's inputs differ from the example's for one operation.
OVERRIDES = {
    ("reproject-to", "reference"): "truth37.tif",
    ("geolocate", "igm_crs"): UTM36,
    # the sample flight's DEM, under the flight (the catalogue's own DEM has no CRS)
    ("direct-georeference", "dem"): "flight_dem.tif",
    ("boresight-calibrate", "dem"): "flight_dem.tif",
    ("boresight-calibrate", "gcps"): "flight_gcps.csv",
}


def _base(alg) -> dict[str, str]:
    """Valid arguments of ``alg`` on the catalogue's inputs, derived from its spec's example
    (an operation is registered by its spec alone): outputs become out.<extension>."""
    base = {}
    for name, value in alg.example.items():
        p = alg.param(name)
        if p.is_output:
            base[name] = f"out.{p.extension}" if p.extension else "outdir"
        elif isinstance(value, list | tuple):  # three numbers: words after one option
            base[name] = " ".join(f"{v:g}" for v in value)
        else:
            base[name] = OVERRIDES.get((alg.name, name), FIXTURES.get(value, value))
    return base


#: Valid arguments of every operation on the inputs of hostile.make_inputs ("{d}" is the
#: case's folder). Outputs are named out.<extension>.
BASE: dict[str, dict[str, str]] = {name: _base(alg) for name, alg in registry().items()}

_FILE_KINDS = ("raster", "multiraster", "file")


@dataclass
class Case:
    id: str
    op: str
    args: dict[str, str]  # values over BASE[op]; "{d}" = the case folder, "{ro}" read-only
    expect: tuple[str, ...]  # substrings of the error line (formatted like args)
    setup: object = None  # callable(d: Path) run before the snapshot
    code: int = 1
    needs_ro: bool = False
    extra: list[str] = field(default_factory=list)  # extra command-line words
    check: object = None  # callable(d: Path) on the outputs of a case that should work (code 0)
    marks: tuple = ()  # pytest marks (a known failure owned elsewhere: xfail, strict)


def _argv(op: str, args: dict[str, str], d: Path, ro: Path | None, extra) -> list[str]:
    argv = [op]
    for name, value in args.items():
        if value is None:
            continue
        value = value.format(d=d, ro=ro)
        alg = registry()[op]
        p = alg.param(name)
        if p.kind in _FILE_KINDS or p.is_output:
            value = value if value.startswith("/") else str(d / value)
        words = value.split() if p.kind == "numbers" else [value]
        argv += ["--" + name.replace("_", "-"), *words]
    return argv + list(extra)


def _path(op, name, value, d) -> str:
    return value if value.startswith("/") else str(d / value)


def _generic_cases() -> list[Case]:
    cases = []
    for op, alg in registry().items():
        if op not in BASE:
            continue  # test_the_catalogue_covers_every_operation names it
        base = BASE[op]
        floats = [p for p in alg.params if p.kind in ("number", "wavelength") and not p.integer]
        for p, bad in zip(floats[:1] + floats[-1:], ("nan", "inf"), strict=False):
            cases.append(
                Case(f"{op}-{bad}-{p.name}", op, {p.name: bad}, (cli_option(p.name), "finite"))
            )
        if len(floats) > 2:
            p = floats[len(floats) // 2]
            cases.append(Case(f"{op}--inf-{p.name}", op, {p.name: "-inf"}, (cli_option(p.name),)))
        ins = [n for n in base if alg.param(n).kind in _FILE_KINDS]
        for name in ins:
            cases.append(
                Case(
                    f"{op}-missing-{name}",
                    op,
                    {name: "nowhere/missing.tif"},
                    ("nowhere/missing.tif", "does not exist"),
                )
            )
        out = next(p for p in alg.outputs if p.name in base)
        ext = f".{out.extension}" if out.extension else ""
        if ins:
            first = base[ins[0]]
            cases.append(Case(f"{op}-output-is-input", op, {out.name: first}, ("input",)))
            stem = first.rsplit(".", 1)[0]
            cases.append(
                Case(
                    f"{op}-output-is-header-other-convention",
                    op,
                    {out.name: first + ".hdr"},
                    # A raster output is refused first for not being a .tif.
                    (".hdr", ".tif" if out.kind == "raster_out" else "sidecar"),
                )
            )
            if first.endswith(".img"):
                cases.append(
                    Case(f"{op}-output-is-header", op, {out.name: stem + ".hdr"}, (".hdr",))
                )

        def pre_existing(d, name=f"out{ext}", ext=ext):
            p = d / name
            if ext:
                p.write_bytes(b"previous output")
            else:
                p.mkdir()
                (p / "vnir.img").write_bytes(b"previous scene")

        cases.append(
            Case(
                f"{op}-output-exists",
                op,
                {out.name: f"out{ext}"},
                ("already exists",),
                setup=pre_existing,
            )
        )
        cases.append(
            Case(
                f"{op}-output-folder-missing",
                op,
                {out.name: f"nofolder/out{ext}"},
                ("nofolder", "does not exist"),
            )
        )
        cases.append(
            Case(
                f"{op}-output-read-only-folder",
                op,
                {out.name: f"{{ro}}/out{ext}"},
                ("not writable",),
                needs_ro=True,
            )
        )
    return cases


def _write(name: str, text: str):
    return lambda d: (d / name).write_text(text)


def _edit_header(name: str, old: str, new: str):
    def setup(d):
        p = d / name
        text = p.read_text()
        assert old in text, (old, text[:300])
        p.write_text(text.replace(old, new, 1))

    return setup


def _resize(name: str, delta: int):
    def setup(d):
        p = d / name
        data = p.read_bytes()
        p.write_bytes(data[:delta] if delta < 0 else data + b"\0" * delta)

    return setup


def _wavelength_header(name: str, values: str, units: str | None):
    def setup(d):
        p = d / name
        lines = [ln for ln in p.read_text().splitlines()]
        out, skip = [], False
        for ln in lines:
            low = ln.lower()
            if low.startswith("wavelength units") or low.startswith("wavelength_units"):
                continue
            if low.startswith("wavelength") and "=" in ln:
                skip = "}" not in ln
                continue
            if skip:
                skip = "}" not in ln
                continue
            out.append(ln)
        out.append(f"wavelength = {{{values}}}")
        if units is not None:
            out.append(f"wavelength units = {units}")
        p.write_text("\n".join(out) + "\n")
        aux = d / (name.rsplit(".", 1)[0] + ".img.aux.xml")
        if aux.exists():
            aux.unlink()  # GDAL's PAM copy of the old list would win otherwise

    return setup


def _specific_cases() -> list[Case]:
    v12 = ", ".join(f"{w:.1f}" for w in range(400, 970, 50))  # 12 values
    c = []
    # Truncated and padded raw files: GDAL would read zeros, or a wrong layout.
    for op in ("ratio", "rx", "shadow-cluster", "disparity", "dark-pixel-shadow", "unmix"):
        c.append(
            Case(
                f"{op}-truncated-vnir", op, {}, ("v.img", "truncated"), setup=_resize("v.img", -60)
            )
        )
    for op in ("ratio", "svdd", "boresight-offset"):
        c.append(
            Case(f"{op}-padded-swir", op, {}, ("s.img", "longer"), setup=_resize("s.img", 512))
        )
    c.append(
        Case(
            "ratio-header-offset-too-big",
            "ratio",
            {},
            ("s.img", "truncated"),
            setup=_edit_header("s.hdr", "header offset = 0", "header offset = 64"),
        )
    )
    c.append(
        Case(
            "ratio-header-lines-too-many",
            "ratio",
            {},
            ("v.img",),
            setup=_edit_header("v.hdr", "lines   = 40", "lines   = 41"),
        )
    )
    # A calibration that does not fit the capture: refused naming both values or the file.
    for cid, setup, expect in (
        (
            "sensorid",
            _edit_header("specim_calibration.hdr", "sensorid = 110001", "sensorid = 100022"),
            ("100022", "110001"),
        ),
        (
            "binning",
            _edit_header("specim_calibration.hdr", "binning = {1, 1}", "binning = {2, 1}"),
            ("binning 2",),
        ),
        (
            "wavelength",
            _edit_header("specim_calibration.hdr", "400.0000,", "440.0000,"),
            ("band 1", "400.00 nm"),
        ),
        (
            "truncated",
            _resize("specim_calibration.cal", -40),
            ("specim_calibration.cal", "truncated"),
        ),
        (
            "no-tint",
            _edit_header("specim_capture.hdr", "tint = 10.0", "shutter = 10.0"),
            ("specim_capture.hdr", "'tint'"),
        ),
    ):
        c.append(Case(f"radiance-calibration-{cid}", "radiance", {}, expect, setup=setup))
    # Garbled and partial wavelength metadata: the token and the file are named.
    for token in ("5l0", "n/a", "abc", "nan"):
        vals = v12.replace("500.0", token)
        c.append(
            Case(
                f"ratio-vnir-wavelength-{token}",
                "ratio",
                {},
                ("v.img", repr(token)),
                setup=_wavelength_header("v.hdr", vals, "Nanometers"),
            )
        )
    c.append(
        Case(
            "rx-vnir-wavelength-garbled",
            "rx",
            {},
            ("v.img", "'5l0'"),
            setup=_wavelength_header("v.hdr", v12.replace("500.0", "5l0"), "Nanometers"),
        )
    )
    c.append(
        Case(
            "ratio-vnir-wavelength-count",
            "ratio",
            {},
            ("v.img", "11 wavelengths"),
            setup=_wavelength_header("v.hdr", v12.rsplit(",", 1)[0], "Nanometers"),
        )
    )
    c.append(
        Case(
            "ratio-vnir-unknown-units",
            "ratio",
            {},
            ("v.img", "Furlongs"),
            setup=_wavelength_header("v.hdr", v12, "Furlongs"),
        )
    )
    c.append(
        Case(
            "ratio-vnir-index-units",
            "ratio",
            {},
            ("v.img", "Index"),
            setup=_wavelength_header("v.hdr", ", ".join(str(i) for i in range(1, 13)), "Index"),
        )
    )
    c.append(
        Case(
            "ratio-vnir-ambiguous-no-units",
            "ratio",
            {},
            ("v.img", "no unit"),
            setup=_wavelength_header("v.hdr", ", ".join(str(i) for i in range(1, 13)), None),
        )
    )
    c.append(
        Case(
            "unmix-swir-ambiguous-no-units",
            "unmix",
            {},
            ("s.img", "no unit"),
            setup=_wavelength_header("s.hdr", ", ".join(str(i * 40) for i in range(1, 51)), None),
        )
    )
    # Wavelengths typed by the user.
    c.append(
        Case(
            "ratio-user-wavelengths-garbled",
            "ratio",
            {"vnir_wavelengths": v12.replace("500.0", "5l0")},
            ("'5l0'", "v.img"),
        )
    )
    c.append(
        Case(
            "ratio-user-wavelengths-nan",
            "ratio",
            {"vnir_wavelengths": v12.replace("500.0", "nan")},
            ("'nan'",),
        )
    )
    c.append(
        Case(
            "ratio-user-wavelengths-count",
            "ratio",
            {"vnir_wavelengths": "400,500"},
            ("v.img", "12 bands", "2 wavelengths"),
        )
    )
    # Numbers hidden in text parameters.
    c.append(Case("stats-percentiles-nan", "stats", {"percentiles": "5,nan"}, ("percentiles",)))
    c.append(Case("stats-percentiles-garbled", "stats", {"percentiles": "5,9o"}, ("percentiles",)))
    c.append(
        Case(
            "dark-pixel-bands-garbled", "dark-pixel-shadow", {"bands_nm": "450,5x0"}, ("bands_nm",)
        )
    )
    c.append(Case("rx-include-garbled", "rx", {"include_nm": "400-9x0"}, ("include_nm",)))
    c.append(
        Case(
            "simulate-boresight-nan",
            "simulate",
            {"boresight_vnir_deg": "nan,0,0"},
            ("boresight_vnir_deg",),
        )
    )
    c.append(Case("stats-band-beyond", "stats", {"band": "7"}, ("--band", "ratio.tif")))
    # CRS and grid mismatches in every operation that takes two rasters.
    pairs = {
        "ratio": ("vnir", "vg.img", "swir"),
        "rx": ("vnir", "vg.img", "swir"),
        "svdd": ("vnir", "vg.img", "swir"),
        "unmix": ("vnir", "vg.img", "swir"),
        "boresight-offset": ("vnir", "vg.img", "swir"),
        "coregister": ("vnir", "vg.img", "swir"),
        "disparity": ("vnir", "vg.img", "swir"),
        "relative-dem": ("vnir", "vg.img", "swir"),
        "view-3d": ("vnir", "vg.img", "swir"),
        "report": ("vnir", "vg.img", "swir"),
        "shadow-map": ("vnir", "vg.img", "swir"),
    }
    for op, (a, a_val, b) in pairs.items():
        base = {a: a_val}
        if op == "view-3d":
            base["dem"] = "dem_g.tif"
        c.append(
            Case(f"{op}-crs-mismatch", op, {**base, b: "sg37.img"}, ("sg37.img", "EPSG:32637"))
        )
        c.append(
            Case(
                f"{op}-grid-shifted",
                op,
                {**base, b: "sg_shift.img"},
                ("sg_shift.img", "geotransform"),
            )
        )
        c.append(
            Case(
                f"{op}-grid-size",
                op,
                {a: "v.img", b: "s_small.img"},
                ("s_small.img", "same pixel grid"),
            )
        )
    second = {
        "shadow-cluster": ({"ratio": "ratio_g.tif", "vnir": "vg37.img"}, "vg37.img"),
        "shadow-fraction-fit": ({"ratio": "ratio_g.tif", "truth": "truth37.tif"}, "truth37.tif"),
        "roc": ({"scores": "score_g.tif", "truth": "target37.tif"}, "target37.tif"),
        "view-3d": ({"dem": "dem37.tif", "vnir": "vg.img", "swir": "sg.img"}, "dem37.tif"),
        "boresight-offset": (
            {"vnir": "vg.img", "swir": "sg.img", "cloud_mask": "mask37.tif"},
            "mask37.tif",
        ),
        "relative-dem": (
            {"vnir": "vg.img", "swir": "sg.img", "cloud_mask": "mask37.tif"},
            "mask37.tif",
        ),
        "report": (
            {"vnir": "vg.img", "swir": "sg.img", "shadow_truth": "truth37.tif"},
            "truth37.tif",
        ),
    }
    for op, (args, bad) in second.items():
        c.append(Case(f"{op}-second-raster-crs", op, args, (bad, "EPSG:32637")))
    small = {
        "shadow-cluster": {"vnir": "s_small.img"},
        "shadow-fraction-fit": {"truth": "truth_small.tif"},
        "roc": {"truth": "target_small.tif"},
        "view-3d": {"dem": "dem_small.tif"},
        "shadow-fraction-fit-mask": {"mask": "mask_small.tif"},
        "disparity": {"cloud_mask": "mask_small.tif"},
        "coregister": {"cloud_mask": "mask_small.tif"},
        "report": {"target_truth": "target_small.tif"},
    }
    for key, args in small.items():
        op = key.removesuffix("-mask")
        c.append(Case(f"{key}-second-raster-size", op, args, (next(iter(args.values())),)))
    # Sidecars and links of inputs as outputs: refused by identity, not by name.
    c.append(Case("ratio-output-aux-xml", "ratio", {"output": "v.img.aux.xml"}, ("aux.xml",)))

    def symlink_to_input(d):
        (d / "link.tif").symlink_to(d / "ratio.tif")

    def hardlink_to_input(d):
        (d / "hard.tif").hardlink_to(d / "ratio.tif")

    c.append(
        Case(
            "boresight-indicator-output-symlink-to-input",
            "boresight-indicator",
            {"output": "link.tif"},
            ("link.tif", "input"),
            setup=symlink_to_input,
            extra=["--overwrite"],
        )
    )
    c.append(
        Case(
            "boresight-indicator-output-hardlink-to-input",
            "boresight-indicator",
            {"output": "hard.tif"},
            ("hard.tif", "input"),
            setup=hardlink_to_input,
            extra=["--overwrite"],
        )
    )
    # The default method with the cube given is 'physical', which does not read the ratio.
    c.append(
        Case(
            "boresight-indicator-ratio-with-the-cube",
            "boresight-indicator",
            {"ratio": "ratio.tif", "vnir": "v.img", "swir": "s.img"},
            ("'ratio'", "not used by method 'physical'", "'eq3'"),
        )
    )
    c.append(
        Case(
            "unmix-output-is-endmembers",
            "unmix",
            {"output": "em.csv"},
            ("em.csv",),
            extra=["--overwrite"],
        )
    )
    c.append(
        Case(
            "roc-csv-is-truth",
            "roc",
            {"csv": "target.tif"},
            ("target.tif", "input"),
            extra=["--overwrite"],
        )
    )
    c.append(Case("stats-two-outputs-same", "stats", {"html": "out.json"}, ("out.json",)))

    # Folder outputs.
    def user_folder(d):
        (d / "mine").mkdir()
        (d / "mine" / "notes.txt").write_text("the user's own notes")
        (d / "mine" / "vnir.img").write_bytes(b"an old scene")

    c.append(
        Case(
            "simulate-overwrite-user-folder",
            "simulate",
            {"output": "mine"},
            ("mine", "notes.txt", "never emptied"),
            setup=user_folder,
            extra=["--overwrite"],
        )
    )
    c.append(
        Case(
            "simulate-ortho-overwrite-user-folder",
            "simulate-ortho",
            {"output": "mine"},
            ("mine", "notes.txt", "never emptied"),
            setup=user_folder,
            extra=["--overwrite"],
        )
    )
    c.append(
        Case(
            "report-products-holds-input",
            "report",
            {"products": "."},
            ("folder holding the input",),
            extra=["--overwrite"],
        )
    )

    def file_not_folder(d):
        (d / "plain").write_text("a file")

    c.append(
        Case(
            "simulate-output-is-a-file",
            "simulate",
            {"output": "plain"},
            ("plain", "is a file"),
            setup=file_not_folder,
            extra=["--overwrite"],
            code=2,  # click's own check of a folder option: a usage error
        )
    )
    # Damaged tables and metadata.
    c.append(
        Case(
            "unmix-endmembers-garbled",
            "unmix",
            {"endmembers": "bad.csv"},
            ("bad.csv",),
            setup=_write("bad.csv", "wavelength_nm,grass\n400,0.1\n41o,0.2\n420,0.3\n"),
        )
    )
    c.append(
        Case(
            "unmix-endmembers-no-material",
            "unmix",
            {"endmembers": "bad.csv"},
            ("bad.csv",),
            setup=_write("bad.csv", "wavelength_nm,fwhm_nm\n400,8\n410,8\n420,8\n"),
        )
    )
    c.append(
        Case(
            "shadow-classes-table-garbled",
            "shadow-classes",
            {"classes": "bad.csv"},
            ("bad.csv",),
            setup=_write("bad.csv", "this is, not a\nclass table\n"),
        )
    )
    c.append(
        Case(
            "shadow-fraction-apply-model-garbled",
            "shadow-fraction-apply",
            {"model": "bad.json"},
            ("bad.json",),
            setup=_write("bad.json", "{not json"),
        )
    )
    c.append(Case("ratio-vnir-not-a-raster", "ratio", {"vnir": "em.csv"}, ("em.csv",)))
    c.append(
        Case(
            "ratio-header-not-envi",
            "ratio",
            {},
            ("v.img",),
            setup=_write("v.hdr", "this is not an ENVI header\n"),
        )
    )
    c.append(Case("report-primary-unreadable", "report", {"vnir": "em.csv"}, ("em.csv",)))
    c.append(
        Case(
            "report-primary-truncated",
            "report",
            {},
            ("v.img", "truncated"),
            setup=_resize("v.img", -100),
        )
    )
    c.append(
        Case("ratio-edges-merged-no-seam", "ratio", {"swir": None, "seam_nm": "2500"}, ("seam",))
    )
    c.append(
        Case("ratio-wavelength-out-of-tolerance", "ratio", {"vnir_nm": "350"}, ("v.img", "350 nm"))
    )
    return c


# --- The georeferencing group, writer options and shadow-map -----------------------------
_UTM_GCP = f"# CRS: {UTM36}\npixel,line,x,y\n"


def _gcp_rows(rows) -> str:
    return _UTM_GCP + "".join(f"{p},{q},{x},{y}\n" for p, q, x, y in rows)


def _igm(name: str, edit):
    """An IGM like hostile's igm.tif (x, y of every pixel centre) changed by ``edit``."""

    def setup(d):
        cols, lines = np.meshgrid(np.arange(COLS) + 0.5, np.arange(ROWS) + 0.5)
        xy = np.stack([700000.0 + 2.0 * cols, 3500000.0 - 2.0 * lines])
        write_gtiff(d / name, edit(xy).astype("float64"))

    return setup


def _nan_rows(xy):
    xy = xy.copy()
    xy[:, 10:14] = np.nan
    return xy


def _lonlat(xy):
    return np.stack([34.0 + (xy[0] - 700000.0) * 1e-5, 31.6 - (3500000.0 - xy[1]) * 1e-5])


def _cube_filled(value_of):
    """v.img and s.img with every sample set to ``value_of(dtype)`` (the size kept)."""

    def setup(d):
        for name in ("v.img", "s.img"):
            hdr = (d / name.replace(".img", ".hdr")).read_text()
            code = int(hdr.split("data type")[1].split("=")[1].split()[0])
            dtype = {1: "uint8", 2: "int16", 4: "float32", 12: "uint16"}[code]
            raw = np.fromfile(d / name, dtype=dtype)
            raw[:] = value_of(np.dtype(dtype))
            raw.tofile(d / name)

    return setup


def _saturated(dtype):
    return np.iinfo(dtype).max if dtype.kind in "iu" else 1e30


def _vector_output_ok(features: int, null: int):
    def check(d):
        import json

        doc = json.loads((d / "out.geojson").read_text())
        assert len(doc["features"]) == features
        assert sum(f["geometry"] is None for f in doc["features"]) == null

    return check


def _raster_output_ok(d):
    import rasterio

    with rasterio.open(d / "out.tif") as src:
        assert src.crs is not None and src.read(1, masked=True).count() > 0


def _georef_cases() -> list[Case]:
    c = []
    long_crs = "EPSG:" + "9" * 200_000
    # geolocate: IGMs of another product, with holes, in other units, or not given.
    c.append(
        Case(
            "geolocate-igm-other-size",
            "geolocate",
            {"igm": "igm_narrow.tif"},
            ("igm_narrow.tif", f"is 20 × {ROWS}", "must belong"),
            setup=_igm("igm_narrow.tif", lambda xy: xy[:, :, :20]),
        )
    )
    c.append(
        Case(
            "geolocate-igm-nan-rows-masked",
            "geolocate",
            {"igm": "igm_nan.tif"},
            (),
            setup=_igm("igm_nan.tif", _nan_rows),
            code=0,
            check=_raster_output_ok,
        )
    )
    c.append(
        Case(
            "geolocate-igm-all-nan",
            "geolocate",
            {"igm": "igm_void.tif"},
            ("igm_void.tif",),
            setup=_igm("igm_void.tif", lambda xy: np.full_like(xy, np.nan)),
        )
    )
    c.append(
        Case(
            "geolocate-igm-lonlat-read-as-utm",
            "geolocate",
            {"igm": "igm_ll.tif"},
            ("igm_ll.tif", "EPSG:32636", "--igm-crs"),
            setup=_igm("igm_ll.tif", _lonlat),
        )
    )
    c.append(
        Case(
            "geolocate-igm-easting-and-northing-swapped",
            "geolocate",
            {"igm": "igm_yx.tif"},
            ("igm_yx.tif", "x and y swapped", "easting first"),
            setup=_igm("igm_yx.tif", lambda xy: xy[::-1]),
        )
    )
    c.append(
        Case(
            "geolocate-glt-float-nan-holes-work",
            "geolocate",
            {"igm": None, "igm_crs": None, "glt": "glt_nan.tif"},
            (),
            setup=_glt_filled("glt_nan.tif", np.nan, "float32"),
            code=0,
            check=_raster_output_ok,
        )
    )
    c.append(
        Case(
            "geolocate-glt-undeclared-fill",
            "geolocate",
            {"igm": None, "igm_crs": None, "glt": "glt_fill.tif"},
            ("glt_fill.tif", "hold -9999", "nodata"),
            setup=_glt_filled("glt_fill.tif", -9999, "int32"),
        )
    )
    for op in ("geolocate", "georeference"):
        c.append(
            Case(
                f"{op}-output-crs-of-another-continent",
                op,
                {"crs": "EPSG:32611"},  # UTM 11N (California) for a line in UTM 36N
                ("'crs'", "EPSG:32611", "far outside", "product's area"),
            )
        )
    c.append(
        Case(
            "geolocate-igm-offset-1e20",
            "geolocate",
            {"igm": "igm_far.tif"},
            ("igm_far.tif", "1e+20", "outside any CRS's range"),
            setup=_igm("igm_far.tif", lambda xy: xy + 1e20),
        )
    )
    c.append(
        Case(
            "geolocate-igm-crs-without-igm",
            "geolocate",
            {"igm": None},
            ("--igm-crs", "needs --igm"),
        )
    )
    c.append(
        Case(
            "geolocate-crs-200000-characters",
            "geolocate",
            {"crs": long_crs},
            ("'crs'", "200,005 characters"),
        )
    )
    # georeference: GCP sets no transform can be fitted to.
    corners = [(0.5, 0.5), (29.5, 0.5), (29.5, 39.5), (0.5, 39.5)]

    def xy(p, q):
        return (p, q, 700000 + 2 * p, 3500000 - 2 * q)

    rows = [xy(*pq) for pq in corners]
    for method in ("polynomial", "tps"):
        # An exact copy: kept by least squares, left out of the spline, saying so (a warning).
        c.append(
            Case(
                f"georeference-repeated-gcp-{method}",
                "georeference",
                {"gcps": "rep.csv", "method": method},
                (),
                setup=_write("rep.csv", _gcp_rows([rows[0], rows[1], rows[1], *rows[2:]])),
                code=0,
            )
        )
    c.append(
        Case(
            "georeference-repeated-position-other-map-point",
            "georeference",
            {"gcps": "rep.csv", "method": "tps"},
            ("rep.csv", "GCPs 1 and 5", "different map points"),
            setup=_write("rep.csv", _gcp_rows([*rows, (0.5, 0.5, 700100, 3499000)])),
        )
    )
    c.append(
        Case(
            "georeference-collinear-gcps",
            "georeference",
            {"gcps": "line.csv"},
            ("line.csv", "one line in the image"),
            setup=_write("line.csv", _gcp_rows([xy(k, k) for k in (1.5, 10.5, 20.5, 29.5)])),
        )
    )
    same = [(p, q, 700001, 3499999) for p, q in [*corners, (15, 20), (5, 30)]]
    for method in ("polynomial", "tps"):
        c.append(
            Case(
                f"georeference-all-same-map-point-{method}",
                "georeference",
                {"gcps": "same.csv", "method": method},
                ("same.csv", "the 6 GCPs share one map point (700001, 3499999)"),
                setup=_write("same.csv", _gcp_rows(same)),
            )
        )
    c.append(
        Case(
            "georeference-coincident-map-points",
            "georeference",
            {"gcps": "two.csv"},
            ("two.csv", "GCPs 2 and 5", "share the map point"),
            setup=_write("two.csv", _gcp_rows([*rows, (15, 20, rows[1][2], rows[1][3])])),
        )
    )
    c.append(
        Case(
            "georeference-map-points-on-a-line",
            "georeference",
            {"gcps": "mline.csv"},
            ("mline.csv", "map points", "one line"),
            setup=_write(
                "mline.csv",
                _gcp_rows([(p, q, 700000 + p + q, 3500000 + 2 * (p + q)) for p, q in corners]),
            ),
        )
    )
    c.append(
        Case(
            "georeference-fewer-gcps-than-the-order",
            "georeference",
            {"order": "2"},
            ("gcps.csv", "5 GCP(s)", "order 2 needs at least 6"),
        )
    )
    points = f"#CRS: {UTM36}\nmapX,mapY,sourceX,sourceY,enable,dX,dY,residual\n" + "".join(
        f"{x},{y},{p},{-q},0,0,0,0\n" for p, q, x, y in rows
    )
    c.append(
        Case(
            "georeference-points-all-disabled",
            "georeference",
            {"gcps": "off.points"},
            ("off.points", "all 4 GCPs are disabled"),
            setup=_write("off.points", points),
        )
    )
    c.append(
        Case(
            "georeference-gcp-crs-200000-characters",
            "georeference",
            {"gcp_crs": long_crs},
            ("'gcp_crs'", "200,005 characters"),
        )
    )
    # auto-georeference: a rough placement nowhere near the reference.
    c.append(
        Case(
            "auto-georeference-placement-misses-reference",
            "auto-georeference",
            {"corners": "100000,100000,100060,100000,100060,99920,100000,99920"},
            ("ratio_g.tif", "does not overlap"),
        )
    )
    c.append(
        Case(
            "auto-georeference-gcps-miss-reference",
            "auto-georeference",
            {"gcps": "far.csv"},
            ("ratio_g.tif", "does not overlap"),
            setup=_write("far.csv", _gcp_rows([(p, q, x - 50000, y) for p, q, x, y in rows])),
        )
    )
    # reproject-to: malformed vector files.
    vec = {"reference": "truth37.tif", "output": "out.geojson"}
    for cid, name, text, expect in (
        ("bare-array", "arr.geojson", '[{"type": "Feature"}]', "JSON array"),
        ("empty-file", "empty.geojson", "", "empty"),
        ("not-json", "bad.geojson", '{"type": "FeatureCollection", ', "not valid JSON"),
        ("not-geojson", "obj.geojson", '{"name": "x"}', "not GeoJSON"),
        (
            "feature-not-object",
            "num.geojson",
            '{"type": "FeatureCollection", "features": [3]}',
            "feature 1",
        ),
        ("geopackage-garbage", "junk.gpkg", "not a geopackage", "GeoPackage"),
    ):
        c.append(
            Case(
                f"reproject-to-vector-{cid}",
                "reproject-to",
                {
                    **vec,
                    "input": name,
                    "output": "out.gpkg" if name.endswith("gpkg") else "out.geojson",
                },
                (name, expect),
                setup=_write(name, text),
            )
        )
    import json

    nogeom = {
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32636"}},
        "features": [
            {"type": "Feature", "properties": {"id": 1}},
            {
                "type": "Feature",
                "properties": {"id": 2},
                "geometry": {"type": "Point", "coordinates": [700010.0, 3499990.0]},
            },
        ],
    }
    c.append(
        Case(
            "reproject-to-vector-feature-without-geometry-kept",
            "reproject-to",
            {**vec, "input": "nogeom.geojson"},
            (),
            setup=_write("nogeom.geojson", json.dumps(nogeom)),
            code=0,
            check=_vector_output_ok(2, 1),
        )
    )
    # Writer options (every GeoTIFF writer): junk, a zero GSD, an option COG refuses.
    for cid, words, expect in (
        ("co-not-name-value", ["--co", "junk"], ("'co'", "'junk'", "NAME=VALUE")),
        ("co-unknown-option", ["--co", "FOO=BAR"], ("'co'", "FOO=BAR")),
        ("co-bad-value", ["--co", "COMPRESS=ZIPPY"], ("'co'", "COMPRESS=ZIPPY")),
        ("raw-gsd-zero", ["--raw-gsd", "0"], ("'raw_gsd'", "> 0")),
        ("raw-gsd-nan", ["--raw-gsd", "nan"], ("'raw_gsd'",)),
        ("cog-refuses-tiled", ["--cog", "--co", "TILED=NO"], ("COG", "TILED=NO")),
        ("cog-refuses-blockxsize", ["--cog", "--co", "BLOCKXSIZE=64"], ("COG", "BLOCKXSIZE")),
    ):
        for op in ("ratio", "geolocate"):
            c.append(Case(f"{op}-writer-{cid}", op, {}, expect, extra=words))
    # shadow-map on cubes whose physics cannot be calibrated: the message must say so.
    c.append(
        Case(
            "shadow-map-all-zero-cube",
            "shadow-map",
            {},
            ("v.img", "zero"),
            setup=_cube_filled(lambda dt: 0),
        )
    )
    c.append(
        Case(
            "shadow-map-saturated-cube",
            "shadow-map",
            {},
            ("v.img", "saturated"),
            setup=_cube_filled(_saturated),
        )
    )
    # A shadow fraction given in percent would be clipped to 0–1 (nearly all "full shadow").
    for op, key in (("deshadow", "shadow"), ("shadow-fraction-fit", "truth")):
        c.append(
            Case(
                f"{op}-fraction-in-percent",
                op,
                {key: "pct.tif"},
                ("pct.tif", "0–1", "divide it by 100"),
                setup=_percent_fraction,
            )
        )
    c += _surface_cases() + _cube_cases()
    return c


def _cube_cases() -> list[Case]:
    """Cubes and options of the detectors that were ignored or misreported: a line too small
    for the boresight offset, wavelengths in micrometres labelled nanometres, a merged cube
    split at the wrong seam, an offset given where nothing uses it."""
    c = []
    for op in ("rx", "svdd", "boresight-offset", "boresight-indicator"):
        args = {"vnir": "v1.img", "swir": "s1.img"}
        if op == "boresight-indicator":
            args["ratio"] = None
        c.append(
            Case(
                f"{op}-one-line-image",
                op,
                args,
                ("30 × 1 pixels", "8 × 8"),
                setup=_one_line,
            )
        )
    # Cloud masks that are not masks: a probability, a clear-sky mask (1 = clear).
    for cid, mask, expect in (
        ("probability", lambda m: 0.01 + 0.3 * m, ("fractional values", "probability")),
        ("clear-sky", lambda m: np.ones_like(m), ("100 %", "inverted")),
    ):
        c.append(
            Case(
                f"boresight-offset-cloud-mask-{cid}",
                "boresight-offset",
                {"cloud_mask": "cm.tif"},
                ("cm.tif", *expect),
                setup=_cloud_mask("cm.tif", mask),
            )
        )
    c.append(
        Case(
            "ratio-micrometres-labelled-nanometres",
            "ratio",
            {},
            ("v.img", "micrometres", "Micrometers"),
            setup=_wavelength_header(
                "v.hdr", ", ".join(f"{w / 1000:.3f}" for w in range(400, 970, 50)), "Nanometers"
            ),
        )
    )
    c.append(
        Case(
            "ratio-merged-seam-too-low",
            "ratio",
            {"vnir": "m.img", "swir": None, "seam_nm": "700"},
            ("m.img", "seam_nm 700", "920 nm"),
            setup=_merged,
        )
    )
    c.append(
        Case(
            "rx-merged-cube-offset-given",
            "rx",
            {"vnir": "m.img", "swir": None, "offset_along": "0.5"},
            ("'offset_along'", "m.img", "SWIR file"),
            setup=_merged,
        )
    )
    c.append(
        Case(
            "svdd-offset-given-coregister-off",
            "svdd",
            {"offset_along": "0.5"},
            ("'offset_along'", "'coregister'"),
            extra=["--no-coregister"],
        )
    )
    c.append(
        Case(
            "boresight-indicator-eq3-offset-given",
            "boresight-indicator",
            {"offset_along": "0.5"},
            ("'offset_along'", "method 'physical'"),
        )
    )
    return c


def _cloud_mask(name: str, edit):
    def setup(d):
        m = np.random.default_rng(7).uniform(size=(1, ROWS, COLS))
        write_gtiff(d / name, edit(m).astype("float32"))

    return setup


def _one_line(d: Path) -> None:
    from synth import SWIR_WL, VNIR_WL, cube, write_envi

    write_envi(d / "v1.img", cube(len(VNIR_WL), 1, COLS, seed=1), VNIR_WL)
    write_envi(d / "s1.img", cube(len(SWIR_WL), 1, COLS, seed=2), SWIR_WL)


def _merged(d: Path) -> None:
    from synth import SWIR_WL, VNIR_WL, cube, write_envi

    vn, sw = cube(len(VNIR_WL), ROWS, COLS, seed=1), cube(len(SWIR_WL), ROWS, COLS, seed=2)
    write_envi(d / "m.img", np.concatenate([vn, sw]), np.concatenate([VNIR_WL, SWIR_WL]))


def _dsm(name: str, fill=None, dtype="float32", nodata=None, transform=GRID, count=1):
    """A DSM on hostile's UTM grid (a 20 m block on level ground at 100 m), its first three
    lines ``fill`` (a hole), written as ``dtype`` with ``nodata`` (None: none declared)."""

    def setup(d):
        z = np.full((count, ROWS, COLS), 100.0)
        z[:, 10:20, 10:18] = 120.0
        if fill is not None:
            z[:, :3] = fill
        if transform.e > 0:  # south-up: the same ground, its rows the other way round
            z = z[:, ::-1]
        profile = dict(driver="GTiff", width=COLS, height=ROWS, count=count, dtype=dtype)
        profile.update(crs=UTM36, transform=transform, nodata=nodata)
        with rasterio.open(d / name, "w", **profile) as dst:
            dst.write(z.astype(dtype))

    return setup


def _surface_cases() -> list[Case]:
    """Surface models and shadow fractions of a GIS analyst's folder: holes filled with a
    value the file does not declare as nodata, grids of the image's size but not its grid."""
    c = []
    sun = {"sun_zenith": "60", "sun_azimuth": "180"}
    on_grid = {"vnir": "vg.img", "swir": "sg.img"}
    for fill, dtype in ((-9999, "float32"), (-32768, "int16")):
        c.append(
            Case(
                f"sun-shadow-dsm-undeclared-fill-{-fill}",
                "sun-shadow",
                {"dsm": "fill.tif"},
                ("fill.tif", f"{fill} m", "nodata"),
                setup=_dsm("fill.tif", fill, dtype),
            )
        )
        c.append(
            Case(
                f"shadow-map-dsm-undeclared-fill-{-fill}",
                "shadow-map",
                {**on_grid, **sun, "dsm": "fill.tif"},
                ("fill.tif", f"{fill} m", "nodata"),
                setup=_dsm("fill.tif", fill, dtype),
            )
        )
    c.append(
        Case(
            "shadow-map-dsm-declared-fill-works",
            "shadow-map",
            {**on_grid, **sun, "dsm": "fill.tif"},
            (),
            setup=_dsm("fill.tif", -32768, "int16", nodata=-32768),
            code=0,
        )
    )
    # A DSM and a DTM in one file: band 1 would be used without a word.
    for op in ("shadow-map", "deshadow"):
        c.append(
            Case(
                f"{op}-dsm-of-two-bands",
                op,
                {**on_grid, **sun, "dsm": "two.tif"},
                ("two.tif", "2 bands", "gdal_translate -b 1"),
                setup=_dsm("two.tif", count=2),
            )
        )
    south_up = Affine(2.0, 0.0, 700000.0, 0.0, 2.0, 3500000.0 - 2.0 * ROWS)
    rotated = GRID @ Affine.rotation(30.0)
    for cid, transform in (("south-up", south_up), ("rotated", rotated)):
        c.append(
            Case(
                f"shadow-map-dsm-{cid}-of-the-image-size",
                "shadow-map",
                {**on_grid, **sun, "dsm": "other.tif"},
                ("other.tif", "geotransform"),
                setup=_dsm("other.tif", transform=transform),
            )
        )
    c.append(
        Case(
            "shadow-map-dsm-other-crs",
            "shadow-map",
            {**on_grid, **sun, "dsm": "dem37.tif"},
            ("dem37.tif", "EPSG:32637"),
        )
    )
    # A DSM on a map grid read through the line's IGM or GLT.
    via = {"vnir": "v.img", "swir": "s.img", **sun, "dsm": "dem_g.tif"}
    c.append(
        Case(
            "shadow-map-igm-without-crs-given-igm-crs",
            "shadow-map",
            {**via, "igm": "igm.tif", "igm_crs": UTM36},
            (),
            code=0,
        )
    )
    c.append(
        Case(
            "shadow-map-igm-crs-without-igm",
            "shadow-map",
            {**via, "igm_crs": UTM36},
            ("igm_crs", "'igm' or 'glt'"),
        )
    )
    for op, args in (
        ("shadow-map", {**via, "igm": "igm0.tif", "igm_crs": UTM36}),
        ("geolocate", {"igm": "igm0.tif"}),
    ):
        c.append(
            Case(
                f"{op}-igm-zero-fill-without-nodata",
                op,
                args,
                ("igm0.tif", "(0, 0)", "nodata"),
                setup=_igm("igm0.tif", _zero_rows),
            )
        )
    # A cell size the geotransform contradicts was ignored (one of the two is wrong).
    c.append(
        Case(
            "sun-shadow-cell-size-contradicts-geotransform",
            "sun-shadow",
            {"cell_size": "0.5"},
            ("'cell_size'", "0.5 m", "2 × 2 m", "dem_g.tif"),
        )
    )
    c.append(
        Case(
            "sun-shadow-cell-size-of-the-geotransform-works",
            "sun-shadow",
            {"cell_size": "2"},
            (),
            code=0,
        )
    )
    c.append(
        Case(
            "shadow-map-cell-size-contradicts-image-geotransform",
            "shadow-map",
            {**on_grid, **sun, "dsm": "dem.tif", "cell_size": "0.5"},
            ("'cell_size'", "0.5 m", "vg.img"),
        )
    )
    c.append(
        Case(
            "shadow-map-cell-size-with-igm",
            "shadow-map",
            {**via, "igm": "igm.tif", "igm_crs": UTM36, "cell_size": "2"},
            ("'cell_size'", "IGM or GLT"),
        )
    )
    c.append(
        Case(
            "geolocate-igm-9999-fill-without-nodata",
            "geolocate",
            {"igm": "igm9.tif"},
            ("igm9.tif", "(-9999, -9999)", "nodata"),
            setup=_igm("igm9.tif", lambda xy: np.where(_zero_rows(xy) == 0, -9999.0, xy)),
        )
    )
    c.append(
        Case(
            "shadow-map-glt-of-another-product",
            "shadow-map",
            {**via, "glt": "glt_big.tif"},
            ("glt_big.tif", "point outside image", "another product"),
            setup=_glt("glt_big.tif", ROWS + 5),
        )
    )
    c.append(
        Case(
            "deshadow-fraction-other-crs",
            "deshadow",
            {**on_grid, "shadow": "truth37.tif"},
            ("truth37.tif", "EPSG:32637"),
        )
    )
    c.append(
        Case(
            "deshadow-fraction-shifted-grid",
            "deshadow",
            {**on_grid, "shadow": "truth_shift.tif"},
            ("truth_shift.tif", "geotransform"),
        )
    )
    c.append(
        Case(
            "deshadow-fraction-nodata-zero",
            "deshadow",
            {"shadow": "nd0.tif"},
            ("nd0.tif", "declares 0 as its nodata", "sunlit"),
            setup=_fraction_nodata_zero,
        )
    )
    c.append(
        Case(
            "deshadow-fraction-in-bytes",
            "deshadow",
            {"shadow": "bytes.tif"},
            ("bytes.tif", "divide it by 255"),
            setup=_byte_fraction,
        )
    )
    return c


def _zero_rows(xy):
    xy = xy.copy()
    xy[:, 5:8] = 0.0
    return xy


def _glt(name: str, lines: int):
    """A GLT on hostile's UTM grid showing a product of ``lines`` lines (COLS samples)."""

    def setup(d):
        sample, line = np.meshgrid(np.arange(COLS) + 1, np.arange(ROWS) + 1)
        line = np.minimum(line * lines // ROWS, lines)
        write_gtiff(d / name, np.stack([sample, line]).astype("int32"), crs=UTM36, transform=GRID)

    return setup


def _glt_filled(name: str, fill, dtype: str):
    """hostile's grid as a GLT of the catalogue's rasters, its first 5 lines ``fill`` (cells
    that show no pixel) without a declared nodata."""

    def setup(d):
        sample, line = np.meshgrid(np.arange(COLS) + 1.0, np.arange(ROWS) + 1.0)
        glt = np.stack([sample, line])
        glt[:, :5] = fill
        write_gtiff(d / name, glt.astype(dtype), crs=UTM36, transform=GRID)

    return setup


def _fraction_nodata_zero(d: Path) -> None:
    with rasterio.open(d / "truth.tif") as src:
        f, profile = src.read(), src.profile
    profile.update(nodata=0)
    with rasterio.open(d / "nd0.tif", "w", **profile) as dst:
        dst.write(f)


def _byte_fraction(d: Path) -> None:
    with rasterio.open(d / "truth.tif") as src:
        f, profile = src.read(), src.profile
    profile.update(dtype="uint8")
    with rasterio.open(d / "bytes.tif", "w", **profile) as dst:
        dst.write(np.round(f * 255.0).astype("uint8"))


def _percent_fraction(d: Path) -> None:
    with rasterio.open(d / "truth.tif") as src:
        f, profile = src.read(), src.profile
    with rasterio.open(d / "pct.tif", "w", **profile) as dst:
        dst.write(f * 100.0)


CASES = _generic_cases() + _specific_cases() + _georef_cases()


def test_the_catalogue_covers_every_operation_and_is_large():
    missing = sorted(set(registry()) - set(BASE))
    assert not missing, f"give these operations valid arguments in BASE: {missing}"
    assert set(BASE) <= set(registry())
    ops = {c.op for c in CASES}
    assert ops == set(registry())
    assert len(CASES) >= 80
    assert len({c.id for c in CASES}) == len(CASES)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    return make_inputs(tmp_path_factory.mktemp("hostile") / "inputs")


@pytest.fixture(scope="module")
def ro_folder(tmp_path_factory):
    with read_only_folder(tmp_path_factory.mktemp("ro") / "ro") as ro:
        yield ro


@pytest.mark.parametrize("case", [pytest.param(c, id=c.id, marks=c.marks) for c in CASES])
def test_bad_input(case: Case, inputs: Path, ro_folder, tmp_path: Path):
    if case.needs_ro and ro_folder is None:
        pytest.skip("no read-only folder on this machine (not root and cannot chmod)")
    d = tmp_path / "case"
    shutil.copytree(inputs, d, symlinks=True)
    if case.setup is not None:
        case.setup(d)
    watched = [d] + ([ro_folder] if case.needs_ro else [])
    before = snapshot(*watched)
    args = {**BASE[case.op], **case.args}
    argv = _argv(case.op, args, d, ro_folder, case.extra)
    result = cli(argv)
    # Exit 70 is a bug in geoboresight: no user input may reach it.
    assert result.exit_code != 70, f"exit 70 (internal error) for {case.id}: {result.output}"
    assert result.exit_code == case.code, (argv, result.output)
    if case.code == 0:
        after = snapshot(*watched)
        assert {k: v for k, v in after.items() if k in before} == before, "an input changed"
        assert set(after) - set(before), "the run wrote nothing"
        if case.check is not None:
            case.check(d)
        return
    line = error_line(result)
    if os.environ.get("SHOW_MESSAGES"):
        print(f"\n{case.id}: {line}")
    for expect in case.expect:
        assert expect.format(d=d, ro=ro_folder) in line, (expect, line)
    assert snapshot(*watched) == before, "a file was left behind, changed or removed"


# --- Every sensor product kind in every raster input ------------------------------------------

PRODUCT_KINDS = ("specim", "hyspex", "enmap", "prisma")

#: (operation, raster input) pairs that take any raster: every RasterIn but a dual-sensor
#: dataset's (vnir, swir beside the layout's seam_nm), which the product readers have always
#: read.
RASTER_INPUTS = [
    (op, p.name)
    for op, alg in registry().items()
    for p in alg.inputs
    if p.kind == "raster"
    and p.name in BASE[op]
    and not (p.name in ("vnir", "swir") and "seam_nm" in {q.name for q in alg.params})
]


@pytest.fixture(scope="module")
def product_inputs(tmp_path_factory):
    from hostile import make_products

    d = make_inputs(tmp_path_factory.mktemp("hostile-products") / "inputs")
    return d, make_products(d)


@pytest.mark.parametrize("kind", PRODUCT_KINDS)
@pytest.mark.parametrize(("op", "name"), RASTER_INPUTS, ids=[f"{o}-{n}" for o, n in RASTER_INPUTS])
def test_every_product_kind_in_every_raster_input(op, name, kind, product_inputs, tmp_path):
    """A Specim capture (dark frames after the image), a HySpex file, an EnMAP zip and a PRISMA
    file where an operation takes any raster: read as the product's image (never GDAL's "not
    recognized" or "0 bands"), so a raw-geometry output has the image's lines, not the file's;
    or refused in one line for what the image holds. No exit 70; inputs untouched."""
    d, products = product_inputs
    p = products[kind]
    alg = registry()[op]
    args = {**BASE[op], name: p.path}
    out = tmp_path / "out"
    out.mkdir()
    args = {k: str(out / v) if alg.param(k).is_output else v for k, v in args.items()}
    before = snapshot(d)
    result = cli(_argv(op, args, d, None, []))
    assert result.exit_code != 70, result.output
    assert result.exit_code in (0, 1), result.output
    assert snapshot(d) == before, "an input changed"
    if result.exit_code == 1:
        line = error_line(result)
        for gdal_said in ("not recognized as being in a supported file format", "0 band"):
            assert gdal_said not in line, line
        return
    for tif in out.glob("*.tif"):
        with rasterio.open(tif) as src:
            if src.crs is None:  # raw sensor geometry: the image's lines and samples
                assert (src.height, src.width) == p.image.shape[1:], (tif.name, src.shape)
