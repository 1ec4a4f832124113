"""File-level scene simulation: a simulated AISA-Dual flight line and its truth, in a folder."""

from __future__ import annotations

import math

from ..errors import ParameterError
from ..io.scene import as_dn, check_scene_folder, write_scene
from ..simulate.scene import (
    LINES,
    PRESET,
    SensorOptions,
    SimulatedFlight,
    Sky,
    simulate_scene,
)

#: Largest boresight angle (degrees) accepted for each of roll, pitch and yaw.
MAX_BORESIGHT_DEG = 10.0


def parse_angles(text, name: str = "boresight angles") -> tuple[float, float, float] | None:
    """``(roll, pitch, yaw)`` in degrees from ``"0,0.3,0"`` (or a sequence of three numbers);
    None for None or an empty string. Each within ±:data:`MAX_BORESIGHT_DEG`."""
    if text is None or (isinstance(text, str) and not text.strip()):
        return None
    try:
        if isinstance(text, str):
            angles = tuple(float(v) for v in text.replace(";", ",").split(","))
        else:
            angles = tuple(float(v) for v in text)
    except (TypeError, ValueError):
        angles = ()
    if len(angles) != 3 or not all(
        math.isfinite(a) and abs(a) <= MAX_BORESIGHT_DEG for a in angles
    ):
        raise ParameterError(
            f"parameter '{name}': give roll,pitch,yaw in degrees (each within "
            f"±{MAX_BORESIGHT_DEG:g}), e.g. 0,0.3,0; got {text!r}"
        )
    return angles


def simulate_file(
    *,
    output,
    preset=PRESET,
    lines=LINES,
    seed=0,
    flight=SimulatedFlight(),
    sky=Sky(),
    targets=None,
    clouds=0,
    cloud_height=None,
    sensor=SensorOptions(),
    merged=False,
    navigation=False,
    capture=False,
    progress=None,
) -> dict:
    """Simulate a raw-geometry AISA-Dual scene (VNIR + SWIR) with its ground truth, into a folder.

    Parameters
    ----------
    output : path
        Folder to create: ``vnir.img/.hdr``, ``swir.img/.hdr`` (ENVI, 12-bit DN), optionally
        ``merged.img/.hdr``, the truth rasters on the VNIR grid, ``truth.json`` and
        ``endmembers.csv`` (see :mod:`geoboresight.io.scene`).
    preset : {"urban", "dunes", "glade", "mixed"}
        The surface.
    lines : int
        Along-track lines (286 pixels each).
    seed : int
        Seed of every random choice: the same seed gives the same files, byte for byte.
    flight : SimulatedFlight
        The geometry preset (``"realistic"``: the paper's 0.3° squint; ``"large-squint"``: 3°,
        relief measurable) and any override of its squint (degrees), flying height and
        co-registration altitude (m), or each instrument's boresight angles
        ``"roll,pitch,yaw"`` in degrees (SWIR's override the squint).
    sky : Sky
        Sun zenith and azimuth (degrees, azimuth clockwise from the flight direction; default:
        the paper's scenes), aerosol optical depth at 550 nm and water-vapour column (cm).
    targets : int, optional
        Number of sub-pixel gray plastic bags (default from the preset).
    clouds : int
        Number of small clouds.
    cloud_height : float, optional
        Cloud height above the ground (m; default 40 % of the flying height).
    sensor : SensorOptions
        Noise-free DN (still rounded to 12 bits) and the rays per pixel side.
    merged : bool
        Also write ``merged.img/.hdr`` with all 198 bands.
    navigation : bool
        Also place the scene on a map (UTM 36N, heading 35°; see
        :mod:`geoboresight.simulate.navigation`) and write ``igm.tif`` (easting and northing
        of each VNIR pixel, for ``geolocate --igm``) and ``ortho.tif`` (an RGB orthophoto of
        the ground, 1 m cells).
    capture : bool
        Also write ``capture.raw/.hdr``, the DN as an AisaFENIX-like raw capture of both
        detectors (two integration times, dark frames, frame counter), and its calibration
        ``capture_cal.cal/.hdr`` (:func:`geoboresight.io.scene.write_capture`), for
        ``radiance`` and ``--vnir-calibration``.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` and the scene's boresight truth: the SWIR−VNIR offset on flat ground
        (``offset_along_px``, ``offset_across_px``), the parallax per metre of relief
        (``disparity_px_per_m``) and the height precision per pixel of matching error
        (``height_precision_m_per_px``).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: the
    AISA-Dual and its boresight offset; section 3.3: the plastic-bag targets).

    Examples
    --------
    >>> import geoboresight as gb
    >>> result = gb.simulate_file(output="out/scene", lines=16)
    >>> round(result["offset_along_px"], 3), round(result["disparity_px_per_m"], 5)
    (1.148, 0.00349)
    >>> import pathlib
    >>> sorted(p.name for p in pathlib.Path("out/scene").glob("*.hdr"))
    ['swir.hdr', 'vnir.hdr']
    """
    # Before the (long) simulation: an existing folder holding the user's own files is never
    # replaced, even with overwrite.
    check_scene_folder(output)
    scene = simulate_scene(
        preset,
        lines=lines,
        seed=seed,
        geometry=flight.geometry,
        squint_deg=flight.squint_deg,
        flying_height=flight.flying_height,
        nominal_altitude=flight.nominal_altitude,
        boresight_vnir_deg=parse_angles(flight.boresight_vnir_deg, "boresight_vnir_deg"),
        boresight_swir_deg=parse_angles(flight.boresight_swir_deg, "boresight_swir_deg"),
        sun_zenith=sky.sun_zenith,
        sun_azimuth=sky.sun_azimuth,
        aot550=sky.aot550,
        water_vapour_cm=sky.water_vapour_cm,
        sky_obstruction=sky.sky_obstruction,
        targets=targets,
        clouds=clouds,
        cloud_height=cloud_height,
        noise_free=sensor.noise_free,
        supersample=sensor.supersample,
        progress=progress.sub(0.0, 0.8 if navigation else 0.9),
    )
    nav = None
    if navigation:
        from ..simulate.navigation import scene_navigation

        progress.update(0.9, "orthophoto")
        nav = scene_navigation(scene, seed=seed)
    raw = None
    if capture:
        from ..simulate.capture import raw_capture

        dn = (as_dn(scene.vnir), as_dn(scene.swir))
        raw = raw_capture(*dn, scene.wavelengths, seed=int(scene.truth["seed"]))
    progress.update(0.95, "writing files")
    # The operation has refused an existing folder unless asked to overwrite it.
    write_scene(scene, output, merged=merged, overwrite=True, navigation=nav, capture=raw)
    progress.update(1.0, "done")
    t = scene.truth
    sigma_h = t["height_precision_m_per_px"]  # None without squint: relief is invisible
    progress.info(
        f"offset SWIR−VNIR on flat ground: along {t['offset_px']['along']:+.3f} px, across "
        f"{t['offset_px']['across']:+.3f} px; parallax {t['disparity_px_per_m']['along']:.4f} px/m; "
        + (
            f"height precision {sigma_h:.1f} m per pixel of matching error"
            if sigma_h is not None
            else "no squint: relief cannot be measured"
        )
    )
    return {
        "output": output,
        "offset_along_px": t["offset_px"]["along"],
        "offset_across_px": t["offset_px"]["across"],
        "disparity_px_per_m": t["disparity_px_per_m"]["along"],
        "height_precision_m_per_px": t["height_precision_m_per_px"],
    }
