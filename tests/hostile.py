"""Small inputs for every operation, and the tools of a hostile user's tests: run the CLI, snapshot
a folder byte by byte, mount a full or read-only file system.

Independent of the simulator: random cubes (``synth``) on a raw grid and on a UTM grid, with
variants in another CRS, on a shifted grid and one line short.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from rasterio.transform import from_origin
from synth import SWIR_WL, VNIR_WL, cube, write_envi, write_gtiff

from geoboresight.cli import main

UTM36 = "EPSG:32636"
UTM37 = "EPSG:32637"
GRID = from_origin(700000.0, 3500000.0, 2.0, 2.0)
SHIFTED = from_origin(700100.0, 3500000.0, 2.0, 2.0)
ROWS, COLS = 40, 30


def _float(seed: int, lo: float = 0.0, hi: float = 1.0, rows: int = ROWS) -> np.ndarray:
    return np.random.default_rng(seed).uniform(lo, hi, (1, rows, COLS)).astype("float32")


def make_inputs(d: Path) -> Path:
    """Write every input the catalogue's operations need into ``d``; ``d``."""
    d.mkdir(parents=True, exist_ok=True)
    vn, sw = cube(len(VNIR_WL), ROWS, COLS, seed=1), cube(len(SWIR_WL), ROWS, COLS, seed=2)
    write_envi(d / "v.img", vn, VNIR_WL)
    write_envi(d / "s.img", sw, SWIR_WL)
    write_envi(d / "s_small.img", sw[:, : ROWS - 1], SWIR_WL)
    write_envi(d / "vg.img", vn, VNIR_WL, crs=UTM36, transform=GRID)
    write_envi(d / "sg.img", sw, SWIR_WL, crs=UTM36, transform=GRID)
    write_envi(d / "sg37.img", sw, SWIR_WL, crs=UTM37, transform=GRID)
    write_envi(d / "sg_shift.img", sw, SWIR_WL, crs=UTM36, transform=SHIFTED)
    write_envi(d / "vg37.img", vn, VNIR_WL, crs=UTM37, transform=GRID)
    ratio = (sw[1:2].astype("float32") + 1.0) / (vn[10:11].astype("float32") + 1.0)
    write_gtiff(d / "ratio.tif", ratio)
    write_gtiff(d / "ratio_g.tif", ratio, crs=UTM36, transform=GRID)
    write_gtiff(d / "ratio_small.tif", ratio[:, : ROWS - 1])
    for name, crs, tr, rows in (
        ("", None, None, ROWS),
        ("_g", UTM36, GRID, ROWS),
        ("37", UTM37, GRID, ROWS),
        ("_shift", UTM36, SHIFTED, ROWS),
        ("_small", None, None, ROWS - 1),
    ):
        write_gtiff(d / f"truth{name}.tif", _float(3, rows=rows), crs=crs, transform=tr)
        target = (_float(4, rows=rows) > 0.9).astype("uint8")
        write_gtiff(d / f"target{name}.tif", target, crs=crs, transform=tr)
        write_gtiff(d / f"dem{name}.tif", _float(5, 0, 30, rows), crs=crs, transform=tr)
        write_gtiff(d / f"score{name}.tif", _float(6, 0, 10, rows), crs=crs, transform=tr)
        write_gtiff(
            d / f"mask{name}.tif",
            (_float(7, rows=rows) > 0.8).astype("uint8"),
            crs=crs,
            transform=tr,
        )
    classes = np.random.default_rng(8).integers(0, 5, (1, ROWS, COLS)).astype("uint8")
    write_gtiff(d / "classes.tif", classes)
    wl = np.arange(400.0, 2460.0, 10.0)
    rng = np.random.default_rng(9)
    rows = [
        f"{w:.1f},8.0,{a:.4f},{b:.4f}"
        for w, a, b in zip(
            wl, rng.uniform(0.05, 0.5, wl.size), rng.uniform(0.05, 0.5, wl.size), strict=True
        )
    ]
    _specim_capture(d)
    (d / "em.csv").write_text("wavelength_nm,fwhm_nm,grass,soil\n" + "\n".join(rows) + "\n")
    # Georeferencing: ground control points and an input geometry map (x, y of each pixel).
    cols, lines = np.meshgrid(np.arange(COLS) + 0.5, np.arange(ROWS) + 0.5)
    x, y = 700000.0 + 2.0 * cols, 3500000.0 - 2.0 * lines
    write_gtiff(d / "igm.tif", np.stack([x, y]).astype("float64"))
    gcp = [(0.5, 0.5), (COLS - 0.5, 0.5), (COLS - 0.5, ROWS - 0.5), (0.5, ROWS - 0.5), (15, 20)]
    (d / "gcps.csv").write_text(
        f"# CRS: {UTM36}\npixel,line,x,y\n"
        + "".join(f"{p},{q},{700000 + 2 * p},{3500000 - 2 * q}\n" for p, q in gcp)
    )
    _flight(d)
    return d


