"""What a QGIS user sees: parameter values mapped faithfully, bands checked, errors as messages,
progress and cancel through QgsProcessingFeedback (the engine's JSON lines), no output left by
a failed or cancelled run, and a clear message when the engine is missing, killed or of another
version."""

from __future__ import annotations

import os

import numpy as np
import pytest
import rasterio

from geoboresight.algorithms import registry
from geoboresight.io import quiet_georef

pytestmark = pytest.mark.qgis


def _feedback():
    from qgis.core import QgsProcessingFeedback

    class Feedback(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.errors, self.infos, self.progress = [], [], []
            self.progressChanged.connect(self.progress.append)

        def reportError(self, error, fatalError=False):  # noqa: N802, N803
            self.errors.append(error)
            super().reportError(error, fatalError)

        def pushInfo(self, info):  # noqa: N802
            self.infos.append(info)
            super().pushInfo(info)

    return Feedback()


def _run(alg, params, feedback=None):
    import processing

    return processing.run(f"geoboresight:{alg}", params, feedback=feedback or _feedback())


def _read(path):
    with quiet_georef(), rasterio.open(path) as src:
        return src.read(1)


def test_enum_index_and_numbers_reach_the_library(provider, inputs, tmp_path):
    """QGIS passes enums as indexes: index 1 must mean the spec's second choice."""
    scene = inputs.scene
    q = str(tmp_path / "q.tif")
    ratio = registry()["ratio"]
    assert ratio.param("band_mode").choices[1] == "edges"
    _run("ratio", {"vnir": scene["vnir"], "swir": scene["swir"], "band_mode": 1, "output": q})
    lib_edges = str(tmp_path / "edges.tif")
    lib_default = str(tmp_path / "default.tif")
    ratio(vnir=scene["vnir"], swir=scene["swir"], band_mode="edges", output=lib_edges)
    ratio(vnir=scene["vnir"], swir=scene["swir"], output=lib_default)
    np.testing.assert_array_equal(_read(q), _read(lib_edges))
    assert not np.array_equal(_read(lib_edges), _read(lib_default))  # the choice mattered


def test_band_beyond_the_raster_is_a_clear_error(provider, inputs, tmp_path):
    """QGIS does not check a band number against its raster: the algorithm must."""
    from qgis.core import QgsProcessingException

    out = tmp_path / "stats.json"
    fb = _feedback()
    with pytest.raises(QgsProcessingException) as err:
        _run("stats", {"input": inputs.ratio, "band": 5, "output": str(out)}, fb)
    text = str(err.value)
    assert "band 5 does not exist" in text and "1 band" in text and inputs.ratio in text, text
    assert not out.exists()


def test_range_error_gives_the_range(provider, inputs, tmp_path):
    from qgis.core import QgsProcessingException

    out = tmp_path / "r.tif"
    fb = _feedback()
    params = {"vnir": inputs.scene["vnir"], "swir": inputs.scene["swir"], "output": str(out)}
    params["swir_nm"] = 5000.0  # above the Wavelength maximum
    spec = registry()["ratio"].param("swir_nm")
    with pytest.raises(QgsProcessingException) as err:
        _run("ratio", params, fb)
    text = str(err.value)
    assert "swir_nm" in text and "5000 nm" in text, text
    assert f"{spec.minimum:g}–{spec.maximum:g} nm" in text, text
    assert not out.exists()


def test_envi_header_is_accepted(provider, inputs, tmp_path):
    """The label promises '.hdr/.img': a header path runs like its data file."""
    scene = inputs.scene
    hdr = os.path.splitext(scene["vnir"])[0] + ".hdr"
    assert os.path.exists(hdr)
    by_header, by_data = str(tmp_path / "h.tif"), str(tmp_path / "d.tif")
    _run("ratio", {"vnir": hdr, "swir": scene["swir"], "output": by_header})
    _run("ratio", {"vnir": scene["vnir"], "swir": scene["swir"], "output": by_data})
    np.testing.assert_array_equal(_read(by_header), _read(by_data))


def test_missing_envi_data_is_named(provider, tmp_path):
    from qgis.core import QgsProcessingException

    hdr = tmp_path / "lonely.hdr"
    hdr.write_text("ENVI\n")
    with pytest.raises(QgsProcessingException) as err:
        _run("ratio", {"vnir": str(hdr), "output": str(tmp_path / "r.tif")})
    assert "no data file sits beside it" in str(err.value) and str(hdr) in str(err.value)


def test_library_error_message_reaches_the_user(provider, inputs, tmp_path):
    """A wavelength with no band near it: the library's message, not a traceback."""
    from qgis.core import QgsProcessingException

    out = tmp_path / "r.tif"
    fb = _feedback()
    params = {
        "vnir": inputs.scene["vnir"],
        "swir": inputs.scene["swir"],
        "swir_nm": 2590.0,  # in range, but no SWIR band within the tolerance
        "tolerance_nm": 1.0,
        "output": str(out),
    }
    with pytest.raises(QgsProcessingException) as err:
        _run("ratio", params, fb)
    assert "2590" in str(err.value) and "Traceback" not in str(err.value), str(err.value)
    assert not out.exists()


def _long_line(scene, folder, lines):
    """The scene's VNIR and SWIR repeated along-track to at least ``lines`` lines (ENVI: the
    image bytes repeated, the header's line count changed)."""
    import re

    out = {}
    for name in ("vnir", "swir"):
        img = scene[name]
        with open(os.path.splitext(img)[0] + ".hdr", encoding="utf-8") as f:
            header = f.read()
        n = int(re.search(r"lines\s*=\s*(\d+)", header).group(1))
        repeat = -(-lines // n)
        with open(img, "rb") as f:
            data = f.read()
        out[name] = os.path.join(folder, f"{name}.img")
        with open(out[name], "wb") as f:
            f.write(data * repeat)
        with open(os.path.join(folder, f"{name}.hdr"), "w", encoding="utf-8") as f:
            f.write(re.sub(r"lines\s*=\s*\d+", f"lines = {n * repeat}", header))
    return out, n * repeat


def test_progress_and_cancel_at_the_first_block(provider, inputs, tmp_path):
    """Cancelled at its first progress line, the engine is terminated: no further progress is
    shown, the engine's own message says so, and neither the output nor a temporary file is
    left. The line is long enough (thousands of 4-line blocks) that the engine is still
    running when the cancel reaches it (a run that finished first keeps its outputs and says
    so: tests/test_engine.py, the engine's side of it)."""
    from qgis.core import QgsProcessingException

    folder = tmp_path / "line"
    folder.mkdir()
    line, n_lines = _long_line(inputs.scene, str(folder), 6000)
    out = tmp_path / "r.tif"
    fb = _feedback()
    blocks = []

    def cancel_after_first_block(value):
        blocks.append(value)
        fb.cancel()

    fb.progressChanged.connect(cancel_after_first_block)
    params = {
        "vnir": line["vnir"],
        "swir": line["swir"],
        "block_rows": 4,  # many blocks: cancelling must not wait for the rest
        "output": str(out),
    }
    with pytest.raises(QgsProcessingException) as err:
        _run("ratio", params, fb)
    n_blocks = -(-n_lines // 4)
    assert n_blocks >= 1000
    positive = [b for b in blocks if b > 0]
    assert len(positive) == 1, blocks  # nothing reported after the cancel
    # The first progress line came within the first 1 % of the blocks (progress is reported
    # only in steps of 0.1 %: QgsFeedback.setProgress): the cancel stopped the engine early.
    assert 0 < positive[0] < 1.0
    assert "cancelled by the user: no output was written" in str(err.value)
    assert not out.exists()
    assert not [n for n in os.listdir(tmp_path) if n.startswith(".r.")]  # no temp file left


def test_raw_geometry_output_is_flagged(provider, inputs, tmp_path):
    """No CRS: QGIS alone would read pixels as degrees without a word."""
    from qgis.core import QgsProcessingFeedback

    warnings = []

    class Feedback(QgsProcessingFeedback):
        def pushWarning(self, warning):  # noqa: N802
            warnings.append(warning)
            super().pushWarning(warning)

    with quiet_georef(), rasterio.open(inputs.scene["vnir"]) as src:
        assert src.crs is None  # the simulated scene is in raw sensor geometry
    out = str(tmp_path / "r.tif")
    _run(
        "ratio",
        {"vnir": inputs.scene["vnir"], "swir": inputs.scene["swir"], "output": out},
        Feedback(),
    )
    assert any("r.tif is in raw sensor geometry (no CRS)" in w for w in warnings), warnings


def test_progress_reaches_100(provider, inputs, tmp_path):
    fb = _feedback()
    _run(
        "ratio",
        {
            "vnir": inputs.scene["vnir"],
            "swir": inputs.scene["swir"],
            "block_rows": 8,
            "output": str(tmp_path / "r.tif"),
        },
        fb,
    )
    steps = [p for p in fb.progress if p > 0]
    assert len(steps) >= 3 and steps == sorted(steps) and steps[-1] == pytest.approx(100.0)
    assert any("boresight ratio" in m for m in fb.infos)
