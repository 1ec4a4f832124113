"""Simulating a dual pushbroom scene: :func:`simulate_scene`, arrays in, a :class:`Scene` out.

The simulation runs in stages, each a function below; the ray tracing runs in along-track
blocks of lines, so its memory is bounded by a block:

1. the layout (:func:`scene_extent`): the area every ray of the flight line can hit, plus
   the margin whose objects can cast shadows into it; the surface (:func:`preset_surface`,
   :mod:`.surface`) and the cloud layer (:func:`cloud_layer`) over it;
2. per block, the fine grid (a third of a pixel, :func:`block_window`) covering the block's
   footprints and its up-sun margin, and the sun geometry on it (:func:`sun_maps`,
   :mod:`.shadow`): cos i, cast shadows, sky view, cloud shadows;
3. each instrument's pixels are sampled by ``supersample²`` rays spread over the pixel's
   IFOV and line period, intersected with the DSM (:mod:`.geometry`); at each hit the material
   fractions and illumination are interpolated from the fine grid (:func:`trace_block`);
4. per pixel and material: the mean direct-light and sky-light coefficients
   (:class:`Footprints`), times the sub-material brightness factor of each ray's ground cell
   (the texture within a material, :data:`.presets.TEXTURE`; it scales the signal, not the
   truth abundances); clouds above the ground are seen at each instrument's own footprint on
   the cloud layer; sub-pixel targets replace a fraction of the pixel exactly, footprint ∩
   target rectangle (:func:`add_targets`);
5. the instrument PSF blurs the coefficient images (:func:`psf_blur`); radiance per band
   follows from the material spectra and the atmosphere (:mod:`.atmosphere`,
   :func:`at_sensor_radiance`):
   ``L = T_up/π · Σ_m (D_m ρ_m E_dir + F_m ρ_m E_sky) + L_path``;
6. the detectors turn radiance into noisy 12-bit DN (:mod:`.sensor`, :func:`instrument_cube`).

The truth rasters are computed from the VNIR rays of step 3 (box footprint, no PSF).
Writing a scene to files is :func:`geoboresight.io.scene.write_scene`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from ..errors import ParameterError
from ..progress import Progress, as_progress
from . import presets as _presets
from .atmosphere import AOT550, WATER_VAPOUR_CM, Illumination, illumination
from .geometry import COLS, IFOV_MRAD, Geometry, Heights, Instrument, intersect
from .sensor import SWIR, VNIR, Detector
from .shadow import cast_shadow, horizon_sky, incidence, sky_view, sun_vector
from .spectra import MATERIAL_IDS, MATERIALS, aisa_dual_bands, band_average, material_spectrum
from .surface import Surface, Window, smooth_field

#: The paper's targets: 24 gray plastic bags of 35 × 55 cm (section 3.3).
BAG_SIZE_M = (0.35, 0.55)
TARGET = "plastic_bag"
BLOCK_LINES = 96
NOISE_BLOCK_LINES = 256
OPEN_GROUND = ("grass", "soil", "dark_soil", "sand", "dry_vegetation")
INSTRUMENTS = ("vnir", "swir")

#: Defaults of :func:`simulate_scene`, shared by the ``simulate`` operation and spec.
PRESET = "urban"
LINES = 128
MIN_LINES = 8
GEOMETRY = "realistic"
SUPERSAMPLE = 3
#: Cloud height above the ground, as a fraction of the flying height, unless given.
CLOUD_HEIGHT_FRACTION = 0.4
#: Heights (m) up to which the layout is planned before the surface exists, and the farthest
#: distance (m) at which an object is allowed to cast a shadow into the image.
Z_BOUND_M = 100.0
MAX_SHADOW_REACH_M = 400.0
#: How far (m) :func:`.shadow.horizon_sky` looks for surfaces hiding the sky (``sky_obstruction``):
#: a 20 m building 50 m away still hides 14 % of the sky in its direction.
SKY_REACH_M = 50.0


@dataclass(frozen=True)
class SimulatedFlight:
    """The simulated flight and the two instruments' lines of sight: a ``geometry`` preset
    (:data:`.presets.GEOMETRIES`) with any of its values overridden: the squint (degrees), the
    flying height and the vendor's co-registration altitude (m), or each instrument's full
    boresight angles ``"roll,pitch,yaw"`` (degrees; SWIR's override the squint). None keeps
    the preset's value (see :func:`flight_geometry`).

    Examples
    --------
    The paper's geometry measures no relief; a 3° squint makes a pixel of parallax per 29 m:

    >>> import geoboresight as gb
    >>> flight = gb.SimulatedFlight(geometry="large-squint")  # --geometry large-squint
    >>> result = gb.simulate_file(output="out/scene", lines=16, flight=flight)
    >>> round(result["disparity_px_per_m"], 4)
    0.0349
    """

    geometry: str = GEOMETRY
    squint_deg: float | None = None
    flying_height: float | None = None
    nominal_altitude: float | None = None
    boresight_vnir_deg: str | tuple[float, float, float] | None = None
    boresight_swir_deg: str | tuple[float, float, float] | None = None


@dataclass(frozen=True)
class Sky:
    """The sun and the atmosphere of a simulated flight: sun zenith and azimuth (degrees,
    azimuth clockwise from the flight direction; None: the paper's scene for the preset), the
    aerosol optical depth at 550 nm, the water-vapour column (cm), and whether the
    surroundings hide part of the sky (``sky_obstruction``, :func:`simulate_scene`).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.Sky()  # the sun of the preset's scene, a clear sky
    Sky(sun_zenith=None, sun_azimuth=None, aot550=0.15, water_vapour_cm=2.0, sky_obstruction=False)
    >>> gb.Sky(sun_zenith=30, aot550=0.4).aot550  # a hazier sky: --sun-zenith 30 --aot550 0.4
    0.4
    """

    sun_zenith: float | None = None
    sun_azimuth: float | None = None
    aot550: float = AOT550
    water_vapour_cm: float = WATER_VAPOUR_CM
    sky_obstruction: bool = False


@dataclass(frozen=True)
class SensorOptions:
    """How the detectors are simulated: noise-free DN (still rounded to 12 bits when written)
    and the rays per pixel side integrating each footprint.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.SensorOptions()
    SensorOptions(noise_free=False, supersample=3)
    """

    noise_free: bool = False
    supersample: int = SUPERSAMPLE


@dataclass(frozen=True)
class Scene:
    """A simulated AISA-Dual scene in raw geometry, with its ground truth.

    ``vnir``/``swir``: (bands, lines, 286) uint16 DN, SWIR co-registered to VNIR by the vendor
    shift for the nominal altitude (so a residual offset and relief parallax remain).
    Truth arrays are on the VNIR pixel grid: ``dsm`` (m above the lowest ground, z = 0),
    ``shadow_fraction`` (0–1, part of the footprint in cast shadow or self-shade from the direct
    sun, cloud shadows included), ``target_abundance`` (0–1), ``cloud_mask``, ``material``
    (dominant material id, names in ``material_names``), ``abundances`` (per material,
    ``abundance_names``; they sum to 1 with the target and cloud layers), and
    ``endmember_spectra`` (name → reflectance at the 198 band centres). ``truth`` is what
    ``truth.json`` holds. ``ground_xy`` (2, lines, cols): each VNIR pixel's mean ground point
    (m, track frame), ``surface`` and ``extent`` (x0, x1, y0, y1) the surface it was traced on:
    what :func:`.navigation.scene_navigation` places on a map.
    """

    vnir: np.ndarray
    swir: np.ndarray
    vnir_wavelengths: np.ndarray
    swir_wavelengths: np.ndarray
    vnir_fwhm: np.ndarray
    swir_fwhm: np.ndarray
    dsm: np.ndarray
    shadow_fraction: np.ndarray
    target_abundance: np.ndarray
    cloud_mask: np.ndarray
    material: np.ndarray
    material_names: dict
    abundances: np.ndarray
    abundance_names: tuple
    endmember_spectra: dict
    truth: dict = field(repr=False)
    ground_xy: np.ndarray | None = field(default=None, repr=False, compare=False)
    surface: Surface | None = field(default=None, repr=False, compare=False)
    extent: tuple | None = field(default=None, repr=False, compare=False)

    @property
    def wavelengths(self) -> np.ndarray:
        return np.concatenate([self.vnir_wavelengths, self.swir_wavelengths])

    @property
    def fwhm(self) -> np.ndarray:
        return np.concatenate([self.vnir_fwhm, self.swir_fwhm])

    @property
    def lines(self) -> int:
        return self.vnir.shape[1]

    def reflectance(self) -> np.ndarray:
        """(198, lines, cols) true surface reflectance of each VNIR footprint (linear mixture)."""
        spectra = np.stack([self.endmember_spectra[n] for n in self.abundance_names])
        return np.einsum("kb,klc->blc", spectra, self.abundances).astype("float32")


@dataclass(frozen=True)
class Sun:
    """The sun's direction: zenith and azimuth (degrees, azimuth clockwise from the flight
    direction) and the unit vector towards it."""

    zenith_deg: float
    azimuth_deg: float

    @property
    def vector(self) -> np.ndarray:
        return sun_vector(self.zenith_deg, self.azimuth_deg)

    @property
    def tan_zenith(self):
        return np.tan(np.radians(self.zenith_deg))

    @property
    def cos_zenith(self) -> float:
        return float(np.cos(np.radians(self.zenith_deg)))


@dataclass(frozen=True)
class Clouds:
    """The cloud layer: opacity (0–1) on a coarse ``window`` at ``height_m`` above ground."""

    window: Window
    opacity: np.ndarray
    height_m: float


@dataclass(frozen=True)
class SunMaps:
    """The sun geometry of one block on its fine grid ``window``.

    ``maps`` (K + 4, ny, nx): the K material fractions, the direct-sun factor (cos i, cast
    and cloud shadows), the sky view, the shadow fraction and the texture's brightness
    factor; ``heights``: the surface for ray intersection, between ``z_lo`` and ``z_hi``.
    """

    window: Window
    maps: np.ndarray
    heights: Heights
    z_lo: float
    z_hi: float


@dataclass
class Footprints:
    """Per-pixel coefficients of one instrument (lines, 286), averaged over each pixel's rays.

    ``direct``/``sky`` (K, lines, cols): fraction of each material times its direct-sun
    (cos i, unshadowed, cloud-free, texture factor) and sky-view terms; ``direct_plain``/
    ``sky_plain``: the same for a texture-free surface of any material (a target's share);
    ``cloud_direct``/``cloud_sky``: the cloud's share lit by the sun and the sky; ``x``/``y``:
    the mean ground point (m, track frame).
    """

    direct: np.ndarray
    sky: np.ndarray
    cloud_direct: np.ndarray
    cloud_sky: np.ndarray
    direct_plain: np.ndarray
    sky_plain: np.ndarray
    x: np.ndarray
    y: np.ndarray

    @classmethod
    def zeros(cls, materials: int, lines: int) -> Footprints:
        per_material = (materials, lines, COLS)
        return cls(
            direct=np.zeros(per_material, "float32"),
            sky=np.zeros(per_material, "float32"),
            cloud_direct=np.zeros((lines, COLS), "float32"),
            cloud_sky=np.zeros((lines, COLS), "float32"),
            direct_plain=np.zeros((lines, COLS), "float32"),
            sky_plain=np.zeros((lines, COLS), "float32"),
            x=np.zeros((lines, COLS), "float64"),
            y=np.zeros((lines, COLS), "float64"),
        )

    def put(self, rows: slice, block: Footprints) -> None:
        """Store a block's coefficients at image lines ``rows``."""
        for name, array in vars(block).items():
            getattr(self, name)[..., rows, :] = array


@dataclass
class GroundTruth:
    """The truth on the VNIR pixel grid (box footprints, no PSF): material ``abundances``
    (K, lines, cols), ``shadow`` fraction, surface height ``z`` and ``cloud`` cover."""

    abundances: np.ndarray
    shadow: np.ndarray
    z: np.ndarray
    cloud: np.ndarray

    @classmethod
    def zeros(cls, materials: int, lines: int) -> GroundTruth:
        return cls(
            abundances=np.zeros((materials, lines, COLS), "float32"),
            shadow=np.zeros((lines, COLS), "float32"),
            z=np.zeros((lines, COLS), "float32"),
            cloud=np.zeros((lines, COLS), "float32"),
        )

    def put(self, rows: slice, block: GroundTruth) -> None:
        """Store a block's truth at image lines ``rows``."""
        for name, array in vars(block).items():
            getattr(self, name)[..., rows, :] = array


def simulate_scene(
    preset: str = PRESET,
    lines: int = LINES,
    seed: int = 0,
    *,
    geometry: str = GEOMETRY,
    squint_deg: float | None = None,
    flying_height: float | None = None,
    nominal_altitude: float | None = None,
    line_spacing: float | None = None,
    boresight_vnir_deg=None,
    boresight_swir_deg=None,
    sun_zenith: float | None = None,
    sun_azimuth: float | None = None,
    targets: int | None = None,
    clouds: int = 0,
    cloud_height: float | None = None,
    aot550: float = AOT550,
    water_vapour_cm: float = WATER_VAPOUR_CM,
    noise_free: bool = False,
    supersample: int = SUPERSAMPLE,
    surface: Surface | None = None,
    texture: bool = True,
    cast_shadows: bool = True,
    sky_obstruction: bool = False,
    progress: Progress | None = None,
) -> Scene:
    """Simulate a VNIR + SWIR pushbroom scene with its ground truth.

    Parameters
    ----------
    preset : {"urban", "dunes", "glade", "mixed"}
        The surface (see :mod:`.presets`); ignored for the surface when ``surface`` is given,
        but still sets the default sun angles and target count.
    lines : int
        Along-track lines (286 across-track pixels each).
    seed : int
        Seed of every random choice (surface, targets, clouds, noise): same seed, same scene.
    geometry : {"realistic", "large-squint"}
        Flight and squint defaults (see :mod:`.presets`); ``squint_deg``, ``flying_height``,
        ``nominal_altitude`` (m; the vendor's co-registration altitude) and ``line_spacing``
        (m, default = flying height × IFOV) override them. ``boresight_*_deg`` give full
        (roll, pitch, yaw) angles per instrument instead of the squint.
    sun_zenith, sun_azimuth : float
        Degrees; azimuth clockwise from the flight direction. Defaults from the paper's scenes.
    targets : int
        Number of sub-pixel gray plastic bags (35 × 55 cm) on open ground.
    clouds : int
        Number of cloud blobs at ``cloud_height`` (m above ground, default 40 % of the flying
        height), seen with each instrument's parallax and casting shadows.
    aot550, water_vapour_cm : float
        Aerosol optical depth at 550 nm and water-vapour column.
    noise_free : bool
        True gives noise-free, unquantised DN (float32): for tests and planning.
    supersample : int
        Rays per pixel side (footprint integration and sub-pixel shadow fraction).
    surface : Surface
        A custom surface instead of the preset's (its own ``brightness`` fields, if any, are
        used; ``texture`` does not add any).
    texture : bool
        Give a preset's materials their sub-material brightness texture (soil moisture and
        stones, grass density, sand patches, stains; :data:`.presets.TEXTURE`, drawn from
        its own generator so the scene's layout is the same either way). False gives
        uniform materials (each exactly its library spectrum): for tests and comparisons.
    cast_shadows : bool
        False gives the scene's sunlit twin: no surface casts a shadow, so every surface that
        faces the sun gets its direct light (self-shade, clouds and everything else as with
        True, same layout). A shadowed pixel's twin is its own sunlit signal, under its own
        sky view: the reference a de-shadowing is checked against.
    sky_obstruction : bool
        True: the sky light of each cell is also cut by the surfaces around it that hide part
        of the sky (walls, crowns, slopes within :data:`SKY_REACH_M`; horizon-elevation sky
        view, :func:`.shadow.horizon_sky`), as in street canyons. False (the default, with
        which the bundled sample was made): only the cell's own tilt, ``(1 + cos slope)/2``.
    progress : Progress, optional

    Returns
    -------
    Scene
        The two DN cubes, the band set and the truth arrays (nothing is written: see
        :func:`geoboresight.io.scene.write_scene`).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: the
    AISA-Dual's two optics and their boresight offset; Eq. 3; section 3.3: the targets).
    """
    lines = _check_scene(preset, lines)
    progress = as_progress(progress)
    geo = flight_geometry(
        geometry,
        squint_deg,
        flying_height,
        nominal_altitude,
        line_spacing,
        boresight_vnir_deg,
        boresight_swir_deg,
    )
    sun = _sun(preset, sun_zenith, sun_azimuth)
    n_targets = _presets.DEFAULT_TARGETS[preset] if targets is None else int(targets)
    H = geo.flying_height
    z_cloud = CLOUD_HEIGHT_FRACTION * H if cloud_height is None else float(cloud_height)
    rng = np.random.default_rng(seed)

    # 1. Layout, surface and clouds (one generator, drawn in this order: same seed, same scene).
    extent, core = scene_extent(geo, lines, sun)
    if surface is None:
        surface = preset_surface(preset, rng, extent, core, seed=seed, texture=texture)
    progress.update(0.05, "surface built")
    names = list(surface.materials)
    if n_targets:
        names.append(TARGET)
    cloud = cloud_layer(rng, geo, extent, core, int(clouds), z_cloud) if clouds else None

    # Spectra and atmosphere at the band set.
    vwl, vfw, swl, sfw = aisa_dual_bands()
    all_wl, all_fw = np.concatenate([vwl, swl]), np.concatenate([vfw, sfw])
    spectra = band_spectra([*names, "cloud"], all_wl, all_fw)
    ill = illumination(
        all_wl, all_fw, sun.zenith_deg, H, aot550=aot550, water_vapour_cm=water_vapour_cm
    )

    # 2–4. Ray tracing, block by block; then the targets.
    footprints, truth = trace_footprints(
        geo,
        surface,
        names,
        lines,
        sun,
        cloud,
        int(supersample),
        progress.sub(0.05, 0.65),
        cast_shadows=cast_shadows,
        sky_obstruction=sky_obstruction,
    )
    target_list, target_abundance = _targets(
        rng, n_targets, names, truth, footprints, lines, progress
    )

    # 5–6. Radiance and DN, per instrument.
    cubes = _cubes(footprints, names, spectra, ill, all_wl, len(vwl), seed, noise_free)
    progress.update(0.95, "radiometry done")

    material, material_names = material_map(truth.abundances, names, has_target=bool(n_targets))
    truth_json = _truth_dict(
        preset,
        seed,
        lines,
        geo,
        sun.zenith_deg,
        sun.azimuth_deg,
        material_names,
        target_list,
        not noise_free,
        aot550,
        water_vapour_cm,
        clouds,
        z_cloud,
        supersample,
        geometry,
    )
    abundances = np.concatenate([truth.abundances * (1 - truth.cloud), truth.cloud[None]])
    ab_names = (*names, "cloud")
    return Scene(
        vnir=cubes["vnir"],
        swir=cubes["swir"],
        vnir_wavelengths=vwl,
        swir_wavelengths=swl,
        vnir_fwhm=vfw,
        swir_fwhm=sfw,
        dsm=np.maximum(truth.z, 0.0),  # bisection leaves < 1 cm; heights are >= 0
        shadow_fraction=np.clip(truth.shadow, 0, 1),
        target_abundance=np.clip(target_abundance, 0, 1),
        cloud_mask=truth.cloud > 0.5,
        material=material,
        material_names=material_names,
        abundances=np.clip(abundances, 0, 1).astype("float32"),
        abundance_names=ab_names,
        endmember_spectra={n: spectra[n].astype("float64") for n in ab_names},
        truth=truth_json,
        ground_xy=np.stack([footprints["vnir"].x, footprints["vnir"].y]),
        surface=surface,
        extent=tuple(float(v) for v in extent),
    )


def _check_scene(preset: str, lines) -> int:
    """The preset checked and the number of lines as an int (at least :data:`MIN_LINES`)."""
    if preset not in _presets.SCENES:
        raise ParameterError(
            f"parameter 'preset': {preset!r} is not one of {', '.join(_presets.SCENES)}"
        )
    lines = int(lines)
    if lines < MIN_LINES:
        raise ParameterError(
            f"parameter 'lines': {lines} is too few; simulate at least {MIN_LINES} lines"
        )
    return lines


def _targets(rng, n_targets, names, truth, footprints, lines, progress):
    """Step 4: ``n_targets`` targets placed on open, flat, sunlit ground and added to the
    footprints and the truth; (their list, their abundance on the VNIR grid)."""
    target_list, target_abundance = [], np.zeros((lines, COLS), "float32")
    if n_targets:
        target_list = place_targets(rng, n_targets, names, truth, footprints["vnir"])
        if len(target_list) < n_targets:
            progress.info(
                f"only {len(target_list)} of {n_targets} targets fit on open, flat, sunlit ground "
                "at least 6 pixels apart: simulate more lines for more targets"
            )
        target_abundance = add_targets(target_list, names.index(TARGET), footprints, truth)
    return target_list, target_abundance


def _cubes(footprints, names, spectra, ill, all_wl, nv, seed, noise_free) -> dict:
    """Steps 5–6: each instrument's DN cube from its footprints (blurred by its PSF), the
    materials' spectra and the illumination at its bands (``nv`` VNIR bands first); the
    noise of each drawn from its own generator."""
    spec = np.stack([spectra[n] for n in names])  # (K, 198)
    cubes = {}
    for n_inst, (inst, det, sl) in enumerate(
        (("vnir", VNIR, slice(0, nv)), ("swir", SWIR, slice(nv, None)))
    ):
        cubes[inst] = instrument_cube(
            psf_blur(footprints[inst], det.psf_sigma_px),
            det,
            spec[:, sl],
            spectra["cloud"][sl],
            _band_slice(ill, sl),
            all_wl[sl],
            None if noise_free else np.random.default_rng([seed, 101 + n_inst]),
        )
    return cubes


def flight_geometry(
    geometry: str = GEOMETRY,
    squint_deg=None,
    flying_height=None,
    nominal_altitude=None,
    line_spacing=None,
    boresight_vnir_deg=None,
    boresight_swir_deg=None,
) -> Geometry:
    """The flight and both instruments' lines of sight: a geometry preset (see
    :mod:`.presets`) with any of its values overridden (see :func:`simulate_scene`)."""
    if geometry not in _presets.GEOMETRIES:
        raise ParameterError(
            f"parameter 'geometry': {geometry!r} is not one of {', '.join(_presets.GEOMETRIES)}"
        )
    g = _presets.GEOMETRIES[geometry]
    squint = g["squint_deg"] if squint_deg is None else float(squint_deg)
    H = g["flying_height"] if flying_height is None else float(flying_height)
    Hn = nominal_altitude if nominal_altitude is not None else g["nominal_altitude"]
    Hn = H if Hn is None else float(Hn)
    if not 100.0 <= H <= 10000.0:
        raise ParameterError(f"parameter 'flying_height': {H} m is outside 100–10,000 m")
    if abs(squint) > 10:
        raise ParameterError(f"parameter 'squint_deg': {squint}° is outside ±10°")
    spacing = H * IFOV_MRAD * 1e-3 if line_spacing is None else float(line_spacing)
    bv = tuple(boresight_vnir_deg) if boresight_vnir_deg is not None else (0.0, 0.0, 0.0)
    bs = tuple(boresight_swir_deg) if boresight_swir_deg is not None else (0.0, bv[1] + squint, 0.0)
    return Geometry(
        flying_height=H,
        nominal_altitude=Hn,
        vnir=Instrument(*bv),
        swir=Instrument(*bs),
        line_spacing=spacing,
    )


def _sun(preset: str, zenith, azimuth) -> Sun:
    zen = _presets.SUN[preset][0] if zenith is None else float(zenith)
    azi = _presets.SUN[preset][1] if azimuth is None else float(azimuth)
    if not 0.0 <= zen < 85.0:
        raise ParameterError(f"parameter 'sun_zenith': {zen}° is outside 0–85°")
    return Sun(zen, azi)


def scene_extent(geo: Geometry, lines: int, sun: Sun):
    """Stage 1, the layout: ``(extent, core)`` as (x0, x1, y0, y1) in metres (track frame).

    ``core`` holds every ray's ground point for heights 0 to :data:`Z_BOUND_M`; ``extent``
    adds a margin and the reach of shadows cast from outside (any direction).
    """
    H = geo.flying_height
    shadow_reach = min(Z_BOUND_M * sun.tan_zenith, MAX_SHADOW_REACH_M)
    ext = []
    for inst in INSTRUMENTS:
        t, u, v = geo.rays(inst, np.array([0, lines - 1]), np.array([0, COLS - 1]), 1)
        for z in (0.0, Z_BOUND_M):
            ext.append(((H - z) * u, t * geo.line_spacing + (H - z) * v))
    xs = np.concatenate([e[0].ravel() for e in ext])
    ys = np.concatenate([e[1].ravel() for e in ext])
    pad = 10.0 + geo.line_spacing * 2
    extent = (
        xs.min() - pad - shadow_reach,
        xs.max() + pad + shadow_reach,
        ys.min() - pad - shadow_reach,
        ys.max() + pad + shadow_reach,
    )
    return extent, (xs.min(), xs.max(), ys.min(), ys.max())


def preset_surface(
    preset: str, rng: np.random.Generator, extent, core, *, seed: int = 0, texture: bool = True
) -> Surface:
    """Stage 1, the surface of a preset over ``extent`` (relief normalised over ``core``),
    with its sub-material texture drawn from its own generator ``(seed, 303)``."""
    surface = _presets.BUILDERS[preset](rng, extent, core=core)
    if texture:
        surface = _presets.add_texture(surface, np.random.default_rng([seed, 303]))
    return surface


def cloud_layer(
    rng: np.random.Generator, geo: Geometry, extent, core, count: int, height_m: float
) -> Clouds:
    """Stage 1, the clouds: ``count`` blobs centred over the image as seen at the cloud
    layer (the swath narrows with height)."""
    H = geo.flying_height
    shrink = (H - height_m) / H
    image_area = (core[0] * shrink, core[1] * shrink, core[2], core[3])
    window, opacity = _clouds(rng, extent, image_area, count)
    return Clouds(window, opacity, height_m)


def band_spectra(names, wavelengths, fwhm) -> dict[str, np.ndarray]:
    """Each material's reflectance averaged over the bands' Gaussian responses."""
    return {n: band_average(material_spectrum(n), wavelengths, fwhm) for n in names}


def _bilinear(maps: np.ndarray, win: Window, x, y) -> np.ndarray:
    """Sample (K, ny, nx) maps at points (x, y): (K, n), bilinear, edges clamped."""
    i, j = win.ij(x, y)
    i = np.clip(i, 0, win.ny - 1.000001)
    j = np.clip(j, 0, win.nx - 1.000001)
    i0 = np.floor(i).astype(np.intp)
    j0 = np.floor(j).astype(np.intp)
    fi = (i - i0).astype("float32")
    fj = (j - j0).astype("float32")
    flat = maps.reshape(maps.shape[0], -1)
    k00 = i0 * win.nx + j0
    out = flat[:, k00] * ((1 - fi) * (1 - fj))
    out += flat[:, k00 + 1] * ((1 - fi) * fj)
    out += flat[:, k00 + win.nx] * (fi * (1 - fj))
    out += flat[:, k00 + win.nx + 1] * (fi * fj)
    return out


def _clouds(rng, extent, image_area, count, cell=4.0):
    """Cloud opacity field (0–1) on a coarse grid over ``extent``: ``count`` fractal blobs."""
    x0, x1, y0, y1 = extent
    nx, ny = int((x1 - x0) / cell) + 2, int((y1 - y0) / cell) + 2
    Y, X = np.mgrid[0:ny, 0:nx] * cell
    X, Y = X + x0, Y + y0
    opacity = np.zeros((ny, nx))
    texture = smooth_field(rng, (ny, nx), 2.5)
    for _ in range(count):
        cx, cy = rng.uniform(*image_area[:2]), rng.uniform(*image_area[2:])
        rx, ry = rng.uniform(25, 70), rng.uniform(25, 70)
        d = np.sqrt(((X - cx) / rx) ** 2 + ((Y - cy) / ry) ** 2)
        opacity = np.maximum(opacity, np.clip(2.5 * (1 - d) + 0.4 * texture, 0, 1))
    return Window(x0 - 0.5 * cell, y0 - 0.5 * cell, nx, ny, cell), opacity.astype("float32")


def trace_footprints(
    geo: Geometry,
    surface: Surface,
    names: list[str],
    lines: int,
    sun: Sun,
    clouds: Clouds | None,
    sub: int,
    progress: Progress | None = None,
    block_lines: int = BLOCK_LINES,
    cast_shadows: bool = True,
    sky_obstruction: bool = False,
) -> tuple[dict[str, Footprints], GroundTruth]:
    """Stages 2–4 for the whole flight line, in blocks of ``block_lines`` lines (each block
    has its own fine grid, so the block size moves the grid by a fraction of a cell).

    ``names`` are the surface's materials, then the target's if any (its fractions start
    at 0 and are set by :func:`add_targets`). Returns each instrument's :class:`Footprints`
    and the :class:`GroundTruth` on the VNIR grid.
    """
    K = len(names)
    cell = geo.gsd_m / 3.0
    z_top = surface.max_height() + 0.5
    footprints = {inst: Footprints.zeros(K, lines) for inst in INSTRUMENTS}
    truth = GroundTruth.zeros(K, lines)

    def block(l0, l1):
        rays = {
            inst: geo.rays(inst, np.arange(l0, l1), np.arange(COLS), sub) for inst in INSTRUMENTS
        }
        win = block_window(rays, geo, z_top, sun, cell, SKY_REACH_M if sky_obstruction else 0.0)
        maps = sun_maps(surface, win, names, sun, clouds, cast_shadows, sky_obstruction)
        return trace_block(rays, geo, maps, K, clouds, sun)

    progress = as_progress(progress)
    for l0 in range(0, lines, block_lines):
        rows = slice(l0, min(l0 + block_lines, lines))
        blocks, vnir_truth = block(rows.start, rows.stop)
        for inst in INSTRUMENTS:
            footprints[inst].put(rows, blocks[inst])
        truth.put(rows, vnir_truth)
        progress.update(rows.stop / lines, f"ray-traced lines {rows.start}-{rows.stop - 1}")
    return footprints, truth


def block_window(
    rays: dict, geo: Geometry, z_top: float, sun: Sun, cell: float, around: float = 0.0
) -> Window:
    """Stage 2, the fine grid of a block: every ray of the block at heights 0 to ``z_top``,
    extended towards the sun (objects there cast shadows into the block) and by ``around``
    metres on every side (objects there hide part of the sky)."""
    H = geo.flying_height
    s = sun.vector
    px, py = [], []
    for t, u, v in rays.values():
        for z in (0.0, z_top):
            px.append(((H - z) * u).ravel())
            py.append((t * geo.line_spacing + (H - z) * v).ravel())
    px, py = np.concatenate(px), np.concatenate(py)
    reach = min(z_top * sun.tan_zenith, MAX_SHADOW_REACH_M)
    m = 3 * cell + around
    wx0 = px.min() - m - reach * (s[0] < 0)
    wx1 = px.max() + m + reach * (s[0] > 0)
    wy0 = py.min() - m - reach * (s[1] < 0)
    wy1 = py.max() + m + reach * (s[1] > 0)
    return Window(
        wx0, wy0, int(np.ceil((wx1 - wx0) / cell)), int(np.ceil((wy1 - wy0) / cell)), cell
    )


def sun_maps(
    surface: Surface,
    win: Window,
    names: list[str],
    sun: Sun,
    clouds: Clouds | None,
    cast_shadows: bool = True,
    sky_obstruction: bool = False,
) -> SunMaps:
    """Stage 2, the sun geometry on the fine grid ``win`` (see :class:`SunMaps`); without
    ``cast_shadows`` only self-shade (cos i ≤ 0) and clouds keep the sun off a cell."""
    has_target = names[-1] == TARGET
    cell = win.cell
    dsm, frac, ground_z = surface.rasterize(win, names[:-1] if has_target else names)
    heights = Heights(ground_z, dsm, win)
    if has_target:
        frac = np.concatenate([frac, np.zeros((1, *dsm.shape), "float32")])
    zen, azi = sun.zenith_deg, sun.azimuth_deg
    cos_i = incidence(dsm, cell, zen, azi, ground_z)
    lit = cos_i > 0
    if cast_shadows:
        lit &= ~cast_shadow(dsm, cell, zen, azi)
    if clouds is not None:
        s = sun.vector
        gx, gy = win.xy(np.arange(win.ny)[:, None], np.arange(win.nx)[None, :])
        d = np.clip(clouds.height_m - dsm, 0, None) * sun.tan_zenith / max(np.hypot(*s[:2]), 1e-9)
        cx = gx + d * s[0]
        cy = gy + d * s[1]
        c_sh = _bilinear(clouds.opacity[None], clouds.window, cx.ravel(), cy.ravel())[0]
        sunlit = lit * (1.0 - c_sh.reshape(dsm.shape))
    else:
        sunlit = lit.astype("float32")
    direct = (np.clip(cos_i, 0, None) * sunlit).astype("float32")
    sky = sky_view(dsm, cell, ground_z)
    if sky_obstruction:
        sky = sky * horizon_sky(dsm, cell, SKY_REACH_M)
    sky = sky.astype("float32")
    bright = surface.brightness_on(win, frac, names)
    maps = np.concatenate(
        [
            frac,
            direct[None],
            sky[None],
            (1.0 - sunlit)[None].astype("float32"),
            bright[None],
        ]
    )
    return SunMaps(win, maps, heights, float(dsm.min()) - 0.01, float(dsm.max()) + 0.01)


def trace_block(
    rays: dict,
    geo: Geometry,
    fine: SunMaps,
    K: int,
    clouds: Clouds | None,
    sun: Sun,
) -> tuple[dict[str, Footprints], GroundTruth]:
    """Stages 3–4 for one block: each instrument's rays intersected with the surface, the
    maps of ``fine`` (:func:`sun_maps`) sampled at the hits and averaged per pixel.

    Returns each instrument's block :class:`Footprints` and the block's VNIR truth.
    """
    H = geo.flying_height
    cos_z = sun.cos_zenith
    out = {}
    truth = None
    for inst, (t, u, v) in rays.items():
        n_lines, _, rays_per_pixel = t.shape
        tt, uu, vv = t.ravel(), u.ravel(), v.ravel()
        x, y, z = intersect(tt, uu, vv, geo, fine.heights, fine.z_lo, fine.z_hi)
        s = _bilinear(fine.maps, fine.window, x, y)
        fr, di, sk = s[:K], s[K], s[K + 1]
        if clouds is not None:
            h = H - clouds.height_m
            c = _bilinear(
                clouds.opacity[None], clouds.window, h * uu, tt * geo.line_spacing + h * vv
            )[0]
        else:
            c = np.zeros_like(di)
        shape = (K, n_lines, COLS, rays_per_pixel)

        def mean(a, shape=shape[1:]):
            return a.reshape(shape).mean(-1)

        ground = 1.0 - c
        br = s[K + 3]
        out[inst] = Footprints(
            direct=mean(fr * (di * ground * br), shape),
            sky=mean(fr * (sk * ground * br), shape),
            cloud_direct=mean(c * cos_z),
            cloud_sky=mean(c),
            direct_plain=mean(di * ground),
            sky_plain=mean(sk * ground),
            x=mean(x),
            y=mean(y),
        )
        if inst == "vnir":
            truth = GroundTruth(
                abundances=mean(fr, shape), shadow=mean(s[K + 2]), z=mean(z), cloud=mean(c)
            )
    return out, truth


def place_targets(
    rng: np.random.Generator, n: int, names: list[str], truth: GroundTruth, vnir: Footprints
) -> list[dict]:
    """Stage 4: up to ``n`` bags at VNIR pixel centres on open, sunlit, cloud-free, flat
    ground, at least 6 pixels apart (a list of target dicts, as in ``truth.json``)."""
    open_ids = [names.index(m) for m in OPEN_GROUND if m in names]
    shadow = truth.shadow
    openness = truth.abundances[open_ids].sum(0) if open_ids else np.zeros(shadow.shape)
    ok = (openness > 0.99) & (shadow < 0.01) & (truth.cloud < 0.01)
    # Flat: no height change within 3 pixels (no building or tree nearby).
    zmax = ndimage.maximum_filter(truth.z, 7)
    zmin = ndimage.minimum_filter(truth.z, 7)
    ok &= (zmax - zmin) < 2.0
    ok[:4] = ok[-4:] = False
    ok[:, :4] = ok[:, -4:] = False
    rows, cols = np.nonzero(ok)
    order = rng.permutation(len(rows))
    chosen = []
    for k in order:
        r, c = rows[k], cols[k]
        if all(max(abs(r - r2), abs(c - c2)) >= 6 for r2, c2 in chosen):
            chosen.append((int(r), int(c)))
        if len(chosen) == n:
            break
    return [
        {
            "row": r,
            "col": c,
            "x_m": float(vnir.x[r, c]),
            "y_m": float(vnir.y[r, c]),
            "size_m": list(BAG_SIZE_M),
            "material": TARGET,
        }
        for r, c in chosen
    ]


def target_cover(targets: list[dict], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Fraction of each pixel's footprint covered by the bags (rectangle overlap); ``x``,
    ``y`` are the footprint centres (m)."""
    cover = np.zeros(x.shape, "float64")
    lines, cols = x.shape
    for t in targets:
        bx0, bx1 = t["x_m"] - BAG_SIZE_M[0] / 2, t["x_m"] + BAG_SIZE_M[0] / 2
        by0, by1 = t["y_m"] - BAG_SIZE_M[1] / 2, t["y_m"] + BAG_SIZE_M[1] / 2
        # Pixels whose footprint centres are near the bag.
        d = (x - t["x_m"]) ** 2 + (y - t["y_m"]) ** 2
        r, c = np.unravel_index(np.argmin(d), d.shape)
        r0, r1 = max(r - 3, 0), min(r + 4, lines)
        c0, c1 = max(c - 3, 0), min(c + 4, cols)
        px, py = x[r0:r1, c0:c1], y[r0:r1, c0:c1]
        # Footprint size from the neighbouring pixel centres (box = one pixel pitch).
        wx = np.gradient(x, axis=1)[r0:r1, c0:c1]
        wy = np.gradient(y, axis=0)[r0:r1, c0:c1]
        ox = np.clip(np.minimum(px + wx / 2, bx1) - np.maximum(px - wx / 2, bx0), 0, None)
        oy = np.clip(np.minimum(py + wy / 2, by1) - np.maximum(py - wy / 2, by0), 0, None)
        cover[r0:r1, c0:c1] += ox * oy / (wx * wy)
    return np.clip(cover, 0, 1)


def add_targets(
    targets: list[dict],
    k: int,
    footprints: dict[str, Footprints],
    truth: GroundTruth,
) -> np.ndarray:
    """Stage 4: the bags replace their share of each instrument's footprints (material
    ``k``, in place); the VNIR truth abundances follow, and each target gets its
    ``abundance``. Returns the target abundance on the VNIR grid (float32)."""
    abundance = None
    for inst in INSTRUMENTS:
        a = footprints[inst]
        cover = target_cover(targets, a.x, a.y)
        # The bag has its own reflectance: the ground's texture does not apply to it.
        a.direct *= 1.0 - cover
        a.sky *= 1.0 - cover
        a.direct[k] += cover * a.direct_plain
        a.sky[k] += cover * a.sky_plain
        if inst == "vnir":
            abundance = cover.astype("float32")
            for t in targets:
                t["abundance"] = float(cover[t["row"], t["col"]])
            truth.abundances *= 1.0 - cover
            truth.abundances[k] += cover
    return abundance


def psf_blur(footprints: Footprints, sigma_px: float) -> Footprints:
    """Stage 5: the instrument's Gaussian PSF (σ in pixels) over the coefficient images that
    make radiance (a new :class:`Footprints`; the ground points are kept)."""
    sig = sigma_px
    return Footprints(
        direct=ndimage.gaussian_filter(footprints.direct, (0, sig, sig), mode="nearest"),
        sky=ndimage.gaussian_filter(footprints.sky, (0, sig, sig), mode="nearest"),
        cloud_direct=ndimage.gaussian_filter(footprints.cloud_direct, sig, mode="nearest"),
        cloud_sky=ndimage.gaussian_filter(footprints.cloud_sky, sig, mode="nearest"),
        direct_plain=footprints.direct_plain,
        sky_plain=footprints.sky_plain,
        x=footprints.x,
        y=footprints.y,
    )


def _band_slice(ill: Illumination, bands: slice) -> Illumination:
    return Illumination(ill.direct[bands], ill.diffuse[bands], ill.path[bands], ill.t_up[bands])


def at_sensor_radiance(
    direct: np.ndarray,
    sky: np.ndarray,
    cloud_direct: np.ndarray,
    cloud_sky: np.ndarray,
    reflectance: np.ndarray,
    cloud_reflectance: np.ndarray,
    ill: Illumination,
) -> np.ndarray:
    """Stage 5: (bands, lines, cols) radiance at the sensor, float32:
    ``L = T_up/π · (Σ_m ρ_m (D_m E_dir + F_m E_sky) + ρ_c (D_c E_dir + F_c E_sky)) + L_path``.

    ``direct``/``sky`` (K, lines, cols) and ``cloud_direct``/``cloud_sky`` (lines, cols) are
    the coefficients of :class:`Footprints`, ``reflectance`` (K, bands) the materials' and
    ``cloud_reflectance`` (bands,) the cloud's, ``ill`` the atmosphere at the bands.
    """
    rad = np.einsum("kb,klc->blc", reflectance * ill.direct, direct)
    rad += np.einsum("kb,klc->blc", reflectance * ill.diffuse, sky)
    rad += (cloud_reflectance * ill.direct)[:, None, None] * cloud_direct[None]
    rad += (cloud_reflectance * ill.diffuse)[:, None, None] * cloud_sky[None]
    rad = rad * (ill.t_up / np.pi)[:, None, None] + ill.path[:, None, None]
    return rad.astype("float32")


def instrument_cube(
    footprints: Footprints,
    detector: Detector,
    reflectance: np.ndarray,
    cloud_reflectance: np.ndarray,
    ill: Illumination,
    wavelengths: np.ndarray,
    rng: np.random.Generator | None,
    block_lines: int = NOISE_BLOCK_LINES,
) -> np.ndarray:
    """Stages 5–6 for one instrument: radiance and then DN (:meth:`.sensor.Detector.to_dn`),
    in blocks of ``block_lines`` lines. ``rng=None``: noise-free float32 DN (the noise, drawn
    block by block, depends on the block size)."""
    lines = footprints.x.shape[0]
    cube = np.zeros((reflectance.shape[1], lines, COLS), "uint16" if rng is not None else "float32")

    def block(l0, l1):
        rows = slice(l0, l1)
        rad = at_sensor_radiance(
            footprints.direct[:, rows],
            footprints.sky[:, rows],
            footprints.cloud_direct[rows],
            footprints.cloud_sky[rows],
            reflectance,
            cloud_reflectance,
            ill,
        )
        return detector.to_dn(rad, wavelengths, rng)

    # In line order: the noise generator draws the same numbers every run.
    for l0 in range(0, lines, block_lines):
        l1 = min(l0 + block_lines, lines)
        cube[:, l0:l1] = block(l0, l1)
    return cube


def material_map(
    abundances: np.ndarray, names: list[str], has_target: bool
) -> tuple[np.ndarray, dict[int, str]]:
    """The dominant surface material id per pixel (targets left out) and the names of the
    ids used (those of the map and of every material of the scene)."""
    material_ids = np.array([MATERIAL_IDS[n] for n in names], "uint8")
    material = material_ids[np.argmax(abundances[:-1] if has_target else abundances, axis=0)]
    used = sorted(set(np.unique(material).tolist()) | {int(i) for i in material_ids})
    return material, {int(i): MATERIALS[int(i)] for i in used}


def _truth_dict(
    preset,
    seed,
    lines,
    geo,
    zen,
    azi,
    material_names,
    targets,
    noise,
    aot,
    wv,
    clouds,
    zc,
    sub,
    geometry,
):
    gt = geo.truth()
    squint = round(float(np.degrees(np.arctan(gt["tan_squint"]))), 9)
    return {
        "preset": preset,
        "geometry": geometry,
        "seed": int(seed),
        "lines": int(lines),
        "cols": COLS,
        "bands": {"vnir": 96, "swir": 102},
        "gsd_m": geo.gsd_m,
        "line_spacing_m": geo.line_spacing,
        "ifov_mrad": geo.vnir.ifov_mrad,
        "flying_height_m": geo.flying_height,
        "nominal_altitude_m": geo.nominal_altitude,
        "squint_deg": squint,
        "boresight_deg": {
            "vnir": [geo.vnir.roll_deg, geo.vnir.pitch_deg, geo.vnir.yaw_deg],
            "swir": [geo.swir.roll_deg, geo.swir.pitch_deg, geo.swir.yaw_deg],
        },
        "vendor_coregistration_px": dict(
            zip(("along", "across"), geo.coregistration(), strict=True)
        ),
        "offset_px": gt["offset_px"],
        "offset_convention": (
            "SWIR relative to VNIR on flat ground at height 0, in VNIR pixels: a feature at "
            "VNIR row r, column c appears at SWIR row r + along, column c + across"
        ),
        "disparity_px_per_m": gt["disparity_px_per_m"],
        "height_precision_m_per_px": gt["height_precision_m_per_px"],
        "sun": {"zenith_deg": zen, "azimuth_deg": azi, "azimuth_reference": "flight direction"},
        "atmosphere": {"aot550": aot, "water_vapour_cm": wv},
        "materials": {str(k): v for k, v in material_names.items()},
        "targets": targets,
        "clouds": {"count": int(clouds), "height_m": zc if clouds else None},
        "noise": {
            "enabled": bool(noise),
            "vnir": {
                "dark_dn": VNIR.dark_dn,
                "gain": VNIR.gain,
                "electrons_per_dn": VNIR.electrons_per_dn,
                "read_noise_dn": VNIR.read_noise_dn,
                "psf_sigma_px": VNIR.psf_sigma_px,
            },
            "swir": {
                "dark_dn": SWIR.dark_dn,
                "gain": SWIR.gain,
                "electrons_per_dn": SWIR.electrons_per_dn,
                "read_noise_dn": SWIR.read_noise_dn,
                "psf_sigma_px": SWIR.psf_sigma_px,
            },
            "bits": 12,
        },
        "supersample": int(sub),
        "heights": "metres above the lowest ground of the simulated area (z = 0)",
    }
