"""The scene report: one self-contained HTML page whose figures really render (headless
Chromium), whose numbers are the operations' own, and which degrades to notes, not crashes."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import threading

import numpy as np
import pytest
import rasterio

from geoboresight import report_file
from geoboresight.algorithms import registry
from geoboresight.algorithms.report import REPORT
from geoboresight.errors import Cancelled
from geoboresight.io import quiet_georef
from geoboresight.progress import Progress

CHROMIUM = ("/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome")
SECTIONS = ("Boresight ratio and statistics", "Shadow", "Relative DEM", "Anomaly detection")


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    from geoboresight.io.scene import write_scene
    from geoboresight.simulate import simulate_scene

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
    result = REPORT(
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
    assert "Parameters used" in text and "ratio bands" in text
    assert "numerator_nm" not in text and "denominator_nm" not in text  # former names


def test_report_shows_the_shadow_map_with_true_captions(full_report):
    out, products, _ = full_report
    text = out.read_text(encoding="utf-8")
    assert (products / "shadow_map.tif").exists() and "Shadow map" in text
    assert "class 1 (maroon) 80–100 %" in text  # class 1 is the deepest shadow
    assert "higher classes are deeper shadow" not in text
    assert "Figure 5B line" in text  # why the paper's line may slope otherwise
    # No path of the report's work folder (a temporary name) in the page.
    assert ".tmp" not in text and str(products) not in text
    # The cluster is called isolated only when shadow-cluster does not warn it is not.
    warned = "not a cluster of its own" in text
    assert ("an isolated shadow cluster" in text) != warned


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
    report_file(str(folder / "vnir.img"), str(folder / "swir.img"), svdd=False, output=str(out))
    text = out.read_text(encoding="utf-8")
    notes = re.findall(r"class='missing'>([^<]*)<", text)
    assert any("Figure 5" in n for n in notes)
    assert any("ROC" in n for n in notes)
    assert any("relative-dem" in n and "height" in n.lower() for n in notes), notes
    assert "<h2>Anomaly detection</h2>" in text and text.count("data:image/png") >= 5
    assert not (tmp_path / "r.html.work").exists()  # intermediate products cleaned up


def test_a_key_an_operation_does_not_know_is_a_bug_that_raises(tmp_path):
    """The report passes each operation its values explicitly: a misspelt or retired key
    raises instead of being dropped (the run's own failures still become notes)."""
    from geoboresight import stats_file
    from geoboresight.report.page import Runner, Section

    section = Section("x", "y")
    run = Runner(str(tmp_path), Progress(), 2)
    with pytest.raises(TypeError, match="numerator_nm"):
        run.run(section, stats_file, "r.tif", output="s.json", numerator_nm=1010.0)
    step = run.run(section, stats_file, str(tmp_path / "none.tif"), output="s.json")
    assert step.result is None and "could not run" in step.error
    assert "could not run" in section.html() and section.steps[0].rows


def test_cancel_leaves_nothing(scene, tmp_path):
    folder, _ = scene
    out = tmp_path / "r.html"
    calls = []

    def cancelled():
        calls.append(1)
        return len(calls) > 3

    with pytest.raises(Cancelled):
        REPORT(
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


def test_report_spec_runs_report_file():
    assert REPORT.operation is report_file and registry()["report"] is REPORT


# ------------------------------------------------------------------ HTML templates
def test_pages_escape_text_and_values():
    from geoboresight.html import page, table
    from geoboresight.report.page import Section, Step

    evil = "<script>alert('x')</script>"
    html = page(evil, table([(evil, evil), ("n", 12345), ("x", float("nan"))], caption=evil))
    assert "<script>" not in html and "&lt;script&gt;" in html
    assert "<td>12,345</td>" in html and "<td>–</td>" in html
    section = Section(evil, evil)
    section.note(evil)
    section.table([(evil, 1.5)], caption=evil)
    section.steps.append(Step("ratio", {"output": "/a/b/" + evil, "flag": True}))
    text = section.html()
    assert "<script>" not in text and text.count("&lt;script&gt;") == 5
    assert "<td>yes</td>" in text  # a flag reads yes/no, not 1/0
    assert "class='missing'" in text and "<details><summary>Parameters used</summary>" in text


def test_stats_page_from_descriptives_and_from_its_json_agree():
    """The stats operation renders a Descriptives, the report the stats JSON: one template,
    the same Table 1."""
    from dataclasses import asdict

    from geoboresight.html import descriptives_html
    from geoboresight.stats import describe

    d = describe(np.random.default_rng(0).gamma(2.0, size=5000))
    a = descriptives_html(d, "ratio", "r.tif, band 1", None)
    b = descriptives_html(json.loads(json.dumps(asdict(d))), "ratio", "r.tif, band 1", None)
    assert a == b
    row = re.search(r"<tr><td class='l'>ratio</td>(.*?)</tr></table>", a).group(1)
    cells = re.findall(r"<td>([^<]*)</td>", row)
    assert len(cells) == 9 and int(cells[0].replace(",", "")) == 5000
    assert float(cells[1]) == pytest.approx(d.mean, abs=1e-4)
    assert "Tests of normality, outliers and percentiles" in a and "percentile 50" in a


# ------------------------------------------------------------------ figures
def test_figures_do_not_load_pyplot_or_switch_the_backend(tmp_path):
    """Figures are plain objects with their own Agg canvas: QGIS keeps its backend."""
    code = (
        "import sys, matplotlib; before = matplotlib.get_backend(); "
        "from geoboresight.figures import histogram_figure; "
        "from geoboresight.io.write import save_figure; "
        f"save_figure(histogram_figure([1, 3, 2], [0, 1, 2, 3], 't', 'x', 1.5, 0.2), {str(tmp_path / 'h.png')!r}); "
        "print('matplotlib.pyplot' in sys.modules, matplotlib.get_backend() == before)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "MPLBACKEND": "svg"},
    )
    assert out.stdout.split() == ["False", "True"]
    assert (tmp_path / "h.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_figure_that_fails_to_render_leaves_the_old_png_and_no_litter(tmp_path):
    from geoboresight.figures import histogram_figure
    from geoboresight.io.write import save_figure

    path = tmp_path / "h.png"
    path.write_bytes(b"old")

    class Broken:
        def savefig(self, target, format):
            with open(target, "wb") as f:
                f.write(b"half a PNG")
            raise RuntimeError("renderer died")

    with pytest.raises(RuntimeError, match="renderer died"):
        save_figure(Broken(), str(path))
    assert path.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.png"]
    assert save_figure(histogram_figure([1, 2], [0, 1, 2], "t", "x"), path) == str(path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_figures_drawn_in_threads_equal_figures_drawn_one_by_one(tmp_path):
    """Processing runs algorithms in worker threads: concurrent figures do not mix."""
    from concurrent.futures import ThreadPoolExecutor

    from geoboresight.figures import histogram_figure
    from geoboresight.io.write import save_figure

    def draw(i):
        rng = np.random.default_rng(i)
        counts, edges = np.histogram(rng.normal(i, 1 + i, 2000), 30)
        path = str(tmp_path / f"{i}_{threading.get_ident()}.png")
        save_figure(histogram_figure(counts, edges, f"figure {i}", "x", i, 1 + i), path)
        with open(path, "rb") as f:
            return f.read()

    serial = [draw(i) for i in range(6)]
    with ThreadPoolExecutor(3) as pool:
        threaded = list(pool.map(draw, range(6)))
    assert threaded == serial


def _cells(page: str) -> list[str]:
    import html

    return [
        " ".join(html.unescape(re.sub(r"<[^>]+>", " ", cell)).split())
        for cell in re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", page, flags=re.S)
    ]


def test_the_parameters_are_in_a_readers_words(full_report, scene):
    """The tables show the files, the ratio's bands in nm and the flight geometry: never the
    repr of an opened dataset, a value class or an array of wavelengths."""
    import geoboresight as gb

    out, _, _ = full_report
    folder, truth = scene
    cells = _cells(out.read_text(encoding="utf-8"))
    repr_like = re.compile(r"array\(|\b[A-Z]\w*\(\w+=|DualSensor|SensorFile|dtype")
    assert not [c for c in cells if repr_like.search(c)]
    assert max(len(c) for c in cells) < 120
    rows = dict(zip(cells[2::2], cells[3::2], strict=False))  # after the table's header
    assert rows["VNIR"] == "vnir.img" and rows["SWIR"] == "swir.img"
    bands = gb.open_dual(str(folder / "vnir.img"), str(folder / "swir.img")).ratio_bands()
    assert rows["ratio bands"] == (
        f"SWIR band {bands.swir_band} ({bands.swir_nm:.1f} nm) / "
        f"VNIR band {bands.vnir_band} ({bands.vnir_nm:.1f} nm)"
    )
    k = abs(truth["disparity_px_per_m"]["along"])
    assert rows["flight geometry"].startswith(f"height factor {k:.4g} px per metre")
    assert rows["image"].startswith("40 lines × 286 pixels")
    # Each step lists the files it read by name.
    assert "vnir.img, swir.img" in cells and "truth_target_abundance.tif" in cells


def test_a_value_is_shown_without_its_repr():
    import geoboresight as gb
    from geoboresight.report.page import _show

    assert _show(np.arange(400.0, 1000.0, 6.0)) == "100 values, 400 to 994"
    assert _show((920.0, 1010.0)) == "920, 1010"
    assert _show(["/data/a.tif", "/data/b.tif"]) == "a.tif, b.tif"
    assert _show(np.float32(2.5)) == 2.5
    assert _show(gb.BandChoice(vnir_nm=922.0)) == (
        "band_mode wavelength, vnir_nm 922.0, swir_nm 1010.0, tolerance_nm 10.0"
    )
