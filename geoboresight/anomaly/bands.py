"""Choosing the bands an anomaly detector uses, by wavelength (paper §3.3).

Water-vapour absorption bands (around 1,400 and 1,900 nm) carry almost no ground signal in
airborne data: their noise dominates a covariance matrix and makes RX flag noise. They are
excluded by wavelength range, so the same setting works for any sensor's band set.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError

#: Default exclusion: the 1.4 µm and 1.9 µm water-vapour absorption bands, and beyond 2,450 nm.
WATER_BANDS_NM = "1340-1460,1790-1980,2450-2600"


@dataclass(frozen=True)
class BandSelection:
    """Which bands per-pixel spectral work (RX, SVDD, unmixing) uses, by wavelength: those in
    the ``include_nm`` ranges (every band when empty), less those in the ``exclude_nm`` ranges
    (default: the water-vapour absorption bands), e.g. ``include_nm="400-900,1000-1300"``.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.BandSelection()  # every band but the water-vapour absorptions and the SWIR's end
    BandSelection(include_nm='', exclude_nm='1340-1460,1790-1980,2450-2600')
    >>> vnir_only = gb.BandSelection(include_nm="400-970")  # --include-nm 400-970
    >>> gb.rx_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...            output="out/rx.tif", spectral=vnir_only)["bands"]
    96
    """

    include_nm: str = ""
    exclude_nm: str = WATER_BANDS_NM


def parse_ranges(text: str | None, name: str = "ranges") -> list[tuple[float, float]]:
    """Parse "400-900, 1000-1300" (nm) into [(400, 900), (1000, 1300)]."""
    if text is None or not str(text).strip():
        return []
    out = []
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        m = re.fullmatch(r"(\d+(?:\.\d*)?)\s*(?:-|–|:)\s*(\d+(?:\.\d*)?)", part)
        if not m:
            raise ParameterError(
                f"parameter '{name}': {part!r} is not a wavelength range; write e.g. "
                "'1340-1460,1790-1980' (nm)"
            )
        lo, hi = float(m.group(1)), float(m.group(2))
        if hi < lo:
            raise ParameterError(f"parameter '{name}': range {part!r} ends before it starts")
        out.append((lo, hi))
    return out


def select_bands(
    wavelengths: np.ndarray | None,
    count: int,
    include: str | None = None,
    exclude: str | None = WATER_BANDS_NM,
) -> np.ndarray:
    """0-based indexes of the bands to use.

    ``include``: keep only bands whose centre lies in one of these ranges (all bands when
    empty). ``exclude``: then drop bands in these ranges. Without wavelength metadata only
    "all bands" is possible.
    """
    inc = parse_ranges(include, "include_nm")
    exc = parse_ranges(exclude, "exclude_nm")
    if wavelengths is None:
        if inc:
            raise ParameterError(
                "parameter 'include_nm': the image has no wavelength metadata, so bands "
                "cannot be chosen by wavelength; leave include_nm empty"
            )
        return np.arange(count)
    wl = np.asarray(wavelengths, dtype=float)
    keep = np.ones(wl.size, dtype=bool)
    if inc:
        keep = np.zeros(wl.size, dtype=bool)
        for lo, hi in inc:
            keep |= (wl >= lo) & (wl <= hi)
    for lo, hi in exc:
        keep &= ~((wl >= lo) & (wl <= hi))
    idx = np.flatnonzero(keep)
    if idx.size < 2:
        raise ParameterError(
            f"the band selection (include {include or 'all'}, exclude {exclude or 'none'}) "
            f"leaves {idx.size} band(s) of {wl.size} ({wl.min():.0f}–{wl.max():.0f} nm): "
            "widen include_nm or narrow exclude_nm"
        )
    return idx


def band_label(i: int, wavelengths: np.ndarray | None = None) -> str:
    """'band 12 (523.4 nm)' for the 0-based index ``i``."""
    if wavelengths is None:
        return f"band {i + 1}"
    return f"band {i + 1} ({wavelengths[i]:.1f} nm)"
