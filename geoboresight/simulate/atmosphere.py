"""Sun and atmosphere: direct and diffuse irradiance, path radiance, transmittance.

A compact parametric model (no radiative-transfer code), evaluated on a 1 nm grid and then
integrated over each band's Gaussian response:

* **Solar irradiance** at the top of the atmosphere: a 5,778 K black body scaled to the solar
  constant (no Fraunhofer lines).
* **Extinction**: Rayleigh optical depth (Bodhaine et al. 1999 approximation,
  τ = 0.008569 λ⁻⁴ (1 + 0.0113 λ⁻² + 0.00013 λ⁻⁴), λ in µm); aerosol optical depth with an
  Ångström law τₐ = τ₅₅₀ (λ/550)^−α (α = 1.3, single-scattering albedo 0.92, asymmetry 0.7);
  gas absorption as Gaussian bands in optical depth for water vapour (720, 820, 940, 1,135,
  1,380, 1,870 nm and the 2.7 µm wing), O₂ (688, 762, 1,268 nm), CO₂ (2,008, 2,062 nm) and
  CH₄ (2,320 nm), water scaled by the column (cm).
* **Direct** beam irradiance E₀ exp(−τ/μₛ); **diffuse** sky irradiance on a horizontal surface
  E₀ μₛ T_gas [½(1 − e^{−τ_R/μₛ}) + ω F (1 − e^{−τₐ/μₛ})], F = (1+g)/2 the forward-scattered
  aerosol fraction. The sky light is much bluer than the sun beam (Rayleigh λ⁻⁴), which is one
  of the radiometric terms behind the paper's shadow behaviour.
* **Up-path** between the ground and the aircraft: only the part of each constituent below the
  flying height (scale heights: Rayleigh 8 km, aerosol 1.5 km, water vapour 2 km) attenuates
  (direct transmittance, nadir view) and scatters sunlight into the view (**path radiance**,
  single-scattering slab formula with Rayleigh and Henyey–Greenstein phase functions).

Not modelled: multiple scattering beyond the diffuse-irradiance formula, the ground–sky
coupling (spherical albedo), adjacency effects (diffuse up-transmittance), view-angle
dependence of the path across the swath, terrain height dependence of the atmosphere,
polarisation, refraction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .spectra import FINE_NM, band_average

SUN_TEMPERATURE_K = 5778.0
SOLAR_CONSTANT_W_M2 = 1361.0
ANGSTROM_ALPHA = 1.3
AEROSOL_SSA = 0.92
AEROSOL_G = 0.70
#: Default aerosol optical depth at 550 nm and water-vapour column (cm).
AOT550 = 0.15
WATER_VAPOUR_CM = 2.0
SCALE_HEIGHT_M = {"rayleigh": 8000.0, "aerosol": 1500.0, "water": 2000.0, "mixed": 8000.0}

#: (centre nm, sigma nm, vertical optical depth for 2 cm of water vapour)
WATER_BANDS = (
    (720.0, 8.0, 0.05),
    (822.0, 10.0, 0.08),
    (940.0, 12.0, 0.90),
    (1135.0, 22.0, 1.10),
    (1380.0, 40.0, 6.0),
    (1870.0, 45.0, 8.0),
    (2700.0, 90.0, 10.0),
)
#: (centre nm, sigma nm, vertical optical depth) of well-mixed gases (O2, CO2, CH4)
MIXED_GAS_BANDS = (
    (688.0, 2.5, 0.20),
    (762.0, 3.0, 2.0),
    (1268.0, 3.0, 0.30),
    (2008.0, 6.0, 0.35),
    (2062.0, 7.0, 0.45),
    (2320.0, 25.0, 0.08),
)


def solar_irradiance(wl_nm=FINE_NM) -> np.ndarray:
    """Top-of-atmosphere solar spectral irradiance (W m⁻² nm⁻¹): scaled 5,778 K black body."""
    h, c, k = 6.62607015e-34, 2.99792458e8, 1.380649e-23
    lam = np.asarray(wl_nm, float) * 1e-9
    planck = 2 * h * c**2 / lam**5 / np.expm1(h * c / (lam * k * SUN_TEMPERATURE_K))
    sigma = 5.670374419e-8
    total = sigma * SUN_TEMPERATURE_K**4  # W m-2 at the sun's surface, all wavelengths
    return np.pi * planck * 1e-9 * SOLAR_CONSTANT_W_M2 / total


def rayleigh_depth(wl_nm=FINE_NM) -> np.ndarray:
    um = np.asarray(wl_nm, float) / 1000.0
    return 0.008569 * um**-4 * (1 + 0.0113 * um**-2 + 0.00013 * um**-4)


def aerosol_depth(wl_nm=FINE_NM, aot550: float = AOT550) -> np.ndarray:
    return aot550 * (np.asarray(wl_nm, float) / 550.0) ** -ANGSTROM_ALPHA


def _bands(wl, table, scale=1.0):
    tau = np.zeros_like(np.asarray(wl, float))
    for centre, sigma, depth in table:
        tau += depth * scale * np.exp(-0.5 * ((wl - centre) / sigma) ** 2)
    return tau


def _hg(cos_theta, g):
    return (1 - g**2) / (1 + g**2 - 2 * g * cos_theta) ** 1.5


@dataclass(frozen=True)
class Illumination:
    """Band-averaged radiometric terms (one value per band).

    ``direct``: sun-beam irradiance on a surface facing the sun (W m⁻² nm⁻¹);
    ``diffuse``: sky irradiance on a horizontal surface; ``path``: path radiance between the
    ground and the sensor (W m⁻² sr⁻¹ nm⁻¹); ``t_up``: ground-to-sensor transmittance.
    """

    direct: np.ndarray
    diffuse: np.ndarray
    path: np.ndarray
    t_up: np.ndarray


def illumination(
    centres,
    fwhm,
    sun_zenith_deg: float,
    flying_height: float,
    aot550: float = AOT550,
    water_vapour_cm: float = WATER_VAPOUR_CM,
) -> Illumination:
    """Direct, diffuse, path and up-transmittance terms for a band set (see module docstring)."""
    wl = FINE_NM
    mu = np.cos(np.radians(sun_zenith_deg))
    e0 = solar_irradiance(wl)
    t_r = rayleigh_depth(wl)
    t_a = aerosol_depth(wl, aot550)
    t_w = _bands(wl, WATER_BANDS, water_vapour_cm / 2.0)
    t_m = _bands(wl, MIXED_GAS_BANDS)
    t_gas = t_w + t_m

    direct = e0 * np.exp(-(t_r + t_a + t_gas) / mu)
    forward = 0.5 * (1.0 + AEROSOL_G)
    diffuse = (
        e0
        * mu
        * np.exp(-t_gas / mu)
        * (0.5 * -np.expm1(-t_r / mu) + AEROSOL_SSA * forward * -np.expm1(-t_a / mu))
    )

    below = {k: -np.expm1(-flying_height / s) for k, s in SCALE_HEIGHT_M.items()}
    tr_b, ta_b = t_r * below["rayleigh"], t_a * below["aerosol"]
    tg_b = t_w * below["water"] + t_m * below["mixed"]
    t_up = np.exp(-(tr_b + ta_b + tg_b))
    # Single scattering in the slab below the aircraft, nadir view (mu_v = 1): the sun beam
    # reaching the slab is attenuated by what lies above it.
    cos_scat = -mu  # scattering angle between the sun beam and the upward view
    p_r = 0.75 * (1 + cos_scat**2)
    p_a = _hg(cos_scat, AEROSOL_G)
    above = np.exp(-((t_r - tr_b) + (t_a - ta_b) + (t_gas - tg_b)) / mu)
    tau_b = tr_b + ta_b
    scat = tr_b * p_r + AEROSOL_SSA * ta_b * p_a
    slab = np.where(tau_b > 0, -np.expm1(-tau_b * (1 / mu + 1)) / np.maximum(tau_b, 1e-12), 0)
    path = e0 * above * np.exp(-tg_b) * mu / (4 * np.pi) * scat * slab / (mu + 1)

    def avg(x):
        return band_average(x, centres, fwhm)

    return Illumination(avg(direct), avg(diffuse), avg(path), avg(t_up))
