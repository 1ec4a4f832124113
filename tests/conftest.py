"""Suite-wide hooks.

``GEOBORESIGHT_REQUIRE_QGIS=1`` (set by ``.ci/run``) turns a skipped ``@pytest.mark.qgis`` test
into a failure, and fails the run if it was meant to include the QGIS tests but none of them
ran: in CI, "QGIS is missing" must never look like success.

The ``compat`` marker: ``make test-main`` runs every test but the QGIS ones with numpy 2;
``make test-qgis`` runs, in the environment beside Debian's QGIS (numpy 1.26, Debian's
matplotlib), the QGIS tests and the modules of ``COMPAT`` below, the ones whose results that
environment can change.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

_QGIS_DIR = Path(__file__).parent / "qgis"

# The test modules run again with numpy 1.26 and Debian's matplotlib, and why: what they check
# goes through an API whose behaviour differs between the two environments. numpy 2.0 changed
# the type promotion of scalars with arrays (NEP 50: float32 results and their rounding), the
# copy rules of array conversions, byte-order and dtype handling, and the repr of its scalars
# (which reaches JSON and messages); matplotlib is Debian's 3.6 there.
COMPAT = {
    "test_ratio.py": "Eq. 3 on every input dtype, interleave and nodata: type promotion",
    "test_stats.py": "statistics against SciPy, merged over strips, written as JSON: scalars",
    "test_windows.py": "the one block loop: strip dtypes, halos, merged reductions, copies",
    "test_strip_reading.py": "raw ENVI strips from memory maps, co-registered float32 strips",
    "test_products_raw.py": "Specim raw and HySpex readers: byte order, memory maps, frombuffer",
    "test_products_space.py": "EnMAP and PRISMA readers: HDF5 and VRT data to arrays, byte order",
    "test_simulate_io.py": "the simulator's files byte for byte and its headers' numbers",
    "test_map_ready.py": "the GeoTIFF writers: profiles and predictors by dtype, overviews",
    "test_vector.py": "the vector writers: field and geometry arrays handed to pyogrio",
    "test_engine.py": "the engine's JSON lines, which the QGIS plugin reads: scalars in JSON",
    "test_report.py": "figures drawn with Debian's matplotlib, numbers formatted into HTML",
    "test_info.py": "every sensor product's reader, and what it reports as text and JSON",
    "test_cache.py": "measured offsets remembered as JSON and read back: scalars",
    "test_anomaly.py": "RX, SVDD, unmixing, ROC against their references: numpy.linalg, float32",
    "test_anomaly_physical.py": "co-registered RX and d-prime: numpy.linalg.solve, float32 sums",
    "test_dem.py": "matching and kriging: stacked numpy.linalg.solve (2.0 changed how b broadcasts)",
    "test_georef.py": "transforms fitted with numpy.linalg against GDAL's, pyproj's scalars",
    "test_shadow.py": "shadow classes, cluster and dark pixels: numpy.linalg.solve, isin",
    "test_properties.py": "kernel invariances on random float32 inputs: type promotion",
}


def _require_qgis() -> bool:
    return os.environ.get("GEOBORESIGHT_REQUIRE_QGIS", "") not in ("", "0")


def _qgis_selected(config) -> bool:
    """True when this run was meant to include tests/qgis (not deselected, not out of scope)."""
    markexpr = config.getoption("markexpr", "") or ""
    if "not qgis" in markexpr.replace("  ", " "):
        return False
    args = [Path(a.split("::")[0]).resolve() for a in config.args] or [Path.cwd()]
    qdir = _QGIS_DIR.resolve()
    return any(a == qdir or a in qdir.parents or qdir in a.parents for a in args)


def pytest_configure(config):
    config._geoboresight_qgis_ran = 0
    missing = sorted(m for m in COMPAT if not (Path(__file__).parent / m).is_file())
    if missing:  # a renamed module must not leave the numpy 1.26 run silently
        raise pytest.UsageError(f"tests/conftest.py COMPAT names missing modules: {missing}")
    # Measured values are remembered in a folder of this run's own (never the user's cache),
    # inherited by the command lines and engines the tests start.
    os.environ["GEOBORESIGHT_CACHE_DIR"] = tempfile.mkdtemp(prefix="geoboresight-cache-")


@pytest.hookimpl(tryfirst=True)  # before -m selects by the markers
def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.name in COMPAT and item.path.parent == Path(__file__).parent:
            item.add_marker(pytest.mark.compat)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    if not (_require_qgis() and item.get_closest_marker("qgis")):
        return
    if report.skipped and not hasattr(report, "wasxfail"):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        report.outcome = "failed"
        report.longrepr = f"GEOBORESIGHT_REQUIRE_QGIS=1 but this QGIS test was skipped: {reason}"
    elif (
        report.when == "call"
        and report.passed
        and {"qgis_app", "qgis_env", "desktop"} & set(item.fixturenames)
    ):
        item.config._geoboresight_qgis_ran += 1  # a test that really ran QGIS


def pytest_sessionfinish(session, exitstatus):
    config = session.config
    if _require_qgis() and _qgis_selected(config) and config._geoboresight_qgis_ran == 0:
        config._geoboresight_no_qgis = True
        if session.exitstatus == 0:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if getattr(config, "_geoboresight_no_qgis", False):
        terminalreporter.write_line(
            "GEOBORESIGHT_REQUIRE_QGIS=1 but no QGIS test passed: install Debian's qgis, "
            "python3-qgis and qgis-providers and run with a venv made from /usr/bin/python3 "
            "--system-site-packages (see docs/qgis.md)",
            red=True,
        )