def _flight(d: Path) -> None:
    """The sample flight's navigation and DEM, with line times and a sensor model for the
    catalogue's image (its first lines; the model's middle pixels), for direct georeferencing
    and boresight calibration."""
    flight = Path(__file__).resolve().parents[1] / "sample_data" / "scene" / "flight"
    (d / "flight.out").write_bytes((flight / "flight.out").read_bytes())
    (d / "flight_dem.tif").write_bytes((flight / "dem.tif").read_bytes())
    times = (flight / "line_times.txt").read_text().splitlines()[:ROWS]
    (d / "line_times.txt").write_text("\n".join(times) + "\n")
    header, *rows = (flight / "vnir_model.csv").read_text().splitlines()
    first = (len(rows) - COLS) // 2
    middle = [f"{i},{row.split(',', 1)[1]}" for i, row in enumerate(rows[first : first + COLS])]
    (d / "vnir_model.csv").write_text("\n".join([header, *middle]) + "\n")
    _flight_gcps(d, json.loads((flight / "flight.json").read_text()))


def _flight_gcps(d: Path, known: dict) -> None:
    """GCPs on the catalogue's image where the flight's true VNIR angles put its pixels."""
    import rasterio

    from geoboresight.io.navigation import read_navigation, read_sensor_model
    from geoboresight.sensor.boresight import LeverArm
    from geoboresight.sensor.calibrate import tie_point_ground
    from geoboresight.sensor.georeference import Surface

    with rasterio.open(d / "flight_dem.tif") as src:
        dem = Surface(src.read(1).astype("float64"), src.transform, src.crs.to_wkt())
    times = np.loadtxt(d / "line_times.txt")
    model = read_sensor_model(str(d / "vnir_model.csv"))
    lever = LeverArm(*known["lever_arm_m"]["vnir"])
    project = tie_point_ground(read_navigation(str(d / "flight.out")), times, model, lever, dem)
    pl = np.array([(p, q) for p in (2.5, 15.0, 27.5) for q in (3.5, 20.0, 36.5)])
    xy = project(known["boresight_deg"]["vnir"], 0.0, pl)
    (d / "flight_gcps.csv").write_text(
        f"# CRS: {known['crs']}\npixel,line,x,y\n"
        + "".join(f"{p},{q},{x:.4f},{y:.4f}\n" for (p, q), (x, y) in zip(pl, xy, strict=True))
    )


def _specim_capture(d: Path) -> None:
    """A raw Specim capture (dark frames after the image) and the calibration of its sensor
    (tests/products.py: APL's and the calpacks' layouts), for ``radiance``."""
    from products import write_calibration, write_specim_raw

    vn = cube(len(VNIR_WL), ROWS, COLS, seed=1)
    write_specim_raw(d, "specim_capture", vn, VNIR_WL, dark=5.0, dark_lines=8, sensorid="110001")
    gain = np.random.default_rng(10).uniform(1.0, 2.0, (len(VNIR_WL), COLS))
    write_calibration(d, "specim_calibration", gain, VNIR_WL, sensorid="110001")


