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

import pytest
from hostile import UTM36, cli, error_line, make_inputs, read_only_folder, snapshot

from geoboresight.algorithms import registry
from geoboresight.errors import cli_option

#: Valid arguments of every operation on the inputs of hostile.make_inputs ("{d}" is the
#: case's folder). Outputs are named out.<extension>.
BASE: dict[str, dict[str, str]] = {
    "ratio": {"vnir": "v.img", "swir": "s.img", "output": "out.tif"},
    "stats": {"input": "ratio.tif", "output": "out.json"},
    "dark-pixel-shadow": {"vnir": "v.img", "output": "out.tif"},
    "shadow-classes": {"ratio": "ratio.tif", "output": "out.tif"},
    "shadow-cluster": {"ratio": "ratio.tif", "vnir": "v.img", "output": "out.tif"},
    "shadow-fraction-apply": {"ratio": "ratio.tif", "output": "out.tif"},
    "shadow-fraction-fit": {"ratio": "ratio.tif", "truth": "truth.tif", "report": "out.json"},
    "shadow-map": {"vnir": "v.img", "swir": "s.img", "output": "out.tif"},
    "shadow-polygons": {"classes_raster": "classes.tif", "output": "out.gpkg"},
    "sun-shadow": {
        "dsm": "dem_g.tif",
        "sun_zenith": "40",
        "sun_azimuth": "135",
        "output": "out.tif",
    },
    "boresight-offset": {"vnir": "v.img", "swir": "s.img", "output": "out.json"},
    "coregister": {"vnir": "v.img", "swir": "s.img", "output": "out.tif"},
    "disparity": {"vnir": "v.img", "swir": "s.img", "output": "out.tif"},
    "relative-dem": {"vnir": "v.img", "swir": "s.img", "height_factor": "0.1", "output": "out.tif"},
    "view-3d": {"dem": "dem.tif", "vnir": "v.img", "swir": "s.img", "output": "out.png"},
    "anomaly-polygons": {"score": "score.tif", "threshold": "5", "output": "out.gpkg"},
    "boresight-indicator": {"ratio": "ratio.tif", "output": "out.tif"},
    "roc": {"scores": "score.tif", "truth": "target.tif", "output": "out.png"},
    "rx": {"vnir": "v.img", "swir": "s.img", "output": "out.tif"},
    "svdd": {"vnir": "v.img", "swir": "s.img", "output": "out.tif"},
    "unmix": {"vnir": "v.img", "swir": "s.img", "endmembers": "em.csv", "output": "out.tif"},
    "simulate": {"output": "outdir", "lines": "16"},
    "simulate-ortho": {"output": "outdir", "lines": "16"},
    "auto-georeference": {"input": "ratio.tif", "reference": "ratio_g.tif", "output": "out.tif"},
    "geolocate": {"input": "ratio.tif", "igm": "igm.tif", "igm_crs": UTM36, "output": "out.tif"},
    "georeference": {"input": "ratio.tif", "gcps": "gcps.csv", "output": "out.tif"},
    "reproject-to": {"input": "ratio_g.tif", "reference": "truth37.tif", "output": "out.tif"},
    "report": {"vnir": "v.img", "swir": "s.img", "output": "out.html"},
    "info": {"vnir": "v.img", "output": "out.json"},
}

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
        argv += ["--" + name.replace("_", "-"), value]
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


CASES = _generic_cases() + _specific_cases()


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


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
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
    assert result.exit_code == case.code, (argv, result.output)
    line = error_line(result)
    if os.environ.get("SHOW_MESSAGES"):
        print(f"\n{case.id}: {line}")
    for expect in case.expect:
        assert expect.format(d=d, ro=ro_folder) in line, (expect, line)
    assert snapshot(*watched) == before, "a file was left behind, changed or removed"
