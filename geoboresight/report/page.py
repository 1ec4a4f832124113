"""A self-contained HTML report of one scene: every application of the paper in one page.

The report does no science of its own: it runs the operations (``ratio``, ``stats``, ``shadow-map``,
``shadow-classes``, ``shadow-cluster``, ``shadow-fraction-fit``, ``relative-dem``, ``view-3d``,
``rx``, ``svdd``, ``boresight-indicator``, ``roc``) through their specs, with flat values, as
any face would (:func:`geoboresight.algorithms.execute`: the values are validated and grouped
for the operation, whatever its grouping), and lays out their figures and numbers, with the
parameters each step set beside the operation's defaults. A key an operation does not know is
a bug of the report and raises. Figures are embedded as base64 PNG, so the page is one file
that opens anywhere, offline. A step that cannot run (a missing input such as the sensor
geometry for the DEM, a missing optional package) becomes a note in its section; the other
sections are still written.

The page is the ``report.html`` template (:mod:`geoboresight.html`, autoescaped); the file-level
operation that writes it is :func:`geoboresight.report.scene.report_file`.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import os
import platform
from dataclasses import dataclass, field

import numpy as np

from .._version import __version__
from ..errors import Cancelled, GeoboresightError
from ..figures import new_figure
from ..html import macro, png_data_uri, render
from ..io.write import save_figure
from ..operations._guard import translate_error
from ..progress import Progress


@dataclass
class Step:
    """One operation run for the report: what ran, with the values the report set (beside
    the operation's defaults), and what came out."""

    name: str
    values: dict
    result: dict | None = None
    error: str | None = None

    @property
    def rows(self) -> list[tuple[str, object]]:
        """(parameter, value) rows of the "Parameters used" table (file names without folders)."""
        return [(k, _show(v)) for k, v in self.values.items() if v not in (None, "")]


@dataclass
class Section:
    """One section of the report: a title, an introduction, parts (figures, notes, tables, the
    statistics) and the steps whose parameters it lists. Rendered by the ``section`` macro
    of ``templates/macros.html``."""

    title: str
    intro: str
    parts: list[dict] = field(default_factory=list)
    steps: list[Step] = field(default_factory=list)

    def figure(self, png: str | None, caption: str) -> None:
        """A PNG figure (embedded) with its caption; nothing if the PNG was not made."""
        if png and os.path.exists(png):
            self.parts.append({"kind": "figure", "src": png_data_uri(png), "caption": caption})

    def note(self, text: str) -> None:
        """Why something is missing from the section."""
        self.parts.append({"kind": "note", "text": text})

    def remark(self, text: str) -> None:
        """What a step that ran warned about its result (a caveat, not a gap)."""
        self.parts.append({"kind": "remark", "text": text})

    def table(self, rows, caption: str, header=("", "value")) -> None:
        """A two-column table of (label, value)."""
        self.parts.append(
            {"kind": "table", "rows": list(rows), "caption": caption, "header": header}
        )

    def descriptives(self, stats: dict, histogram: str | None = None) -> None:
        """Table 1 and the rest of a ``stats`` JSON (with its Figure 3 histogram PNG)."""
        self.parts.append(
            {
                "kind": "descriptives",
                "d": stats,
                "title": stats["band_description"],
                "source": f"{os.path.basename(stats['input'])}, band {stats['band']}",
                "histogram": png_data_uri(histogram)
                if histogram and os.path.exists(histogram)
                else None,
            }
        )

    def html(self) -> str:
        """The section as HTML."""
        return str(macro("section")(self))


def _show(value):
    """A parameter's value as a reader wants it: files by name, a list of numbers by its count
    and range, a yes or no; never the repr of an array or of an opened dataset."""
    if value is None or isinstance(value, bool | int | float | np.number):
        return value.item() if isinstance(value, np.number) else value
    if hasattr(value, "files"):  # an opened dataset (DualSensor): its files
        return ", ".join(os.path.basename(f) for f in value.files)
    if isinstance(value, str | os.PathLike):
        text = os.fspath(value)
        return os.path.basename(text) if os.path.sep in text else text
    if isinstance(value, np.ndarray) or (
        isinstance(value, list | tuple) and value and all(isinstance(v, int | float) for v in value)
    ):
        numbers = np.asarray(value, dtype=float).ravel()
        if numbers.size <= 4:
            return ", ".join(f"{v:g}" for v in numbers)
        return f"{numbers.size} values, {numbers.min():g} to {numbers.max():g}"
    if isinstance(value, list | tuple):
        return ", ".join(str(_show(v)) for v in value)
    if dataclasses.is_dataclass(value):
        return ", ".join(
            f"{f.name} {_show(getattr(value, f.name))}"
            for f in dataclasses.fields(value)
            if getattr(value, f.name) is not None
        )
    text = str(value)
    return text if len(text) <= 80 else type(value).__name__


def _nm_range(sensor) -> str:
    wl = np.asarray(sensor.wavelengths, dtype=float)
    return f"{len(sensor.bands)} bands, {wl.min():.0f}–{wl.max():.0f} nm"


def _geometry_text(geometry) -> str:
    """The flight geometry the relative DEM used, in words and units."""
    parts = []
    if geometry.height_factor is not None:
        parts.append(f"height factor {geometry.height_factor:.4g} px per metre")
    if geometry.squint_deg is not None:
        parts.append(f"squint {geometry.squint_deg:g}°")
    if geometry.flying_height is not None:
        parts.append(f"flying height {geometry.flying_height:g} m")
    if geometry.ifov_mrad is not None:
        parts.append(f"IFOV {geometry.ifov_mrad:g} mrad")
    if not parts:
        return "not given (the relative DEM says what it needs)"
    axis = f"parallax {geometry.parallax_axis}-track" + (
        ", inverted" if geometry.invert_parallax else ""
    )
    return ", ".join([*parts, axis])


def report_parameters(values: dict) -> list[tuple[str, object]]:
    """The "Report parameters" table: the files read, the image's size and geometry, the
    ratio's two bands in nm, the flight geometry and the optional inputs, in a reader's
    words (``values`` as :func:`build_report` takes them)."""
    dual = values["dual"]
    rows: list[tuple[str, object]] = []
    if dual.merged or dual.vnir.path == dual.swir.path:
        rows.append(("VNIR + SWIR", f"{os.path.basename(dual.vnir.path)}"))
        rows.append(("seam", f"{values['layout'].seam_nm:g} nm"))
    else:
        rows.append(("VNIR", os.path.basename(dual.vnir.path)))
        rows.append(("SWIR", os.path.basename(dual.swir.path)))
    rows.append(("VNIR bands", _nm_range(dual.vnir)))
    rows.append(("SWIR bands", _nm_range(dual.swir)))
    for key in ("vnir_wavelengths", "swir_wavelengths"):
        if getattr(values["layout"], key, None):
            rows.append((key.replace("_", " "), _show(getattr(values["layout"], key))))
    grid = dual.grid
    where = "raw sensor geometry (no CRS)"
    if grid.crs is not None and grid.transform is not None:
        epsg = grid.crs.to_epsg()
        crs = f"EPSG:{epsg}" if epsg else grid.crs.to_string()
        crs = crs if len(crs) <= 40 else "a CRS without an EPSG code"
        where = f"{crs}, pixels {abs(grid.transform.a):g} × {abs(grid.transform.e):g}"
    rows.append(("image", f"{grid.height} lines × {grid.width} pixels, {where}"))
    try:
        b = dual.ratio_bands(values["bands"])
        rows.append(
            (
                "ratio bands",
                f"SWIR band {b.swir_band} ({b.swir_nm:.1f} nm) / VNIR band {b.vnir_band} "
                f"({b.vnir_nm:.1f} nm)",
            )
        )
    except GeoboresightError as exc:
        rows.append(("ratio bands", f"not found: {exc}"))
    rows.append(("flight geometry", _geometry_text(values["geometry"])))
    for key, label in (
        ("shadow_truth", "shadow truth"),
        ("target_truth", "target truth"),
        ("cloud_mask", "cloud mask"),
    ):
        if values.get(key):
            rows.append((label, _show(values[key])))
    rows.append(("detectors", "RX, SVDD" if values.get("svdd") else "RX"))
    return rows


class Runner:
    """Runs file-level operations into a work folder; failures become notes, not crashes."""

    def __init__(self, work_dir: str, progress: Progress, n_steps: int):
        self.work_dir = work_dir
        self.progress = progress
        self.n_steps = max(1, n_steps)
        self.done = 0

    def path(self, name: str) -> str:
        return os.path.join(self.work_dir, name)

    def run(self, section: Section, function, *args, **kwargs) -> Step:
        """Run the file-level operation ``function`` (e.g. :func:`.ratio.ratio_file`) with
        these arguments; the page shows the keyword arguments that differ from its defaults."""
        name = function.__name__.removesuffix("_file").replace("_", "-")
        signature = inspect.signature(function)
        defaults = {k: p.default for k, p in signature.parameters.items()}
        # The inputs given by position, under their names (the files the step read).
        shown = {k: v for k, v in signature.bind_partial(*args).arguments.items() if v is not None}
        for k, v in kwargs.items():
            if v is None or v == defaults.get(k):
                continue
            if dataclasses.is_dataclass(v):  # a value: its members that differ
                base = defaults.get(k)
                shown.update(
                    {
                        f.name: getattr(v, f.name)
                        for f in dataclasses.fields(v)
                        if base is None or getattr(v, f.name) != getattr(base, f.name, None)
                    }
                )
            else:
                shown[k] = v
        step = Step(name, shown)
        sub = self.progress.sub(self.done / self.n_steps, (self.done + 1) / self.n_steps)
        self.done = min(self.done + 1, self.n_steps)
        sub.info(f"report: running {name}")
        try:
            # The report's own spec has checked the values the steps share; each step writes
            # into the work folder, which is the report's own.
            step.result = function(*args, **kwargs, progress=sub)
        except Cancelled:
            raise
        except (GeoboresightError, ImportError, OSError, MemoryError) as exc:
            if isinstance(exc, OSError | MemoryError):
                exc = translate_error(exc, [], [], list(signature.parameters))
            step.error = f"'{name}' could not run: {exc}"
        section.steps.append(step)
        if step.error:
            section.note(step.error)
        sub.update(1.0)
        return step


#: Caption of a Table 2 class raster: class 1 is the deepest shadow (80–100 %).
CLASS_CAPTION = (
    "{what}, in Table 2's colours: class 1 (maroon) 80–100 % of the pixel in shadow, class 2 "
    "(magenta) 50–80 %, class 3 (cyan) 20–50 %, class 4 (yellow) 10–20 %; class 0 no shadow. Lower class numbers are "
    "deeper shadow."
)

#: Longest side (pixels) of the rasters drawn in the report's figures.
QUICKLOOK_PX = 2000


def raster_figure(path: str, title: str, label: str, out_png: str) -> str:
    """A quick look of band 1: classes in their own colour table, values on a 2–98 % stretch."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    from ..figures import decimated_shape
    from ..io import open_raster, read_masked

    with open_raster(path) as src:
        height, width = src.height, src.width
        # A page figure shows at most ~1,000 rows: a whole flight line is read decimated
        # (from its overviews), not in full.
        _, shape = decimated_shape(height, width, QUICKLOOK_PX)
        values, valid = read_masked(src, 1, out_shape=shape)
        try:
            colormap = src.colormap(1)
        except ValueError:
            colormap = None
    fig, ax = new_figure(width=min(9.0, 2.0 + 6.0 * width / max(height, width)) + 1.5, height=4.8)
    ax.grid(False)
    data = np.ma.array(values, mask=~valid)
    if colormap:
        codes = sorted(int(c) for c in np.unique(values[valid])) or [0]
        top = max(codes) + 1
        colours = [np.array(colormap.get(i, (0, 0, 0, 0))) / 255.0 for i in range(top)]
        image = ax.imshow(
            data,
            cmap=ListedColormap(colours),
            norm=BoundaryNorm(np.arange(top + 1) - 0.5, top),
            interpolation="nearest",
            aspect="auto",
            extent=(0, width, height, 0),
        )
        fig.colorbar(image, ax=ax, ticks=codes, label=label)
    else:
        lo, hi = np.percentile(values[valid], [2, 98]) if valid.any() else (0.0, 1.0)
        image = ax.imshow(
            data,
            cmap="viridis",
            vmin=lo,
            vmax=hi,
            interpolation="nearest",
            aspect="auto",
            extent=(0, width, height, 0),
        )
        fig.colorbar(image, ax=ax, label=label)
    ax.set_title(title)
    ax.set_xlabel("across-track pixel")
    ax.set_ylabel("along-track line")
    return save_figure(fig, out_png)


def build_report(values: dict, work_dir: str, progress: Progress) -> str:
    """Run the operations for the scene described by ``values`` (the ``report`` operation's
    arguments: ``dual`` the opened dataset, ``layout``, ``bands``, ``geometry``, the truths,
    the cloud mask, ``svdd``) with their products in ``work_dir``; the whole HTML page."""
    from ..operations.anomaly import rx_file, svdd_file

    detectors = [rx_file, svdd_file] if values.get("svdd") else [rx_file]
    run = Runner(work_dir, progress, n_steps=11 + len(detectors))
    ratio_section, ratio_path = _ratio_section(run, values)
    sections = [
        ratio_section,
        _shadow_section(run, values, ratio_path),
        _dem_section(run, values),
        _anomaly_section(run, values, ratio_path, detectors),
    ]
    progress.update(1.0, "report")
    return render(
        "report.html",
        title="geoboresight scene report",
        parameters=report_parameters(values),
        software=[
            ("geoboresight", __version__),
            ("Python", platform.python_version()),
            ("NumPy", np.__version__),
        ],
        sections=sections,
    )


def _numbers(result: dict) -> list[tuple[str, object]]:
    """The numbers among an operation's results, as table rows."""
    return [
        (k, v) for k, v in result.items() if isinstance(v, int | float) and not isinstance(v, bool)
    ]


def ratio_values(dual) -> str:
    """Whether the ratio divides radiances or raw DN, in a sentence."""
    units = {dual.vnir.units, dual.swir.units}
    kind = getattr(dual.product, "kind", "")
    if "DN" not in units:
        return f"The ratio divides radiances ({' and '.join(sorted(units))})."
    if kind in ("Specim raw ENVI", "HySpex"):
        return (
            "The ratio divides raw DN: each detector's dark level, gain and integration time are "
            "in it, so it compares with other flights only in radiance (give the captures' "
            "calibration: vnir_calibration, swir_calibration)."
        )
    return "The ratio divides the files' values as they are (no sensor calibration applied)."


def _ratio_section(run: Runner, values: dict) -> tuple[Section, str | None]:
    """Ratio and statistics (Eq. 3, Table 1, Figure 3); the section and the ratio's path (None
    when it could not be computed)."""
    from ..operations.ratio import ratio_file
    from ..operations.stats import stats_file

    s = Section(
        "Boresight ratio and statistics",
        "The boresight band ratio b(1010 nm)/b(920 nm) (Eq. 3) and its descriptive statistics as "
        "SPSS reports them (Table 1), with the histogram (Figure 3).",
    )
    ratio = run.run(
        s, ratio_file, values["dual"], output=run.path("ratio.tif"), bands=values["bands"]
    )
    ratio_path = ratio.result["output"] if ratio.result else None
    s.remark(ratio_values(values["dual"]))
    if ratio_path:
        s.figure(
            raster_figure(ratio_path, "Boresight ratio", "b(1010)/b(920)", run.path("ratio.png")),
            "The boresight band ratio.",
        )
        stats = run.run(
            s,
            stats_file,
            ratio_path,
            output=run.path("stats.json"),
            html=run.path("stats.html"),
            histogram=run.path("histogram.png"),
        )
        if stats.result:
            with open(stats.result["output"], encoding="utf-8") as f:
                s.descriptives(json.load(f), stats.result.get("histogram"))
    return s, ratio_path


def _shadow_section(run: Runner, values: dict, ratio_path: str | None) -> Section:
    """Shadow (§3.1, Table 2, Figures 4 and 5): the shadow map, then what the ratio gives."""
    from ..operations.shadow_map import shadow_map_file

    s = Section(
        "Shadow",
        "The shadow product (shadow-map): a shadow mask and Table 2's four shadow-fraction "
        "classes, read relative to this scene's sunlit ratio. Table 2's fixed ratio thresholds "
        "(shadow-classes) are shown only where they can mean what Table 2 says; the shadow "
        "component in the ratio against 941 nm scatter (Figure 4) and, with ground truth, the "
        "linear shadow-fraction model (Figure 5).",
    )
    mapped = run.run(
        s,
        shadow_map_file,
        values["dual"],
        output=run.path("shadow_map.tif"),
        mask=run.path("shadow_map_mask.tif"),
        layout=values["layout"],
        bands=values["bands"],
    )
    if mapped.result:
        s.figure(
            raster_figure(
                mapped.result["output"],
                "Shadow map (Table 2 classes on the scene's sunlit ratio)",
                "class",
                run.path("shadow_map.png"),
            ),
            CLASS_CAPTION.format(what="Shadow map"),
        )
        for w in mapped.result.get("warnings", []):
            s.remark(f"shadow-map: {w}")
    if ratio_path:
        _ratio_shadow(run, s, values, ratio_path)
    else:
        s.note("The shadow classes need the boresight ratio, which could not be computed.")
    return s


def _ratio_shadow(run: Runner, s: Section, values: dict, ratio_path: str) -> None:
    """Table 2's fixed thresholds, the Figure 4 cluster and the Figure 5 fit, on the ratio."""
    from ..operations.shadow import NirBand, shadow_classes_file, shadow_cluster_file

    classes = run.run(s, shadow_classes_file, ratio_path, output=run.path("shadow_classes.tif"))
    if classes.result and classes.result.get("warnings"):
        s.remark(
            "Table 2's fixed ratio thresholds are not shown: on this scene they cannot mean "
            "what Table 2 says (" + "; ".join(classes.result["warnings"]) + "). The shadow "
            "map above reads the same classes relative to the scene's sunlit ratio."
        )
    elif classes.result:
        s.figure(
            raster_figure(
                classes.result["output"],
                "Shadow classes, Table 2's fixed thresholds",
                "class",
                run.path("classes.png"),
            ),
            CLASS_CAPTION.format(what="Table 2's fixed ratio thresholds"),
        )
    cluster = run.run(
        s,
        shadow_cluster_file,
        ratio_path,
        values["dual"].vnir.path,
        output=run.path("shadow_cluster.tif"),
        plot=run.path("scatter.png"),
        nir=NirBand(vnir_wavelengths=values["layout"].vnir_wavelengths),
    )
    if cluster.result:
        warnings = cluster.result.get("warnings") or []
        s.figure(
            cluster.result.get("plot"),
            "Ratio against the 941 nm band with the fitted shadow component (Figure 4)"
            + (
                ": on this scene it is not a cluster of its own (see the note); the "
                "shadow map is the shadow product."
                if warnings
                else ": an isolated shadow cluster, as in the paper."
            ),
        )
        for w in warnings:
            s.remark(f"shadow-cluster: {w}")
    _fraction_fit(run, s, values, ratio_path)


def _fraction_fit(run: Runner, s: Section, values: dict, ratio_path: str) -> None:
    """Figure 5: the ratio against the true shadow fraction, when the truth is given."""
    from ..operations.shadow import shadow_fraction_fit_file

    if not values.get("shadow_truth"):
        s.note("No ground-truth shadow fraction given: the Figure 5 model fit is left out.")
        return
    fit = run.run(
        s,
        shadow_fraction_fit_file,
        ratio_path,
        values["shadow_truth"],
        report=run.path("fit.json"),
        plot=run.path("fit.png"),
    )
    if fit.result:
        s.figure(
            fit.result.get("plot"),
            "Boresight ratio against the true shadow fraction, with the line fitted on "
            "this scene (Figure 5). The paper's Figure 5B line (ratio = −0.74 · "
            "fraction + 1.31) is drawn for reference only: it was fitted on the ratio "
            "values of the paper's figure (0.57–1.31, falling with shadow), not on DN "
            "ratios like this scene's (about 2–4, rising with shadow), so its level and "
            "slope differ; what carries over is that the ratio is linear in the shadow "
            "fraction (compare the R²).",
        )


def _dem_section(run: Runner, values: dict) -> Section:
    """Relative DEM (§3.2, Figure 9)."""
    from ..operations.dem import relative_dem_file, view_3d_file

    s = Section(
        "Relative DEM",
        "Heights relative to the lowest region, from the VNIR/SWIR disparity, kriged onto a "
        "surface, and the image draped on it (Figure 9). The height precision is "
        "σ_h = σ_d·GSD / tan θ: a small squint makes relief nearly invisible, and the product "
        "says so.",
    )
    dual = values["dual"]
    dem = run.run(
        s,
        relative_dem_file,
        dual,
        None,
        values["cloud_mask"],
        output=run.path("relative_dem.tif"),
        report=run.path("dem.json"),
        geometry=values["geometry"],
    )
    if dem.result:
        rows = _numbers(dem.result)
        if rows:
            s.table(rows, caption="Relative DEM")
        view = run.run(s, view_3d_file, dem.result["output"], dual, output=run.path("view3d.png"))
        if view.result:
            s.figure(view.result["output"], "The scene draped on the relative DEM (Figure 9).")
    return s


def _anomaly_section(run: Runner, values: dict, ratio_path: str | None, detectors) -> Section:
    """Anomaly (§3.3, Figure 12): the boresight indicator against ``detectors``, and ROC."""
    from ..operations.anomaly import boresight_indicator_file

    s = Section(
        "Anomaly detection",
        "The boresight ratio as a sub-pixel anomaly indicator, against global RX"
        + (" and SVDD" if len(detectors) > 1 else "")
        + "; with a truth raster, ROC curves (probability of detection against false alarm, Figure 12).",
    )
    scores, names = [], []
    if ratio_path:
        ind = run.run(s, boresight_indicator_file, ratio_path, output=run.path("indicator.tif"))
        if ind.result:
            scores.append(ind.result["output"])
            names.append("boresight ratio")
    for det in detectors:
        label = det.__name__.removesuffix("_file")
        r = run.run(s, det, values["dual"], output=run.path(f"{label}.tif"))
        if r.result:
            scores.append(r.result["output"])
            names.append(label.upper())
    if scores and values.get("target_truth"):
        _roc(run, s, scores, names, values["target_truth"])
    elif scores:
        s.note(
            "No target truth raster given: ROC curves need one (e.g. truth_target_abundance.tif of a simulated scene)."
        )
    for path, name in zip(scores, names, strict=True):
        s.figure(
            raster_figure(path, f"{name} score", "score", path + ".png"), f"{name} anomaly score."
        )
    return s


def _roc(run: Runner, s: Section, scores: list, names: list, truth: str) -> None:
    from ..operations.anomaly import roc_file

    roc = run.run(
        s,
        roc_file,
        scores,
        truth,
        output=run.path("roc.png"),
        csv=run.path("roc.csv"),
        names=",".join(names),
    )
    if roc.result:
        s.figure(roc.result["output"], "ROC curves of the detectors (Figure 12).")
        rows = _numbers(roc.result)
        if rows:
            s.table(rows, caption="Detection at the chosen false-alarm rate")


__all__ = ["Runner", "Section", "Step", "build_report", "raster_figure", "report_parameters"]