def snapshot(*folders: Path) -> dict[str, str]:
    """Every file under ``folders`` (hidden ones too) with the SHA-256 of its bytes."""
    out = {}
    for folder in folders:
        for root, dirs, files in os.walk(folder):
            for name in dirs + files:
                p = Path(root) / name
                key = str(p)
                out[key] = (
                    "dir"
                    if p.is_dir() and not p.is_symlink()
                    else (
                        "link:" + os.readlink(p)
                        if p.is_symlink()
                        else hashlib.sha256(p.read_bytes()).hexdigest()
                    )
                )
    return out


def cli(argv: list[str]):
    """Run the CLI in-process (quiet); the click result."""
    return CliRunner().invoke(main, [*argv, "-q"], catch_exceptions=True)


def error_line(result) -> str:
    """The error message of a failed run, asserted to be one line without a traceback (a
    command-line usage error, exit status 2, too: it says where the help is)."""
    err = result.stderr.strip()
    assert "Traceback" not in result.output, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(
        result.exception
    )
    if result.exit_code == 2:
        assert "--help')" in err, err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("Error: "), err
    return err


def run_subprocess(args: list[str], **kw) -> subprocess.CompletedProcess:
    """``python -m geoboresight.cli ARGS`` in a subprocess (for signals and resource limits)."""
    return subprocess.run(
        [sys.executable, "-m", "geoboresight.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        **kw,
    )


@contextlib.contextmanager
def mounted(folder: Path, options: str):
    """A tmpfs mounted at ``folder`` with ``options`` (e.g. ``size=64k`` or ``ro``), or None
    when this machine does not let us mount (not root, no CAP_SYS_ADMIN)."""
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        yield None
        return
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)], capture_output=True
    )
    if done.returncode != 0:
        yield None
        return
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], capture_output=True)


@contextlib.contextmanager
def read_only_folder(folder: Path):
    """A folder this process cannot write into: a read-only tmpfs as root, else mode 0555;
    None when neither is possible."""
    if os.geteuid() == 0:
        with mounted(folder, "ro,size=16k") as m:
            yield m
        return
    folder.mkdir(parents=True, exist_ok=True)
    folder.chmod(0o555)
    try:
        yield folder
    finally:
        folder.chmod(0o755)


# --- Sensor products in every raster input ---------------------------------------------------

#: Dark frames after a Specim capture's image lines.
DARK_LINES = 8


@dataclass
class ProductInput:
    """A sensor product written to its published layout (``products``, ``products_space``)
    and the image every operation must read from it: ``image`` (bands, lines, samples) with
    the VNIR bands before the SWIR bands, ``valid`` where a pixel is not masked, the band
    centres (nm), the units and the lines written to the file (image and dark frames)."""

    kind: str
    path: str
    image: np.ndarray
    valid: np.ndarray
    wavelengths: np.ndarray
    units: str
    lines_in_file: int


