"""Band set and reflectance spectra of the simulated AISA-Dual scene.

* **Band set** (:func:`aisa_dual_bands`): 198 bands, 96 VNIR (EAGLE, 400–970 nm, 6 nm sampling,
  6.5 nm FWHM) and 102 SWIR (HAWK, 980–2,450 nm, 14.55 nm sampling, 14.5 nm FWHM). The paper
  gives 198 bands over these ranges (section 2); the split and FWHM are a typical spectral
  binning of the two instruments. The VNIR band nearest 920 nm is 922 nm, the SWIR band nearest
  1,010 nm is 1,009.1 nm (Eq. 3).
* **Resampling**: spectra are interpolated to a 1 nm grid and integrated against a Gaussian
  spectral response function (SRF) of the band's FWHM (:func:`band_average`).
* **Materials**: measured spectra from the ``earthlib`` spectral library (MIT; ASD field and
  laboratory measurements, the ICRAF-ISRIC soil library and PROSAIL canopy simulations). Each
  material is the per-wavelength median of one earthlib class (see :data:`EARTHLIB_CLASSES`), so
  it is deterministic. earthlib has no data in the 1,360–1,450 and 1,800–1,950 nm water bands:
  reflectance is interpolated linearly across them (the atmosphere makes those bands dark anyway).
* **Gray plastic bags** (the paper's sub-pixel targets, section 3.3) are not in any installable
  library: :func:`plastic_bag` models a gray polyethylene film, flat 0.30 reflectance with the
  documented C–H absorption features of polyethylene near 1,215, 1,395/1,415, 1,730/1,760 and
  2,310/2,350 nm (overtone and combination bands; e.g. Garaba & Dierssen 2018, "An airborne
  remote sensing case study of synthetic hydrocarbon detection using short wave infrared
  absorption features identified from marine-harvested macro- and microplastics").
* **Clouds** (:func:`cloud`): a bright, spectrally flat top with the liquid-water absorption
  near 1,500 and 2,000 nm.

Not modelled: intra-class spectral variability (each material is one spectrum; spatial
texture comes from sub-pixel mixing of materials), BRDF (all surfaces are Lambertian).
"""

from __future__ import annotations

from functools import cache

import numpy as np

#: Fine wavelength grid (nm) on which spectra and the atmosphere are evaluated.
FINE_NM = np.arange(350.0, 2551.0, 1.0)

VNIR_BANDS = 96
SWIR_BANDS = 102
VNIR_FWHM_NM = 6.5
SWIR_FWHM_NM = 14.5

#: Material ids (uint8 in the material truth raster) and names. 0 is "none".
MATERIALS = {
    1: "asphalt",
    2: "concrete",
    3: "roof_shingle",
    4: "roof_tile",
    5: "roof_metal",
    6: "soil",
    7: "dark_soil",
    8: "sand",
    9: "grass",
    10: "tree",
    11: "dry_vegetation",
    12: "gravel",
    13: "plastic_bag",
    14: "cloud",
}
MATERIAL_IDS = {name: i for i, name in MATERIALS.items()}

#: Which earthlib class (LEVEL_3) each material is the median of, and an optional filter.
EARTHLIB_CLASSES = {
    "asphalt": ("asphalt", None),
    "concrete": ("sidewalk", None),
    "roof_shingle": ("comp_shingle", None),
    "roof_tile": ("concrete_tile", None),
    "roof_metal": ("metal", None),
    "soil": ("soil", None),
    "dark_soil": ("soil", (0.0, 0.25)),  # darkest quarter of the soils (by 400–2,450 nm mean)
    "sand": ("sand", None),
    "grass": ("canopy", (0.25, 0.50)),  # PROSAIL canopies, 2nd quartile of 850 nm reflectance
    "tree": ("canopy", (0.70, 0.95)),  # dense canopies
    "dry_vegetation": ("litter", None),
    "gravel": ("gravel", None),
}


