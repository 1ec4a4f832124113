"""Radiance from raw DN through the vendor's calibration: the value and its kernels.

A Specim capture (AISA Eagle, Hawk, Dual; AisaFENIX) becomes radiance as NERC-ARF's APL
(``aplcal``) makes it::

    L = (DN − dark) · gain / tint      [µW cm⁻² sr⁻¹ nm⁻¹, tint in ms]

with ``gain`` the calibration file's value of each band and sample (an ENVI ``.cal``: one line
of float32, bands × samples). APL stores L × 1000 as uint16 nW; here it stays float32 µW.
Per detector: an AisaFENIX is two detectors in one file, its VNIR bands (``vimg1``) taken
with ``tint1`` and the rest with ``tint2``. An Eagle's frame-transfer CCD smears every band
with the bands read before it: APL removes ``fsc · Σ_{b' < b} S_b'`` from band ``b`` of the
dark-subtracted signal ``S``, with ``fsc = t_transfer / tint · spectral binning`` and the sum
over the already corrected bands. A calibration measured at a finer binning is binned as APL
bins it: the sum of the binned cells divided by (spectral binning · spatial binning)², since a
binned DN is the sum of its cells.

A HySpex ``.hyspex`` file carries its own calibration; HyPro's ``dn2rdn_Hyspex`` gives::

    L = (DN − background) · h c 10⁶ · 100 / (RE · QE · SF · tint · π a² · Ω · Δλ · λ)

in mW cm⁻² µm⁻¹ sr⁻¹, which is the same number as µW cm⁻² sr⁻¹ nm⁻¹.

References
----------
NERC-ARF Airborne Processing Library (APL), ``src/calibration.cpp`` (``RemoveDarkFrames``,
``SmearCorrect``, ``ApplyGains``, ``ReadBinAndTrimGains``, ``FlagPixels``) and
``src/specimsensors.h`` (raw maxima, frame-transfer time 0.002 ms), github.com/arsf/APL.
EnSpec HyPro, ``hypro/Radiometry.py`` (``make_radio_cali_file_Hyspex``, ``dn2rdn_Hyspex``).
Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: the ratio needs
accurate radiometric calibration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The units of every radiance written here.
UNITS = "uW cm-2 sr-1 nm-1"
#: Largest raw DN (saturated) of each Specim detector (APL ``specimsensors.h``); the FENIX
#: VNIR maximum is multiplied by its spatial binning.
EAGLE_MAX = 4095
HAWK_MAX = 16383
FENIX_VNIR_MAX = 4095
FENIX_SWIR_MAX = 65535
#: Eagle CCD frame-transfer time (ms), APL's ``FRAME_TRANSFER_TIME``.
FRAME_TRANSFER_MS = 0.002
#: Sensor serial numbers APL knows (``specimsensors.h``).
EAGLE_IDS = ("100022", "110001")
HAWK_IDS = ("300011", "310018")
FENIX_IDS = ("350005", "350002")


@dataclass(frozen=True, eq=False)
class Calibration:
    """A radiometric calibration: ``gain`` of each band and sample (float32, shape
    (bands, samples)), so that ``L = (DN − dark) · gain / tint[ms]`` in :data:`UNITS`.

    ``wavelengths``/``fwhm`` (nm) are the calibration's band centres; ``sensorid`` and
    ``binning`` (spectral, spatial) the capture settings it was measured at; ``bad`` the
    0-based (band, sample) cells of the calibration's own grid to mask, from ``bad_source``;
    ``source`` the file it was read from.
    """

    gain: np.ndarray
    wavelengths: np.ndarray
    fwhm: np.ndarray | None = None
    sensorid: str = ""
    binning: tuple[int, int] = (1, 1)
    units: str = UNITS
    source: str = ""
    bad: tuple[tuple[int, int], ...] = ()
    bad_source: str = ""

    @property
    def files(self) -> tuple[str, ...]:
        """The file it was read from (what an operation checks as its input)."""
        return (self.source,) if self.source else ()

    @property
    def bands(self) -> int:
        return int(self.gain.shape[0])

    @property
    def samples(self) -> int:
        return int(self.gain.shape[1])


def bin_gain(gain: np.ndarray, spectral: int, spatial: int) -> np.ndarray:
    """The gain of a capture binned ``spectral`` × ``spatial`` times more than the
    calibration: each cell's gains summed and divided by (spectral · spatial)² (APL's
    ``ReadBinAndTrimGains``: a binned DN is the sum of its cells).

    Parameters
    ----------
    gain : ndarray, shape (bands, samples)
    spectral, spatial : int
        Binning ratios (capture / calibration), ≥ 1; trailing bands or samples that do not
        fill a cell are dropped, as APL drops them.

    Returns
    -------
    ndarray, shape (bands // spectral, samples // spatial), float64
    """
    g = np.asarray(gain, np.float64)
    nb, ns = g.shape[0] // spectral, g.shape[1] // spatial
    cells = g[: nb * spectral, : ns * spatial].reshape(nb, spectral, ns, spatial)
    return cells.sum(axis=(1, 3)) / float(spectral * spatial) ** 2


def binned_wavelengths(wavelengths, spectral: int) -> np.ndarray:
    """Band centres of a calibration binned ``spectral`` times: the mean of each cell's."""
    wl = np.asarray(wavelengths, np.float64)
    n = wl.size // spectral
    return wl[: n * spectral].reshape(n, spectral).mean(axis=1)


def match_bands(capture_nm, calibration_nm) -> tuple[np.ndarray, np.ndarray]:
    """The calibration band of each capture band: the nearest centre, and whether it lies
    within half the calibration's local band spacing ("within a band").

    Returns
    -------
    index : ndarray of int
        0-based calibration band of each capture band.
    ok : ndarray of bool
        False where the nearest calibration centre is further than half a band away.
    """
    cap = np.asarray(capture_nm, np.float64)
    cal = np.asarray(calibration_nm, np.float64)
    order = np.argsort(cal)
    sorted_cal = cal[order]
    pos = np.clip(np.searchsorted(sorted_cal, cap), 1, max(1, cal.size - 1))
    if cal.size == 1:
        return np.zeros(cap.size, int), np.ones(cap.size, bool)
    left, right = sorted_cal[pos - 1], sorted_cal[pos]
    nearest = np.where(np.abs(cap - left) <= np.abs(cap - right), pos - 1, pos)
    spacing = np.gradient(sorted_cal)
    ok = np.abs(cap - sorted_cal[nearest]) <= 0.5 * np.abs(spacing[nearest])
    return order[nearest], ok


def smear_correct(signal: np.ndarray, fsc: float) -> np.ndarray:
    """Remove an Eagle frame-transfer CCD's smear from dark-subtracted ``signal``.

    Band ``b`` loses ``fsc`` times the sum of the bands before it, already corrected
    (APL's ``SmearCorrect``); non-finite cells (the frame counter) add nothing.

    Parameters
    ----------
    signal : ndarray, shape (lines, bands, samples)
        DN − dark, in band order of the CCD.
    fsc : float
        ``t_transfer / tint · spectral binning``.

    Returns
    -------
    ndarray
        The corrected signal (a new float64 array).
    """
    out = np.array(signal, np.float64)
    total = np.zeros((out.shape[0], out.shape[2]), np.float64)
    for b in range(1, out.shape[1]):
        prev = out[:, b - 1]
        total += np.where(np.isfinite(prev), prev, 0.0)
        out[:, b] -= fsc * total
    return out


def radiance(
    dn: np.ndarray,
    dark: np.ndarray,
    gain: np.ndarray,
    tint_ms,
    valid: np.ndarray | None = None,
    *,
    saturation=None,
    bad: np.ndarray | None = None,
    smear: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """``L = (DN − dark) · gain / tint`` of a strip of lines, with what is not radiance masked.

    Parameters
    ----------
    dn : ndarray, shape (lines, bands, samples)
        Raw DN (band-interleaved by line, as the sensors write them).
    dark : ndarray, shape (bands, samples)
        Dark level in DN; non-finite where a cell is not image (the frame counter).
    gain : ndarray, shape (bands, samples)
        The calibration's gain on the capture's grid (:func:`bin_gain`, :func:`match_bands`).
    tint_ms : float or ndarray, shape (bands,)
        Integration time of each band's detector, ms (1 when ``gain`` includes it).
    valid : ndarray of bool, optional
        Cells known valid (broadcast to ``dn``).
    saturation : float or ndarray, shape (bands,), optional
        The detector's raw maximum: cells at or above it are nodata (and, with ``smear``,
        every later band of that sample, which the saturated charge smears: APL's
        ``SmearAffected``).
    bad : ndarray of bool, shape (bands, samples), optional
        Bad detector cells (the ``.bad`` file).
    smear : float
        Frame-transfer smear factor ``fsc`` (:func:`smear_correct`); 0 for none.

    Returns
    -------
    radiance : ndarray, float32, shape of ``dn``
    ok : ndarray of bool, shape of ``dn``
        Cells that are radiance (not saturated, not bad, not the frame counter, finite).

    References
    ----------
    NERC-ARF APL ``src/calibration.cpp`` (``RemoveDarkFrames``, ``SmearCorrect``,
    ``ApplyGains``, ``FlagPixels``); Brook & Ben-Dor, Remote Sens. 2011, 3, 484–502,
    https://doi.org/10.3390/rs3030484.
    """
    # float32 is exact for the DN and the dark difference and rounds the product at 6e-8;
    # the smear's running sum over the bands is kept in float64.
    kind = np.float64 if smear else np.float32
    signal = np.asarray(dn, kind) - np.asarray(dark, kind)[None]
    if smear:
        signal = smear_correct(signal, smear)
    tint = np.asarray(tint_ms, np.float64)
    scale = np.asarray(gain, np.float64) / (tint[:, None] if tint.ndim else tint)
    signal *= scale.astype(kind)[None]
    out = signal.astype(np.float32, copy=False)
    ok = np.isfinite(out)
    if valid is not None:
        ok &= np.broadcast_to(valid, ok.shape)
    if saturation is not None:
        sat = np.asarray(saturation, np.float64)
        high = np.asarray(dn) >= (sat[None, :, None] if sat.ndim else sat)
        if smear:
            high = np.logical_or.accumulate(high, axis=1)
        ok &= ~high
    if bad is not None:
        ok &= ~np.asarray(bad, bool)[None]
    return out, ok


def fenix_tints(n_bands: int, vnir_bands: int, tint1: float, tint2: float) -> np.ndarray:
    """Integration time of each band of an AisaFENIX capture: ``tint1`` for the first
    ``vnir_bands`` (its ``vimg1`` range), ``tint2`` for the rest (APL's two sub-sensors)."""
    t = np.full(n_bands, float(tint2))
    t[:vnir_bands] = float(tint1)
    return t


def hyspex_gain(re, qe, wavelengths, *, scaling, tint, aperture, pixel_x, pixel_y) -> np.ndarray:
    """HySpex gain (radiance per DN above background), HyPro's ``make_radio_cali_file_Hyspex``.

    Parameters
    ----------
    re : ndarray, shape (bands, samples)
        Responsivity matrix.
    qe : ndarray, shape (bands,)
        Quantum efficiency (0–1).
    wavelengths : ndarray, shape (bands,)
        Band centres, nm; the band width is the spacing to the next centre (the last repeated).
    scaling, tint, aperture, pixel_x, pixel_y : float
        The header's scaling factor SF, integration time, aperture size and pixel sizes.

    Returns
    -------
    ndarray, shape (bands, samples)
        Gain in µW cm⁻² sr⁻¹ nm⁻¹ per DN (HyPro's mW cm⁻² µm⁻¹ sr⁻¹, the same number).

    References
    ----------
    EnSpec HyPro ``hypro/Radiometry.py``; Brook & Ben-Dor, Remote Sens. 2011, 3, 484–502,
    https://doi.org/10.3390/rs3030484.
    """
    h = 6.62607015e-34  # Planck constant, J s (SI, exact)
    c = 299792458.0 * 1e9  # speed of light, nm/s
    wl = np.asarray(wavelengths, np.float64)
    step = np.diff(wl)
    step = np.append(step, step[-1]) if step.size else np.ones(1)
    area = np.pi * aperture * aperture
    solid = pixel_x * pixel_y
    denom = (
        np.asarray(re, np.float64)
        * np.asarray(qe, np.float64)[:, None]
        * scaling
        * tint
        * area
        * solid
        * step[:, None]
        * wl[:, None]
    )
    return h * c * 1e6 / denom * 100.0


__all__ = [
    "EAGLE_IDS",
    "EAGLE_MAX",
    "FENIX_IDS",
    "FENIX_SWIR_MAX",
    "FENIX_VNIR_MAX",
    "FRAME_TRANSFER_MS",
    "HAWK_IDS",
    "HAWK_MAX",
    "UNITS",
    "Calibration",
    "bin_gain",
    "binned_wavelengths",
    "fenix_tints",
    "hyspex_gain",
    "match_bands",
    "radiance",
    "smear_correct",
]