def make_products(d: Path) -> dict[str, ProductInput]:
    """A Specim raw capture with dark frames and a frame counter, a HySpex file, an EnMAP L1B
    zip and a PRISMA L1 file of ROWS × COLS pixels in ``d``, by kind."""
    from products import write_hyspex, write_specim_raw
    from products_space import PRISMA_NAME, write_enmap_l1b, write_prisma_l1

    d.mkdir(parents=True, exist_ok=True)
    sw = cube(len(SWIR_WL), ROWS, COLS, seed=2)
    _, data, written = write_specim_raw(
        d, "hawk_raw", sw, SWIR_WL, dark=800.0, dark_lines=DARK_LINES
    )
    valid = np.ones(sw.shape, bool)
    valid[0, :, :2] = False  # band 1's frame counter and zero pixel (APL)
    image = written[:ROWS].transpose(1, 0, 2).astype("float64")
    out = {
        "specim": ProductInput(
            "specim", data, image, valid, np.asarray(SWIR_WL, float), "DN", ROWS + DARK_LINES
        )
    }
    vn = cube(len(VNIR_WL), ROWS, COLS, seed=1)
    background = np.full((len(VNIR_WL), COLS), 190.0)
    path = write_hyspex(d, "capture", vn, VNIR_WL, background)
    out["hyspex"] = ProductInput(
        "hyspex",
        path,
        vn.astype("float64"),
        np.ones(vn.shape, bool),
        np.asarray(VNIR_WL, float),
        "DN",
        ROWS,
    )
    for kind, w in (
        ("enmap", write_enmap_l1b(d / "enmap", zip=True, rows=ROWS, cols=COLS)),
        ("prisma", write_prisma_l1(d / PRISMA_NAME, lines=ROWS, samples=COLS)),
    ):
        valid = (
            np.ones((len(w.vnir_wl) + len(w.swir_wl), ROWS, COLS), bool)
            if w.vnir_valid is None
            else np.concatenate([w.vnir_valid, w.swir_valid])
        )
        out[kind] = ProductInput(
            kind,
            w.path,
            np.concatenate([w.vnir_radiance, w.swir_radiance]),
            valid,
            np.concatenate([w.vnir_wl, w.swir_wl]).astype(float),
            "radiance",
            ROWS,
        )
    return out


# --- The hostile cases every face must meet (CLI, engine, batch) -----------------------------


@dataclass
class FaceCase:
    """One run and what each face must say: ``code`` 0 (with ``warning`` among the result's
    warnings, if given) or 1 with ``expect`` in the error line; ``param`` is a parameter the
    error must name in the face's own words."""

    id: str
    op: str
    values: dict  # parameter -> value ("{d}" = the folder of make_face_inputs)
    code: int
    expect: tuple[str, ...] = ()
    param: str = ""
    warning: str = ""


def make_face_inputs(d: Path) -> Path:
    """The files of :data:`FACE_CASES` in ``d`` (beside make_inputs' files)."""
    import json
    import sqlite3

    import h5py
    from products_space import PRISMA_NAME, write_prisma_l1

    make_inputs(d)
    text = (d / "gcps.csv").read_text()
    (d / "gcps_repeated.csv").write_text(text + text.splitlines()[-1] + "\n")
    feature = {
        "type": "Feature",
        "properties": {"a": 1},
        "geometry": {"type": "Point", "coordinates": [700010.0, 3499990.0]},
    }
    doc = {
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "EPSG:999999"}},
        "features": [feature],
    }
    (d / "unknown_crs.geojson").write_text(json.dumps(doc))
    import pyogrio.raw
    import shapely

    pyogrio.raw.write(
        str(d / "garbled_srs.gpkg"),
        np.array([shapely.to_wkb(shapely.Point(700010.0, 3499990.0))], dtype=object),
        [np.array([1])],
        fields=["a"],
        geometry_type="Point",
        crs="EPSG:32636",
        driver="GPKG",
    )
    with contextlib.closing(sqlite3.connect(d / "garbled_srs.gpkg")) as db:
        db.execute(
            "INSERT INTO gpkg_spatial_ref_sys (srs_name, srs_id, organization, "
            "organization_coordsys_id, definition) VALUES ('garbled', 5555, 'NONE', 5555, 'garbage')"
        )
        db.execute("UPDATE gpkg_geometry_columns SET srs_id = 5555")
        db.execute("UPDATE gpkg_contents SET srs_id = 5555")
        db.commit()
    # PRISMA latitude/longitude of another shape than the cube (a damaged download).
    prisma = d / "short_geo" / PRISMA_NAME
    prisma.parent.mkdir()
    write_prisma_l1(prisma, lines=ROWS, samples=COLS)
    geo = "HDFEOS/SWATHS/PRS_L1_HCO/Geolocation Fields"
    with h5py.File(prisma, "r+") as f:
        for name in ("Latitude_VNIR", "Longitude_VNIR"):
            del f[f"{geo}/{name}"]
            f.create_dataset(f"{geo}/{name}", data=np.full((ROWS - 3, COLS), 45.0, "float32"))
    return d


