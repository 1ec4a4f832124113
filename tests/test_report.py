"""The scene report: one self-contained HTML page whose figures really render (headless
Chromium), whose numbers are the operations' own, and which degrades to notes, not crashes."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess

import numpy as np
import pytest
import rasterio

from geoboresight.algorithms import registry
from geoboresight.errors import Cancelled
from geoboresight.io import quiet_georef
from geoboresight.progress import Progress

CHROMIUM = ("/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome")
SECTIONS = ("Boresight ratio and statistics", "Shadow", "Relative DEM", "Anomaly detection")


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    from geoboresight.simulate import simulate_scene, write_scene

    folder = tmp_path_factory.mktemp("report") / "sim"
    sim = simulate_scene(
        preset="mixed", lines=40, seed=5, geometry="large-squint"
    )  # relief measurable
    write_scene(sim, folder)
    return folder, sim.truth


@pytest.fixture(scope="module")
def full_report(scene):
    folder, truth = scene
    out = folder.parent / "report.html"
    products = folder.parent / "products"
    result = registry()["report"](
        vnir=str(folder / "vnir.img"),
        swir=str(folder / "swir.img"),
        shadow_truth=str(folder / "truth_shadow_fraction.tif"),
        target_truth=str(folder / "truth_target_abundance.tif"),
        height_factor=abs(truth["disparity_px_per_m"]["along"]),
        svdd=False,
        output=str(out),
        products=str(products),
    )
    return out, products, result


def test_report_is_self_contained_with_every_section(full_report):
    out, _, result = full_report
    assert result["output"] == str(out)
    text = out.read_text(encoding="utf-8")
    for title in SECTIONS:
        assert f"<h2>{title}</h2>" in text
    assert "class='missing'" not in text  # every input was given: no section left out
    sources = re.findall(r"""src=['"]([^'"]+)""", text)
    assert len(sources) >= 9  # ratio, histogram, classes, scatter, fit, 3-D, ROC, 2 scores
    assert all(s.startswith("data:image/png;base64,") for s in sources)
    assert "<link" not in text and "<script" not in text  # nothing fetched when opened
    assert "Parameters used" in text and "numerator_nm" in text


def test_report_numbers_are_the_operations_own(full_report):
    """Table 1's N and mean in the page equal NumPy on the ratio raster the report made."""
    out, products, _ = full_report
    with quiet_georef(), rasterio.open(products / "ratio.tif") as src:
        ratio = src.read(1, masked=True).compressed().astype("float64")
    text = out.read_text(encoding="utf-8")
    table1 = text[text.index("Descriptive statistics (as in Table 1)") :]
    row = re.search(r"<tr><td class='l'>[^<]*</td>(.*?)</tr></table>", table1).group(1)
    cells = re.findall(r"<td>([^<]*)</td>", row)
    assert int(cells[0].replace(",", "")) == ratio.size
    assert float(cells[1].replace(",", "")) == pytest.approx(ratio.mean(), abs=1e-4)
    with open(products / "stats.json", encoding="utf-8") as f:
        assert json.load(f)["n"] == ratio.size


def test_missing_inputs_become_notes(scene, tmp_path):
    folder, _ = scene
    out = tmp_path / "r.html"
    registry()["report"](
        vnir=str(folder / "vnir.img"), swir=str(folder / "swir.img"), svdd=False, output=str(out)
    )
    text = out.read_text(encoding="utf-8")
    notes = re.findall(r"class='missing'>([^<]*)<", text)
    assert any("Figure 5" in n for n in notes)
    assert any("ROC" in n for n in notes)
    assert any("relative-dem" in n and "height" in n.lower() for n in notes), notes
    assert "<h2>Anomaly detection</h2>" in text and text.count("data:image/png") >= 5
    assert not (tmp_path / "r.html.work").exists()  # intermediate products cleaned up


def test_unknown_operation_is_a_note(tmp_path):
    from geoboresight.report import Runner, Section

    section = Section("x", "y")
    step = Runner(str(tmp_path), Progress(), 1).run(section, "no-such-operation", {"a": 1})
    assert step.result is None and "not available" in step.error
    assert "not available" in section.html()


def test_cancel_leaves_nothing(scene, tmp_path):
    folder, _ = scene
    out = tmp_path / "r.html"
    calls = []

    def cancelled():
        calls.append(1)
        return len(calls) > 3

    with pytest.raises(Cancelled):
        registry()["report"](
            progress=Progress(is_cancelled=cancelled),
            vnir=str(folder / "vnir.img"),
            swir=str(folder / "swir.img"),
            output=str(out),
        )
    assert os.listdir(tmp_path) == []


def _chromium():
    for path in CHROMIUM:
        if os.path.exists(path):
            return path
    if os.environ.get("GEOBORESIGHT_REQUIRE_TOOLS", "") not in ("", "0"):
        pytest.fail(
            "GEOBORESIGHT_REQUIRE_TOOLS=1 but chromium is not installed (Debian package chromium)"
        )
    pytest.skip("chromium not installed (Debian package chromium)")


def _chromium_args(exe, profile):
    return [
        exe,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={profile}",
        "--virtual-time-budget=5000",
    ]


def test_report_renders_in_chromium(full_report, tmp_path):
    """Every <img> decodes (naturalWidth > 0) and the screenshot shows the figures."""
    from PIL import Image

    exe = _chromium()
    out, _, _ = full_report
    probe = tmp_path / "probe.html"
    script = (
        "<script>window.addEventListener('load',function(){var w=[];"
        "for(var i=0;i<document.images.length;i++){w.push(document.images[i].naturalWidth)}"
        "document.body.setAttribute('data-widths',w.join(','))});</script>"
    )
    probe.write_text(
        out.read_text(encoding="utf-8").replace("</body>", script + "</body>"), encoding="utf-8"
    )
    env = dict(os.environ, HOME=str(tmp_path))
    dom = subprocess.run(
        [*_chromium_args(exe, tmp_path / "p1"), "--dump-dom", probe.as_uri()],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert dom.returncode == 0, dom.stderr[-2000:]
    widths = re.search(r'data-widths="([^"]*)"', dom.stdout)
    assert widths, "the page's load handler did not run"
    widths = [int(w) for w in widths.group(1).split(",")]
    assert len(widths) == out.read_text(encoding="utf-8").count("<img")
    assert len(widths) >= 9 and min(widths) > 0, widths  # 0 = an image that failed to decode

    shot = tmp_path / "shot.png"
    run = subprocess.run(
        [
            *_chromium_args(exe, tmp_path / "p2"),
            f"--screenshot={shot}",
            "--window-size=1280,3000",
            out.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert run.returncode == 0 and shot.exists(), run.stderr[-2000:]
    pixels = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert pixels.shape[:2] == (3000, 1280)
    assert pixels.std() > 20  # not a blank page
    # viridis yellow-green and purple of the ratio quick look are on screen (figures painted)
    saturated = (pixels.max(axis=2) - pixels.min(axis=2)) > 80
    assert saturated.mean() > 0.02
    shutil.rmtree(tmp_path / "p1", ignore_errors=True)
    shutil.rmtree(tmp_path / "p2", ignore_errors=True)
