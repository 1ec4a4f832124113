"""A simulated scene's DN as an AisaFENIX-like raw capture of both detectors, with the
radiometric calibration that turns it back into the simulated radiance.

The capture holds the VNIR bands (``vimg1``) at ``tint1`` and the SWIR bands at ``tint2``
(:data:`TINTS_MS`), dark frames after the image lines (:data:`DARK_LINES`) and a frame counter in
band 1, sample 0, as Specim's raw files do (NERC-ARF APL, ``src/specimsensors.cpp``). Its gain is
chosen so that L = (DN − dark) · gain / tint[ms] is the simulated at-sensor radiance in
µW cm⁻² sr⁻¹ nm⁻¹: gain = 100 · tint / (G · r(λ)), with G and r the simulated detector's gain
and spectral response (:mod:`geoboresight.simulate.sensor`; 1 W m⁻² = 100 µW cm⁻²).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .sensor import SWIR, VNIR

#: Integration times (ms) of the capture's VNIR and SWIR detectors: the simulated DN are taken
#: to be recorded at these, the SWIR's 3.3 times shorter as on an AisaFENIX.
TINTS_MS = (10.0, 3.0)
#: Dark frames after the capture's image lines (shutter closed).
DARK_LINES = 64
#: The capture's sensor id: an AisaFENIX's, as NERC-ARF APL lists them.
SENSORID = "350005"


@dataclasses.dataclass(frozen=True)
class Capture:
    """A raw capture: ``raw`` (lines, bands, samples) uint16 DN, the image's first ``lines``
    then the dark frames; ``gain`` (bands, samples) float32; ``n_vnir`` VNIR bands first."""

    raw: np.ndarray
    gain: np.ndarray
    lines: int
    n_vnir: int
    tints_ms: tuple[float, float] = TINTS_MS
    sensorid: str = SENSORID


def raw_capture(vnir: np.ndarray, swir: np.ndarray, wavelengths, seed: int) -> Capture:
    """The capture of the DN cubes ``vnir`` and ``swir`` (bands, lines, samples; uint16), with
    ``wavelengths`` (nm, VNIR then SWIR) and dark frames drawn from ``seed``.

    Returns
    -------
    Capture
    """
    nv, ns_b = vnir.shape[0], swir.shape[0]
    lines, samples = vnir.shape[1], vnir.shape[2]
    image = np.concatenate([vnir, swir]).transpose(1, 0, 2)
    rng = np.random.default_rng(int(seed) + 7919)
    dark = np.r_[np.full(nv, VNIR.dark_dn), np.full(ns_b, SWIR.dark_dn)][None, :, None]
    noise = np.r_[np.full(nv, VNIR.read_noise_dn), np.full(ns_b, SWIR.read_noise_dn)]
    frames = dark + noise[None, :, None] * rng.standard_normal((DARK_LINES, nv + ns_b, samples))
    raw = np.concatenate([image, np.clip(np.rint(frames), 0, 4095).astype("uint16")])
    # The frame counter jumps at the first dark line (frames pass while the shutter closes).
    count = 1 + np.arange(raw.shape[0]) + np.where(np.arange(raw.shape[0]) >= lines, 25, 0)
    raw[:, 0, 0] = count % 65536
    raw[:, 0, 1] = 0
    wl = np.asarray(wavelengths, float)
    t1, t2 = TINTS_MS
    tints = np.r_[np.full(nv, t1), np.full(ns_b, t2)]
    response = np.r_[
        VNIR.gain * VNIR.relative_response(wl[:nv]), SWIR.gain * SWIR.relative_response(wl[nv:])
    ]
    gain = np.repeat((100.0 * tints / response)[:, None], samples, axis=1).astype("float32")
    return Capture(raw=raw, gain=gain, lines=lines, n_vnir=nv)


__all__ = ["DARK_LINES", "SENSORID", "TINTS_MS", "Capture", "raw_capture"]