FACE_CASES = [
    FaceCase(
        "repeated-gcp-polynomial",
        "georeference",
        {"input": "{d}/ratio.tif", "gcps": "{d}/gcps_repeated.csv", "output": "{o}/poly.tif"},
        0,
        warning="GCP(s) 6 repeat an earlier GCP exactly",
    ),
    FaceCase(
        "repeated-gcp-spline",
        "georeference",
        {
            "input": "{d}/ratio.tif",
            "gcps": "{d}/gcps_repeated.csv",
            "method": "tps",
            "output": "{o}/tps.tif",
        },
        0,
        warning="left out of the thin-plate spline",
    ),
    FaceCase(
        "geojson-unknown-crs",
        "reproject-to",
        {
            "input": "{d}/unknown_crs.geojson",
            "reference": "{d}/ratio_g.tif",
            "output": "{o}/v.gpkg",
        },
        1,
        ("unknown_crs.geojson", "EPSG:999999", "not known"),
    ),
    FaceCase(
        "gpkg-garbled-srs",
        "reproject-to",
        {"input": "{d}/garbled_srs.gpkg", "reference": "{d}/ratio_g.tif", "output": "{o}/g.gpkg"},
        1,
        ("garbled_srs.gpkg", "5555", "'garbage'", "cannot be resolved"),
    ),
    FaceCase(
        "vnir-dark-below-the-data",
        "shadow-map",
        {"vnir": "{d}/v.img", "swir": "{d}/s.img", "vnir_dark": -500, "output": "{o}/f.tif"},
        1,
        ("v.img", "-500", "far below"),
        param="vnir_dark",
    ),
    FaceCase(
        "swir-dark-above-the-signal",
        "shadow-map",
        {"vnir": "{d}/v.img", "swir": "{d}/s.img", "swir_dark": 60000, "output": "{o}/f2.tif"},
        1,
        ("s.img", "60000", "above the signal"),
        param="swir_dark",
    ),
    FaceCase(
        "deshadow-vnir-dark-below-the-data",
        "deshadow",
        {
            "vnir": "{d}/v.img",
            "swir": "{d}/s.img",
            "shadow": "{d}/truth.tif",
            "vnir_dark": -500,
            "output": "{o}/d.tif",
        },
        1,
        ("v.img", "-500", "far below"),
        param="vnir_dark",
    ),
    FaceCase(
        "deshadow-swir-dark-above-the-signal",
        "deshadow",
        {
            "vnir": "{d}/v.img",
            "swir": "{d}/s.img",
            "shadow": "{d}/truth.tif",
            "swir_dark": 60000,
            "output": "{o}/d2.tif",
        },
        1,
        ("s.img", "60000", "above the signal"),
        param="swir_dark",
    ),
    FaceCase(
        "physical-indicator-dark-above-the-signal",
        "boresight-indicator",
        {
            "method": "physical",
            "vnir": "{d}/v.img",
            "swir": "{d}/s.img",
            "swir_dark": 60000,
            "output": "{o}/bi.tif",
        },
        1,
        ("above both dark levels",),
        param="swir_dark",
    ),
    FaceCase(
        "prisma-geolocation-of-another-shape",
        "geolocate",
        {
            "input": "{d}/short_geo/" + "PRS_L1_STD_OFFL_20200524101500_20200524101504_0001.he5",
            "output": "{o}/geo.tif",
        },
        1,
        (f"({ROWS - 3}, {COLS})", f"({ROWS}, {COLS})", "Latitude_VNIR"),
        param="igm",
    ),
]


def face_values(case: FaceCase, d: Path, o: Path) -> dict:
    """``case.values`` with its folders filled in."""
    return {k: v.format(d=d, o=o) if isinstance(v, str) else v for k, v in case.values.items()}
