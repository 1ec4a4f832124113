"""Suite-wide hooks.

``GEOBORESIGHT_REQUIRE_QGIS=1`` (set by ``.ci/run``) turns a skipped ``@pytest.mark.qgis`` test
into a failure, and fails the run if it was meant to include the QGIS tests but none of them
ran: in CI, "QGIS is missing" must never look like success.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

_QGIS_DIR = Path(__file__).parent / "qgis"


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
    # Measured values are remembered in a folder of this run's own (never the user's cache),
    # inherited by the command lines and engines the tests start.
    os.environ["GEOBORESIGHT_CACHE_DIR"] = tempfile.mkdtemp(prefix="geoboresight-cache-")


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
