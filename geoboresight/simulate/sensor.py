"""The two detectors: point spread, spectral response, gain, dark offset, noise, 12-bit DN.

Raw digital numbers are simulated, as a pushbroom system records them before radiometric
calibration (the paper works in raw geometry; section 2):

    DN = round( G · r(λ) · L(λ) + dark + noise ),  clipped to 0 … 4095 (12 bits)

* ``L``: at-sensor radiance (W m⁻² sr⁻¹ nm⁻¹) of the band.
* ``r(λ)``: the instrument's relative spectral response (detector quantum efficiency ×
  spectrograph and filter efficiency). The VNIR silicon CCD loses sensitivity towards 1 µm; the
  SWIR MCT spectrograph is weak at its cut-on edge below ~1,050 nm. Both edge bands of the
  paper's ratio (920 and 1,010 nm) are therefore dim.
* ``G``: gain (DN per unit radiance at r = 1); ``dark``: the dark offset (bias + dark current),
  large for the SWIR MCT array. Because the 1,010 nm signal is small against its dark offset
  while the 920 nm signal is larger against its own, the DN ratio b1010/b920 rises as the
  illumination falls: a core shadow (sky light only) has a high ratio, as in the paper's
  Table 2. The constants below are chosen, within what such instruments show, so that the
  urban preset lands in Table 2's ranges; they are documented, not fitted per pixel.
* **Noise**: shot noise of signal and dark electrons (Gaussian approximation of Poisson, with
  ``electrons_per_dn``) plus read noise; then rounding to integers (quantisation).
* **PSF**: a Gaussian point spread function (optics + along-track motion smear) applied in the
  image, on top of the box footprint that the supersampled rays integrate.

Not modelled: smile and keystone, stray light, spectral and spatial misregistration within one
instrument, non-linearity, bad pixels, fixed-pattern noise, saturation bleeding, frame-time
jitter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: (wavelength nm, relative response) of the VNIR (silicon CCD) instrument.
VNIR_RESPONSE = (
    (400, 0.35),
    (450, 0.60),
    (550, 0.95),
    (650, 1.0),
    (750, 0.90),
    (850, 0.70),
    (920, 0.50),
    (970, 0.35),
)
#: (wavelength nm, relative response) of the SWIR (MCT) instrument: weak cut-on edge.
SWIR_RESPONSE = (
    (980, 0.02),
    (1010, 0.04),
    (1050, 0.25),
    (1100, 0.55),
    (1200, 0.90),
    (1300, 1.0),
    (2300, 1.0),
    (2400, 0.85),
    (2450, 0.60),
)


@dataclass(frozen=True)
class Detector:
    """Radiometric constants of one instrument (see the module docstring)."""

    name: str
    response: tuple
    gain: float  # DN per W m-2 sr-1 nm-1 at relative response 1
    dark_dn: float
    electrons_per_dn: float
    read_noise_dn: float
    psf_sigma_px: float
    bits: int = 12

    def relative_response(self, wavelengths_nm) -> np.ndarray:
        wl, r = np.array(self.response, float).T
        return np.interp(wavelengths_nm, wl, r)

    def to_dn(self, radiance: np.ndarray, wavelengths_nm, rng: np.random.Generator | None):
        """(bands, ...) radiance → uint16 DN with noise (``rng=None``: noise-free, unrounded)."""
        g = (self.gain * self.relative_response(wavelengths_nm)).reshape(
            (-1,) + (1,) * (radiance.ndim - 1)
        )
        signal = g * radiance + self.dark_dn
        if rng is None:
            return signal
        sigma = np.sqrt(np.maximum(signal, 0) / self.electrons_per_dn + self.read_noise_dn**2)
        dn = signal + sigma * rng.standard_normal(signal.shape, dtype="float32")
        return np.clip(np.rint(dn), 0, 2**self.bits - 1).astype("uint16")


VNIR = Detector(
    name="vnir",
    response=VNIR_RESPONSE,
    gain=16000.0,
    dark_dn=190.0,
    electrons_per_dn=20.0,
    read_noise_dn=3.0,
    psf_sigma_px=0.35,
)
SWIR = Detector(
    name="swir",
    response=SWIR_RESPONSE,
    gain=60000.0,
    dark_dn=800.0,
    electrons_per_dn=30.0,
    read_noise_dn=6.0,
    psf_sigma_px=0.45,
)
