"""The engine as a separate process, seen from QGIS: cancel from a timer stops it within a
second and leaves nothing; a killed, missing, old or other-version engine gives one clear
message; QGIS's own process never loads the library or its wheels."""

from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest
from qgis_harness import fake_engine

pytestmark = pytest.mark.qgis


@pytest.fixture(scope="module")
def long_scene(tmp_path_factory):
    """A tall ENVI pair: the ratio streams it in tens of thousands of one-line blocks (seconds
    of work even on a fast machine: 3,000 lines once finished within the cancel's 0.5 s), so
    that a cancel lands in the middle of a run."""
    from geoboresight.io import write_envi

    folder = tmp_path_factory.mktemp("long")
    rng = np.random.default_rng(1)
    shape = (24000, 64)
    vnir = rng.integers(200, 4000, (6, *shape)).astype("uint16")
    swir = rng.integers(200, 4000, (6, *shape)).astype("uint16")
    return (
        write_envi(str(folder / "vnir.img"), vnir, np.linspace(870.0, 970.0, 6)),
        write_envi(str(folder / "swir.img"), swir, 980.0 + 30.0 * np.arange(6)),
    )


def _feedback():
    from qgis.core import QgsProcessingFeedback

    class Feedback(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.progress = []
            self.progressChanged.connect(self.progress.append)

    return Feedback()


def _engine_children() -> list[int]:
    """Running child processes of this one whose command line names geoboresight."""
    me, found = os.getpid(), []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read()
        except (OSError, IndexError, ValueError):
            continue
        if ppid == me and b"geoboresight" in cmd and b"engine" in cmd:
            found.append(int(pid))
    return found


def test_cancel_from_a_timer_stops_the_engine_within_a_second(provider, long_scene, tmp_path):
    import processing
    from qgis.core import QgsProcessingException

    vnir, swir = long_scene
    out = tmp_path / "ratio.tif"
    fb = _feedback()
    when = {}

    def cancel():
        when["cancel"] = time.monotonic()
        when["engines"] = _engine_children()
        fb.cancel()

    timer = threading.Timer(0.5, cancel)
    fb.progressChanged.connect(lambda _: timer.is_alive() or when or timer.start())
    params = {"vnir": vnir, "swir": swir, "block_rows": 1, "output": str(out)}
    with pytest.raises(QgsProcessingException) as err:
        processing.run("geoboresight:ratio", params, feedback=fb)
    assert "cancel" in when, str(err.value)
    stopped = time.monotonic() - when["cancel"]
    assert "cancelled by the user" in str(err.value)
    assert 0 < max(fb.progress) < 100  # the run was under way
    assert len(when["engines"]) == 1  # the engine was running when cancelled
    assert not os.path.exists(f"/proc/{when['engines'][0]}/cmdline") or not _engine_children()
    print(f"engine stopped {stopped:.3f} s after cancel")
    assert stopped < 1.0, stopped
    assert not out.exists()
    assert os.listdir(tmp_path) == []  # nor a temporary file


def test_killed_engine_is_a_clear_message(provider, long_scene, tmp_path):
    import processing
    from qgis.core import QgsProcessingException

    vnir, swir = long_scene
    out = tmp_path / "ratio.tif"
    fb = _feedback()
    killed = []

    def kill(_):
        if not killed:
            killed.extend(_engine_children())
            for pid in killed:
                os.kill(pid, signal.SIGKILL)  # as the out-of-memory killer would

    fb.progressChanged.connect(kill)
    with pytest.raises(QgsProcessingException) as err:
        processing.run(
            "geoboresight:ratio",
            {"vnir": vnir, "swir": swir, "block_rows": 1, "output": str(out)},
            feedback=fb,
        )
    assert killed
    text = str(err.value)
    assert "engine stopped unexpectedly" in text and "'ratio'" in text, text
    assert not out.exists()
    assert os.listdir(tmp_path) == []  # the writer's temporary file removed by the plugin


def _run_ratio(inputs, tmp_path):
    import processing
    from qgis.core import QgsProcessingException

    try:
        return processing.run(
            "geoboresight:ratio",
            {
                "vnir": inputs.scene["vnir"],
                "swir": inputs.scene["swir"],
                "output": str(tmp_path / "r.tif"),
            },
            feedback=_feedback(),
        )
    except QgsProcessingException as exc:
        assert "Traceback" not in str(exc), str(exc)  # the message alone, as QGIS shows it
        raise


def test_missing_engine_says_how_to_set_it_up(provider, inputs, tmp_path, monkeypatch):
    from qgis.core import QgsProcessingException

    monkeypatch.setenv("GEOBORESIGHT_ENGINE", str(tmp_path / "nowhere" / "geoboresight"))
    with pytest.raises(QgsProcessingException) as err:
        _run_ratio(inputs, tmp_path)
    text = str(err.value)
    assert "does not exist" in text and "nowhere" in text and "Set up the geoboresight" in text
    monkeypatch.delenv("GEOBORESIGHT_ENGINE")  # nothing configured, nothing set up
    with pytest.raises(QgsProcessingException) as err:
        _run_ratio(inputs, tmp_path)
    assert "not set up yet" in str(err.value) and "Set up the geoboresight" in str(err.value)
    assert not (tmp_path / "r.tif").exists()


def test_engine_of_another_version_is_refused(provider, inputs, tmp_path, monkeypatch):
    from qgis.core import QgsProcessingException

    engine = fake_engine(
        tmp_path,
        "geoboresight",
        'print(json.dumps({"engine": {"version": "9.4.0", "protocol": 1, "pid": os.getpid()}}),'
        " flush=True)\ntime.sleep(60)\n",
    )
    monkeypatch.setenv("GEOBORESIGHT_ENGINE", engine)
    started = time.monotonic()
    with pytest.raises(QgsProcessingException) as err:
        _run_ratio(inputs, tmp_path)
    text = str(err.value)
    assert "version 9.4.0" in text and "this plugin is version" in text, text
    assert "Set up the geoboresight engine" in text
    assert time.monotonic() - started < 30  # refused at its first line, not after its sleep


def test_engine_without_machine_mode_is_explained(provider, inputs, tmp_path, monkeypatch):
    from qgis.core import QgsProcessingException

    engine = fake_engine(
        tmp_path,
        "geoboresight",
        "sys.stderr.write(\"Error: No such command 'engine'.\\n\")\nsys.exit(2)\n",
    )
    monkeypatch.setenv("GEOBORESIGHT_ENGINE", engine)
    with pytest.raises(QgsProcessingException) as err:
        _run_ratio(inputs, tmp_path)
    text = str(err.value)
    assert "did not answer in the engine protocol" in text and "No such command" in text, text
    assert "older than this plugin" in text