def aisa_dual_bands() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(vnir_centres, vnir_fwhm, swir_centres, swir_fwhm) in nm: the 198-band AISA-Dual set."""
    vnir = np.linspace(400.0, 970.0, VNIR_BANDS)
    swir = np.linspace(980.0, 2450.0, SWIR_BANDS)
    return (
        vnir,
        np.full(VNIR_BANDS, VNIR_FWHM_NM),
        swir,
        np.full(SWIR_BANDS, SWIR_FWHM_NM),
    )


def srf_matrix(centres, fwhm, grid=FINE_NM) -> np.ndarray:
    """(bands, len(grid)) Gaussian spectral response functions, each normalised to sum 1."""
    centres = np.asarray(centres, float)[:, None]
    sigma = np.asarray(fwhm, float)[:, None] / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    w = np.exp(-0.5 * ((grid[None, :] - centres) / sigma) ** 2)
    return w / w.sum(axis=1, keepdims=True)


def band_average(spectrum_fine, centres, fwhm) -> np.ndarray:
    """Band values of a spectrum given on :data:`FINE_NM` (last axis), Gaussian SRFs."""
    return np.asarray(spectrum_fine) @ srf_matrix(centres, fwhm).T


def _gauss(wl, centre, sigma):
    return np.exp(-0.5 * ((wl - centre) / sigma) ** 2)


@cache
def _earthlib() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(wavelengths_nm, spectra (n, bands), level_3 class per spectrum) of earthlib's full
    library, through earthlib's own reader of its bundled data (band centres as its ENVI
    header gives them)."""
    from earthlib import config, read

    spectra, _, sensor = read.envi_library(config.full_endmember_path)
    wl = np.asarray(sensor.band_centers, float)
    if wl.max() < 100:  # the library is in micrometres
        # earthlib keeps the header's centres (0.41, ... µm) as float32: back to the decimals
        wl = np.round(wl, 6) * 1000.0
    classes = config.full_metadata["LEVEL_3"].to_numpy(str)
    return wl, np.asarray(spectra, dtype=float), classes


def earthlib_spectrum(name: str) -> np.ndarray:
    """Reflectance of material ``name`` on :data:`FINE_NM` (median of its earthlib class)."""
    wl, spectra, classes = _earthlib()
    cls, quantiles = EARTHLIB_CLASSES[name]
    sel = spectra[classes == cls]
    if quantiles is not None:
        if cls == "canopy":
            key = sel[:, np.argmin(np.abs(wl - 850.0))]
        else:
            key = sel.mean(axis=1)
        lo, hi = np.quantile(key, quantiles)
        sel = sel[(key >= lo) & (key <= hi)]
    median = np.median(sel, axis=0)
    # Linear interpolation across the library's water-band gaps; flat beyond its ends.
    return np.clip(np.interp(FINE_NM, wl, median), 0.0, 1.0)


def plastic_bag(grey: float = 0.30) -> np.ndarray:
    """Gray polyethylene bag reflectance on :data:`FINE_NM` (see the module docstring)."""
    wl = FINE_NM
    rho = np.full(wl.shape, grey)
    rho *= 1.0 - 0.12 * _gauss(wl, 380.0, 40.0)  # slight blue fall-off of a gray pigment
    features = (  # (centre nm, sigma nm, relative depth): C-H overtones and combinations
        (1215.0, 12.0, 0.10),
        (1395.0, 10.0, 0.06),
        (1415.0, 10.0, 0.06),
        (1730.0, 10.0, 0.20),
        (1762.0, 10.0, 0.12),
        (2310.0, 14.0, 0.22),
        (2350.0, 14.0, 0.16),
    )
    for centre, sigma, depth in features:
        rho *= 1.0 - depth * _gauss(wl, centre, sigma)
    return rho


def cloud() -> np.ndarray:
    """Cloud-top reflectance on :data:`FINE_NM`: bright, flat, liquid-water absorption."""
    wl = FINE_NM
    rho = 0.80 - 0.05 * (wl > 1300) - 0.15 * (wl > 2100)
    rho = rho * (1.0 - 0.25 * _gauss(wl, 1500.0, 80.0) - 0.45 * _gauss(wl, 2000.0, 90.0))
    return rho


def material_spectrum(name: str) -> np.ndarray:
    """Reflectance of any known material on :data:`FINE_NM`."""
    if name == "plastic_bag":
        return plastic_bag()
    if name == "cloud":
        return cloud()
    if name in EARTHLIB_CLASSES:
        return earthlib_spectrum(name)
    raise KeyError(f"unknown material {name!r}; known: {', '.join(MATERIALS.values())}")
