"""A physically based simulator of dual pushbroom (AISA-Dual VNIR + SWIR) scenes with truth.

No public raw-geometry AISA-Dual data exists, so every application of Brook & Ben-Dor (2011) is
validated on scenes whose truth is known. The simulator is also a planning tool: choose the
flying height, squint and sun, and see what offset, parallax and shadow ratio to expect.

>>> from geoboresight.simulate import simulate_scene
>>> from geoboresight.io.scene import write_scene
>>> scene = simulate_scene("urban", lines=128, seed=0)          # doctest: +SKIP
>>> scene.truth["offset_px"], scene.truth["disparity_px_per_m"]  # doctest: +SKIP
>>> write_scene(scene, "urban_scene")                            # doctest: +SKIP

The kernels take and return arrays; the files are written by :mod:`geoboresight.io.scene`
(``geoboresight.operations.simulate.simulate_file`` does both).

**Modelled** (each in its module):

* surface (:mod:`.surface`, :mod:`.presets`): DSM of terrain or dunes, flat-roofed buildings,
  tree crowns; a material map with sub-pixel mixtures; texture within each material
  (spatially correlated, spectrally flat reflectance factors of 2–8 % at ~1 m and several
  metres: soil moisture and stones, grass density, sand patches, stains; ``presets.TEXTURE``);
* spectra (:mod:`.spectra`): 198 AISA-Dual bands (96 VNIR 400–970 nm, FWHM 6.5 nm; 102 SWIR
  980–2,450 nm, FWHM 14.5 nm), Gaussian SRFs; measured spectra from earthlib; gray plastic
  bags with polyethylene absorption features (1,215, 1,730, 2,310 nm); clouds;
* sun and atmosphere (:mod:`.atmosphere`): black-body sun, Rayleigh + aerosol + gas
  absorption, direct and (bluer) diffuse irradiance, path radiance and transmittance below
  the aircraft;
* sun geometry (:mod:`.shadow`): cos i self-shading, cast shadows from the DSM, sky view of
  tilted surfaces, sub-pixel shadow fraction by supersampling, cloud shadows;
* viewing geometry (:mod:`.geometry`): two instruments with their own boresight angles
  (roll, pitch, yaw), IFOV 1 mrad, 286 pixels; each samples the scene at its own footprint by
  ray–DSM intersection (relief parallax, occlusion); the vendor co-registration at the
  nominal altitude, leaving the residual (H − H_nom)·tan θ / Δ plus h·tan θ / Δ;
* sensor (:mod:`.sensor`): Gaussian PSF, spectral response, gain, dark offset, shot and read
  noise, 12-bit quantisation; the high b1010/b920 ratio in shadow comes out of these terms;
* sub-pixel targets with exact footprint overlap, and clouds seen with parallax.

**Not modelled**: radiative transfer beyond the parametric model (no MODTRAN/6S), adjacency
effect, ground–sky multiple scattering, BRDF (all surfaces Lambertian), sky obstruction by
neighbouring objects, light reflected by walls, penumbra, translucent canopies, wall materials,
smile/keystone and optical distortion, aircraft attitude jitter and GPS/INS, lever arm between
the optics, Earth curvature, refraction, non-linearity, bad pixels, stray light, fixed-pattern
noise, moving objects, spectral variability within a material (the texture is a flat factor).
"""

from .geometry import Geometry, Instrument
from .presets import GEOMETRIES, SCENES
from .scene import Scene, simulate_scene
from .spectra import MATERIALS, aisa_dual_bands
from .surface import Surface, Window

__all__ = [
    "GEOMETRIES",
    "MATERIALS",
    "SCENES",
    "Geometry",
    "Instrument",
    "Scene",
    "Surface",
    "Window",
    "aisa_dual_bands",
    "simulate_scene",
]
