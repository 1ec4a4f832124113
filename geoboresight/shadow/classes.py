"""Shadow-fraction classes of the boresight ratio (paper §3.1, Table 2).

Table 2 of Brook & Ben-Dor (2011) maps boresight ratio intervals to ground-truth shadow
fractions::

    class  ratio      shadow fraction  colour (Figures 6–7)
    1      3.4–4.0    80–100 %         maroon
    2      2.5–3.4    50–80 %          magenta
    3      2.1–2.5    20–50 %          cyan
    4      1.9–2.1    10–20 %          yellow

The paper's table stops at 4, but the ratio only grows with shadow (the deepest shadow has the
highest ratio), so :data:`TABLE2` makes class 1 open-ended (3.4–∞): a ratio above 4 is deep
shadow, not "no shadow".

Class 0 is "no shadow" (a ratio outside every interval); :data:`NODATA_CLASS` (255) marks
pixels with no valid ratio. An interval is ``min ≤ ratio < max``; the interval with the highest
``max`` also includes its ``max``. Write ``inf`` as a ``max`` to make the top class open-ended.

Table 2's thresholds are absolute DN ratios of the AISA-Dual: :func:`table_warnings` says when
they are meaningless for a scene (the ratio's bands are not 1,010/920 nm, or the scene's sunlit
ratio falls inside a shadow class), and :func:`scale_table` scales them to a scene's sunlit
ratio (the shadow map of :mod:`geoboresight.shadow.darkness`).

A class table is a CSV (or JSON list of objects) with the columns::

    class,min,max,fraction_min,fraction_max,name,colour

``class`` 1–254, ``min < max`` (ratios), fractions in 0–1, ``colour`` as ``#rrggbb``. Rows must
be listed in ratio order (all ascending or all descending) and intervals must not overlap
(touching ends are fine). Reading and writing such files is :mod:`geoboresight.operations._shadow_tables`'s job;
this module validates the rows (:func:`class_from_row`, :func:`validate_classes`) and applies the
table to arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError

#: Class value of pixels with no valid ratio (the class raster's nodata).
NODATA_CLASS = 255
#: Class value of valid pixels outside every interval.
NO_SHADOW = 0
COLUMNS = ("class", "min", "max", "fraction_min", "fraction_max", "name", "colour")
#: The shadow mask holds the classes whose shadow fraction starts at or above this.
MASK_FRACTION = 0.5
#: Values of a binary shadow mask.
MASK_SHADOW, MASK_NOT_SHADOW, MASK_NODATA = 1, 0, NODATA_CLASS
#: Colour table and category names of a binary shadow mask (shadow maroon, as class 1).
MASK_COLORMAP = {
    MASK_NOT_SHADOW: (255, 255, 255, 0),
    MASK_SHADOW: (128, 0, 0, 255),
    MASK_NODATA: (0, 0, 0, 0),
}
MASK_CATEGORIES = {MASK_NOT_SHADOW: "not shadow", MASK_SHADOW: "shadow"}


@dataclass(frozen=True)
class ShadowClass:
    """One row of a class table: ratio interval → shadow-fraction interval."""

    id: int
    min: float
    max: float
    fraction_min: float
    fraction_max: float
    name: str
    colour: tuple[int, int, int]

    @property
    def hex(self) -> str:
        return "#{:02x}{:02x}{:02x}".format(*self.colour)


@dataclass(frozen=True)
class ClassTable:
    """A validated, ordered set of shadow classes (see :func:`validate_classes`)."""

    classes: tuple[ShadowClass, ...]

    def classify(self, ratio: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
        """uint8 class of each pixel: class id, 0 = no shadow, 255 = no valid ratio."""
        ratio = np.asarray(ratio)
        ok = np.isfinite(ratio) if valid is None else (np.asarray(valid, bool) & np.isfinite(ratio))
        out = np.full(ratio.shape, NO_SHADOW, dtype=np.uint8)
        top = max(c.max for c in self.classes)
        with np.errstate(invalid="ignore"):
            for c in self.classes:
                inside = (ratio >= c.min) & (ratio < c.max)
                if c.max == top:
                    inside |= ratio == c.max
                out[inside & ok] = c.id
        out[~ok] = NODATA_CLASS
        return out

    def shadow_ids(self, min_fraction: float) -> tuple[int, ...]:
        """Ids of classes whose shadow fraction is at least ``min_fraction`` (their lower end)."""
        return tuple(c.id for c in self.classes if c.fraction_min >= min_fraction - 1e-9)

    def mask(self, classes: np.ndarray, min_fraction: float = MASK_FRACTION) -> np.ndarray:
        """uint8 binary shadow mask from a class raster: 1 shadow, 0 not, 255 nodata."""
        ids = self.shadow_ids(min_fraction)
        out = np.isin(classes, ids).astype(np.uint8)
        out[classes == NODATA_CLASS] = MASK_NODATA
        return out

    def colormap(self) -> dict[int, tuple[int, int, int, int]]:
        """GDAL colour table: class colours, 0 transparent white, nodata transparent."""
        cmap = {i: (0, 0, 0, 0) for i in range(256)}
        cmap[NO_SHADOW] = (255, 255, 255, 0)
        for c in self.classes:
            cmap[c.id] = (*c.colour, 255)
        return cmap

    def names(self) -> dict[int, str]:
        """Category name of each class value (0 and the classes)."""
        names = {NO_SHADOW: "no shadow"}
        for c in self.classes:
            names[c.id] = c.name
        return names

    def describe(self) -> str:
        """One line per class, for logs and band metadata."""
        return "; ".join(
            f"{c.id}: ratio {format_ratio(c.min)}–{format_ratio(c.max)} → {fraction_text(c)}"
            for c in self.classes
        )


def fraction_text(c) -> str:
    """ "80–100 % shadow", with the class's name after it only when the name says something
    else (one name per class, not "80–100 % shadow (80-100 % shadow)")."""
    text = f"{c.fraction_min * 100:g}–{c.fraction_max * 100:g} % shadow"
    same = c.name.replace("–", "-").split() == text.replace("–", "-").split()
    return text if same else f"{text} ({c.name})"


def format_ratio(x: float) -> str:
    """A ratio bound as written in a class table: ``inf`` or the shortest ``%g`` form."""
    return "inf" if math.isinf(x) else f"{x:g}"


#: Table 2 of the paper, with the colours of Figures 6–7; class 1 open-ended (3.4–∞).
TABLE2 = (
    ShadowClass(1, 3.4, math.inf, 0.8, 1.0, "80-100 % shadow", (128, 0, 0)),
    ShadowClass(2, 2.5, 3.4, 0.5, 0.8, "50-80 % shadow", (255, 0, 255)),
    ShadowClass(3, 2.1, 2.5, 0.2, 0.5, "20-50 % shadow", (0, 255, 255)),
    ShadowClass(4, 1.9, 2.1, 0.1, 0.2, "10-20 % shadow", (255, 255, 0)),
)


def default_table() -> ClassTable:
    """Table 2 of Brook & Ben-Dor (2011), class 1 open-ended."""
    return validate_classes(TABLE2)


#: The band centres (nm) of the ratio Table 2 was found on (Eq. 3).
TABLE2_VNIR_NM, TABLE2_SWIR_NM = 920.0, 1010.0
#: Largest distance (nm) of the ratio's bands from Table 2's before its thresholds are in doubt.
TABLE2_TOLERANCE_NM = 10.0


#: Log-ratio histogram bins for the scene's most common ratio (ratio 0.05–20, 1 % steps).
MODE_BINS = np.linspace(math.log(0.05), math.log(20.0), 601)


def ratio_histogram(ratio: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
    """Counts of the valid, positive ratios in :data:`MODE_BINS` (log ratio); strips add up."""
    r = np.asarray(ratio, np.float64)
    ok = np.isfinite(r) & (r > 0)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    return np.histogram(np.log(r[ok]), bins=MODE_BINS)[0]


def histogram_mode(counts: np.ndarray) -> float:
    """The ratio at the peak of :func:`ratio_histogram`'s counts (smoothed over 5 bins);
    NaN when empty."""
    c = np.asarray(counts, np.float64)
    if c.sum() == 0:
        return float("nan")
    smooth = np.convolve(c, np.ones(5) / 5, mode="same")
    i = int(np.argmax(smooth))
    return float(math.exp(0.5 * (MODE_BINS[i] + MODE_BINS[i + 1])))


def scale_table(table: ClassTable, factor: float) -> ClassTable:
    """The class table with every ratio bound multiplied by ``factor`` (> 0; ∞ stays ∞).

    The shadow map uses it to read Table 2's intervals relative to a scene's sunlit ratio
    instead of as absolute numbers (``factor`` = scene sunlit ratio / the paper's).

    References
    ----------
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
    (§3.1, Table 2).
    """
    if not (math.isfinite(factor) and factor > 0):
        raise ParameterError(f"class table scale {factor!r} must be a positive number")
    return validate_classes(
        tuple(
            ShadowClass(
                c.id,
                c.min * factor,
                c.max * factor,
                c.fraction_min,
                c.fraction_max,
                c.name,
                c.colour,
            )
            for c in table.classes
        ),
        "scaled class table",
    )


def table_warnings(
    table: ClassTable,
    sunlit_ratio: float | None = None,
    *,
    vnir_nm: float | None = None,
    swir_nm: float | None = None,
) -> list[str]:
    """Reasons why a table's fixed ratio thresholds are meaningless for a scene (may be empty).

    Parameters
    ----------
    table : ClassTable
    sunlit_ratio : float, optional
        The scene's sunlit ratio (the mode of its ratio histogram): when it falls inside a
        shadow class, sunlit ground would be labelled shadow.
    vnir_nm, swir_nm : float, optional
        Centres of the ratio's bands: Table 2 was found on b(1,010 nm) / b(920 nm).

    References
    ----------
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
    (Eq. 3, Table 2).
    """
    out = []
    if vnir_nm is not None and swir_nm is not None:
        if (
            abs(vnir_nm - TABLE2_VNIR_NM) > TABLE2_TOLERANCE_NM
            or abs(swir_nm - TABLE2_SWIR_NM) > TABLE2_TOLERANCE_NM
        ):
            out.append(
                f"the ratio uses {swir_nm:g}/{vnir_nm:g} nm, but Table 2's thresholds were found "
                f"on {TABLE2_SWIR_NM:g}/{TABLE2_VNIR_NM:g} nm: they do not apply; use "
                "'shadow-map' or your own class table"
            )
    if sunlit_ratio is not None and math.isfinite(sunlit_ratio):
        hit = [c for c in table.classes if c.min <= sunlit_ratio < c.max]
        if hit:
            c = hit[0]
            out.append(
                f"the scene's most common ratio {sunlit_ratio:.3g} (its sunlit ground) falls in "
                f"class {c.id} ({format_ratio(c.min)}–{format_ratio(c.max)}, {c.name}): the "
                "fixed thresholds are meaningless for this scene (raw DN carry each "
                "instrument's dark offset); use 'shadow-map', which calibrates the classes to "
                "the scene, or your own class table"
            )
    return out


def validate_classes(classes, source: str = "class table") -> ClassTable:
    """Check a sequence of :class:`ShadowClass`; raise ParameterError naming the bad row."""
    classes = tuple(classes)
    if not classes:
        raise ParameterError(f"{source}: no classes; give at least one row")
    ids = [c.id for c in classes]
    for c in classes:
        where = f"{source}, class {c.id}"
        if not (1 <= c.id <= 254):
            raise ParameterError(f"{where}: class ids must be 1–254 (0 = no shadow, 255 = nodata)")
        if math.isnan(c.min) or math.isnan(c.max):
            raise ParameterError(f"{where}: min and max must be numbers")
        if not c.min < c.max:
            raise ParameterError(
                f"{where}: interval {format_ratio(c.min)}–{format_ratio(c.max)} is unordered or empty; "
                "min must be below max"
            )
        if not (0 <= c.fraction_min <= c.fraction_max <= 1):
            raise ParameterError(
                f"{where}: shadow fractions {c.fraction_min:g}–{c.fraction_max:g} must satisfy "
                "0 ≤ fraction_min ≤ fraction_max ≤ 1 (fractions, not percent)"
            )
    if len(set(ids)) != len(ids):
        raise ParameterError(f"{source}: class ids {ids} repeat; each class needs its own id")
    mins = [c.min for c in classes]
    ascending = all(a < b for a, b in zip(mins, mins[1:], strict=False))
    descending = all(a > b for a, b in zip(mins, mins[1:], strict=False))
    if not (ascending or descending):
        raise ParameterError(
            f"{source}: rows are not in ratio order (mins {', '.join(map(format_ratio, mins))}); "
            "list the intervals from highest to lowest ratio (as Table 2) or lowest to highest"
        )
    ordered = sorted(classes, key=lambda c: c.min)
    for lo, hi in zip(ordered, ordered[1:], strict=False):
        if hi.min < lo.max:
            raise ParameterError(
                f"{source}: class {lo.id} ({format_ratio(lo.min)}–{format_ratio(lo.max)}) overlaps class "
                f"{hi.id} ({format_ratio(hi.min)}–{format_ratio(hi.max)}); intervals may touch but not overlap"
            )
    return ClassTable(classes)


def parse_colour(text: str, where: str) -> tuple[int, int, int]:
    t = str(text).strip()
    if t.startswith("#") and len(t) == 7:
        try:
            return (int(t[1:3], 16), int(t[3:5], 16), int(t[5:7], 16))
        except ValueError:
            pass
    parts = [p for p in t.replace(";", ",").split(",") if p.strip()]
    if len(parts) == 3:
        try:
            rgb = tuple(int(p) for p in parts)
            if all(0 <= v <= 255 for v in rgb):
                return rgb  # type: ignore[return-value]
        except ValueError:
            pass
    raise ParameterError(f"{where}: colour {text!r} is not '#rrggbb' or 'r,g,b' (0–255)")


def class_from_row(row: dict, where: str) -> ShadowClass:
    """One class from a table row (column name → text or number); ``where`` names the row in
    errors. Empty fractions default to 0–1, an empty colour to grey."""
    missing = [k for k in ("class", "min", "max") if str(row.get(k, "")).strip() == ""]
    if missing:
        raise ParameterError(
            f"{where}: missing {', '.join(missing)} (columns: {', '.join(COLUMNS)})"
        )

    def num(key, default=None):
        v = row.get(key)
        if v is None or str(v).strip() == "":
            if default is None:
                raise ParameterError(f"{where}: column '{key}' is empty")
            return default
        try:
            return float(v)
        except (TypeError, ValueError):
            raise ParameterError(f"{where}: column '{key}' = {v!r} is not a number") from None

    try:
        cid = int(str(row["class"]).strip().lstrip("#"))
    except ValueError:
        raise ParameterError(f"{where}: class {row['class']!r} is not a whole number") from None
    fmin, fmax = num("fraction_min", 0.0), num("fraction_max", 1.0)
    if fmax > 1.0 and fmax <= 100.0:
        raise ParameterError(
            f"{where}: fractions must be 0–1 (got {fmin:g}–{fmax:g}; write 0.8 for 80 %)"
        )
    colour = row.get("colour") or row.get("color") or "#808080"
    return ShadowClass(
        cid,
        num("min"),
        num("max"),
        fmin,
        fmax,
        str(row.get("name") or f"class {cid}").strip(),
        parse_colour(colour, where),
    )
