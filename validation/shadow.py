"""Validate the shadow application (paper §3.1) on two scene models with known truth.

Scenes come from two models that share no code: the project's simulator
(``geoboresight.simulate``, AISA-Dual-like) and the independent, deliberately simple
``validation/scene_model2.py`` (other earthlib spectra, water, SPCTRAL2-style sky with
adjacency light in shadows, Poisson noise, band-to-band dark levels, HySpex-like bands). They
vary the dark offsets, gains, sun angles, materials (dark roofs, asphalt, water, dark soil,
char) and relief. Each scene is written to disk and run through the published file-level
operations as a rasterio script would:

* ``shadow-map`` (the default product: the mask and the scene-calibrated classes);
* ``shadow-classes`` with Table 2 (mask = classes 1–2);
* ``shadow-cluster`` (Figure 4's Gaussian mixture);
* ``dark-pixel-shadow`` (the ATCOR-4-like baseline);
* ``sun-shadow`` on the true DSM with its default surface (the ground truth the paper uses).

Scores against the model's own truth shadow fraction (shadow = fraction ≥ 0.5): precision,
recall, F1 on every pixel, and F1 "where the shadow is wider than a pixel" (truth shadow that a
2 × 2 opening removes is left out of the count); the share of sunlit dark-material pixels
(fraction < 0.1) flagged; the accuracy of the shadow-map classes against the truth fraction's
Table 2 class; sun-shadow's IoU against the truth.

The parameters of ``shadow-map`` were fixed on the first scene (simulator, urban, 30.8°)
before the others were run (the "tuning" column says which).

Hold-out scenes (``--set holdout`` and the others of :data:`SETS`; :func:`holdout_cases`:
draws of five model-2 seeds and three simulator scenes, conditions drawn at random from
stated ranges) are not looked at while the method is developed.

``--dsm``: the surface-model prior and de-shadowing instead (:func:`run_dsm_case`):
``shadow-map`` with a DSM from another source (the model's own, moved by a random
sub-pixel shift of up to half a pixel each way: registered within a pixel; smoothed by a
Gaussian of σ 0.7 px: another resolution; with 0.3 m of Gaussian height noise; seeds fixed
below) against ``shadow-map`` with the exact DSM and without one, and ``deshadow`` with the truth fraction and with the map's,
each without and with the DSM (the same noisy one, and the sun).
Its scene sets (``--dsm --set dsm-holdout``, ``deshadow-holdout`` …) are drawn as the others,
with other seeds. Each de-shadowed cube is checked twice (:func:`spectra_check`): against the mean sunlit spectrum
of the material, and against each shadowed pixel's own sunlit signal,
from the scene simulated again without cast shadows (:func:`sunlit_twin`). The first check
also compares pixels at shadow edges (mixed with their neighbours, and with the SWIR seeing
the ground a boresight offset away) with pixels inside sunlit patches: the "perfect" column is
what it gives the twin itself, a perfect de-shadowing. With the de-shadow columns the
simulator's scenes are made with ``sky_obstruction`` (walls and crowns hide sky, as model 2's
do; without it its street canyons see the whole sky). ``--no-deshadow`` leaves the de-shadow
columns empty (and the simulator's scenes without sky obstruction, as the shadow map's other runs have them); ``--additive`` de-shadows with the
additive signal estimated from the pairs (``deshadow_file(light=LightModel(additive=True))``); ``--adjacency``
adds the light of the sunlit surroundings to the columns with the surface model
(``deshadow_file(light=LightModel(adjacency=True))``). ``--dark-reference`` writes
each band's true dark level into the ENVI headers before de-shadowing, as a sensor product's
dark frames give it (model 2's dark levels differ from band to band by 3 %).

Usage::

    python -m validation shadow [--lines 128] [--set dev|quick|holdout|…] [--dsm
        [--no-deshadow | --additive] [--adjacency] [--dark-reference]] [--out FOLDER]
        [--markdown FILE]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import tempfile
import time

import numpy as np
import rasterio
from scipy import ndimage

from geoboresight import (
    LightModel,
    SurfaceModel,
    dark_pixel_shadow_file,
    deshadow_file,
    ratio_file,
    shadow_classes_file,
    shadow_cluster_file,
    shadow_map_file,
    sun_shadow_file,
)
from geoboresight.io import quiet_georef
from geoboresight.io.raster import writer_options
from geoboresight.io.scene import write_scene
from geoboresight.simulate import simulate_scene
from geoboresight.simulate.shadow import raw_grid_azimuth

from .scene_model2 import DARK_MATERIALS as DARK2
from .scene_model2 import MATERIALS as MATERIALS2
from .scene_model2 import simulate2, write_scene2

DARK1 = ("asphalt", "roof_shingle", "roof_tile", "dark_soil")
#: The simulator's dark offsets (geoboresight/simulate/sensor.py), to re-offset its DN.
SIM_DARK = (190.0, 800.0)

# (label, model, options). Model 1 options: preset, zenith, dark offsets, gains (applied to the
# signal above the simulator's offsets). Model 2: simulate2's keywords.
CASES = (
    ("sim urban 30.8° (tuning)", 1, dict(preset="urban", zenith=30.8)),
    ("sim urban 60°", 1, dict(preset="urban", zenith=60.0)),
    ("sim mixed 30.8°", 1, dict(preset="mixed", zenith=30.8)),
    ("sim mixed 60°", 1, dict(preset="mixed", zenith=60.0)),
    (
        "sim urban 45°, darks 60/300, gains ×0.6",
        1,
        dict(preset="urban", zenith=45.0, dark=(60.0, 300.0), gain=(0.6, 0.6)),
    ),
    (
        "sim urban 30.8°, darks 400/1500, gains ×1.5/×0.7",
        1,
        dict(preset="urban", zenith=30.8, dark=(400.0, 1500.0), gain=(1.5, 0.7)),
    ),
    ("sim glade 40°", 1, dict(preset="glade", zenith=40.0)),
    ("m2 seed 0, 35°", 2, dict(seed=0, sun_zenith=35.0)),
    ("m2 seed 1, 55°, aot 0.4", 2, dict(seed=1, sun_zenith=55.0, aot500=0.4)),
    (
        "m2 seed 2, 25°, darks 60/400, gains ×0.5",
        2,
        dict(
            seed=2, sun_zenith=25.0, vnir_dark=60.0, swir_dark=400.0, vnir_gain=0.5, swir_gain=0.5
        ),
    ),
    (
        "m2 seed 3, 45°, darks 300/1500, relief 25 m",
        2,
        dict(seed=3, sun_zenith=45.0, vnir_dark=300.0, swir_dark=1500.0, relief_m=25.0),
    ),
    ("m2 seed 4, 60°, no adjacency light", 2, dict(seed=4, sun_zenith=60.0, adjacency=0.0)),
)
QUICK = (0, 2, 7, 9)

#: The draws of hold-out scenes: (seed of the draws, model-2 seeds, simulator seeds), each
#: seed drawn from the system's random source and fixed here before the draw's first run.
DRAWS = {
    "map-a": (20261122, range(5, 10), (1, 2, 3)),
    "map-b": (20261123, range(10, 15), (4, 5, 6)),
    "map-c": (20261124, range(15, 20), (7, 8, 9)),
    "dsm-a": (20261125, range(20, 25), (10, 11, 12)),
    "deshadow-a": (20261126, range(25, 30), (13, 14, 15)),
    "dsm-b": (1977598514, range(30, 35), (16, 17, 18)),
    "dsm-c": (59352930, range(35, 40), (19, 20, 21)),
    "dsm-d": (1990625790, range(40, 45), (22, 23, 24)),
    "deshadow-b": (650604672, range(40, 45), (22, 23, 24)),
    "dsm-e": (1169926643, range(45, 50), (25, 26, 27)),
    "deshadow-c": (1723010984, range(50, 55), (28, 29, 30)),
    "dsm-f": (1781929714, range(55, 60), (31, 32, 33)),
    "deshadow-d": (702303436, range(60, 65), (34, 35, 36)),
    "dsm-g": (328270496, range(65, 70), (37, 38, 39)),
    "deshadow-e": (342945452, range(70, 75), (40, 41, 42)),
    "dsm-h": (62679417, range(75, 80), (43, 44, 45)),
    "nodsm-a": (1818535745, range(80, 85), (46, 47, 48)),
    "nodsm-b": (477085513, range(85, 90), (49, 50, 51)),
    "deshadow-region-a": (1037402248, range(180, 185), (146, 147, 148)),
    "deshadow-region-b": (158251716, range(185, 190), (149, 150, 151)),
    "nodsm-e": (918135055, range(210, 215), (166, 167, 168)),
    "nodsm-f": (407053608, range(215, 220), (169, 170, 171)),
    "dsm-band-a": (107771649, range(200, 205), (160, 161, 162)),
    "dsm-band-b": (893564715, range(205, 210), (163, 164, 165)),
    "nodsm-g": (200481306, range(220, 225), (172, 173, 174)),
    "nodsm-h": (1187438842, range(225, 230), (175, 176, 177)),
    "deshadow-h": (1210019211, range(240, 245), (184, 185, 186)),
    "deshadow-i": (1377511628, range(245, 250), (187, 188, 189)),
}
#: The scene sets (``--set``). ``dev``: the development scenes, on which the parameters are
#: set; ``quick``: four of them. A hold-out set is run only after the method it scores is
#: fixed; a "seen" set was looked at while the method was developed, so it measures how the
#: method carries over to other conditions, not how it does on scenes never seen.
SETS = {
    "holdout": ("map-a", "map-b", "map-c"),
    "dsm-seen": ("dsm-a", "dsm-b", "dsm-c", "dsm-d", "dsm-e", "dsm-f", "dsm-g"),
    "dsm-holdout": ("dsm-h", "deshadow-d", "deshadow-e"),
    "deshadow-seen": ("dsm-a", "deshadow-a", "deshadow-b", "deshadow-c"),
    "deshadow-holdout": ("deshadow-d", "deshadow-e"),
    "nodsm-holdout": ("nodsm-a", "nodsm-b"),
    "deshadow-region-holdout": ("deshadow-region-a", "deshadow-region-b"),
    "nodsm-swir-holdout": ("nodsm-e", "nodsm-f"),
    "dsm-band-holdout": ("dsm-band-a", "dsm-band-b"),
    "nodsm-joint-holdout": ("nodsm-g", "nodsm-h"),
    "deshadow-pairs-holdout": ("deshadow-h", "deshadow-i"),
}


def scene_set(name):
    """The scenes of a set as (label, model, options, index); ``index`` seeds the DSM's noise
    and shift (its place in the development list, or in its draw)."""
    if name == "dev":
        return [(*c, i) for i, c in enumerate(CASES)]
    if name == "quick":
        return [(*CASES[j], i) for i, j in enumerate(QUICK)]
    return [(*c, i) for draw in SETS[name] for i, c in enumerate(holdout_cases(draw))]


#: Height noise (m), largest sub-pixel shift (px) and Gaussian smoothing (σ, px: a DSM of
#: another resolution) of the DSM given to shadow-map --dsm.
DSM_NOISE_M = 0.3
DSM_SHIFT_PX = 0.5
DSM_SMOOTH_PX = 0.7
DSM_SEED = 24


def holdout_cases(draw):
    """The eight scenes of one draw (:data:`DRAWS`). Conditions drawn at random (uniform
    unless stated) from these ranges:

    * model 2, five seeds (other layouts and earthlib spectra than the development seeds
      0–4): sun zenith 20–62°, azimuth 0–360°, aerosol optical
      depth at 500 nm 0.05–0.5, relief 0 m (half of the scenes) or 5–30 m, VNIR / SWIR dark
      level 40–400 / 250–2,000 DN, gains ×0.4–1.6 each, adjacency 0–0.8, 6–14 buildings, 6–16
      trees, boresight offset 0–1.5 px along and −0.5–0.5 px across;
    * simulator, three scenes: preset urban, mixed, glade (one each), simulator seeds
      (other layouts and noise than the development seed 0), sun zenith
      20–62°, azimuth 0–360° (from the flight direction), aerosol optical depth at 550 nm
      0.05–0.4, VNIR / SWIR dark offset 40–400 / 250–1,600 DN, gains ×0.5–1.3 each (12-bit
      DN, clipped at 4,095).
    """
    seed, m2_seeds, sim_seeds = DRAWS[draw]
    rng = np.random.default_rng(seed)
    u = lambda a, b: round(float(rng.uniform(a, b)), 2)  # noqa: E731
    cases = []
    for s in m2_seeds:
        o = dict(
            seed=s,
            sun_zenith=u(20, 62),
            sun_azimuth=u(0, 360),
            aot500=u(0.05, 0.5),
            relief_m=0.0 if rng.random() < 0.5 else u(5, 30),
            vnir_dark=u(40, 400),
            swir_dark=u(250, 2000),
            vnir_gain=u(0.4, 1.6),
            swir_gain=u(0.4, 1.6),
            adjacency=u(0.0, 0.8),
            buildings=int(rng.integers(6, 15)),
            trees=int(rng.integers(6, 17)),
            offset_px=(u(0.0, 1.5), u(-0.5, 0.5)),
        )
        label = (
            f"HO m2 seed {s}, {o['sun_zenith']:.0f}°/az {o['sun_azimuth']:.0f}°, aot "
            f"{o['aot500']:.2f}, darks {o['vnir_dark']:.0f}/{o['swir_dark']:.0f}, gains "
            f"×{o['vnir_gain']:.2f}/×{o['swir_gain']:.2f}, adjacency {o['adjacency']:.2f}, "
            f"relief {o['relief_m']:.0f} m"
        )
        cases.append((label, 2, o))
    for preset, sim_seed in zip(("urban", "mixed", "glade"), sim_seeds, strict=True):
        o = dict(
            preset=preset,
            seed=sim_seed,
            zenith=u(20, 62),
            azimuth=u(0, 360),
            aot550=u(0.05, 0.4),
            dark=(u(40, 400), u(250, 1600)),
            gain=(u(0.5, 1.3), u(0.5, 1.3)),
        )
        label = (
            f"HO sim {preset} seed {sim_seed}, {o['zenith']:.0f}°/az {o['azimuth']:.0f}°, aot "
            f"{o['aot550']:.2f}, darks {o['dark'][0]:.0f}/{o['dark'][1]:.0f}, gains "
            f"×{o['gain'][0]:.2f}/×{o['gain'][1]:.2f}"
        )
        cases.append((label, 1, o))
    return tuple(cases)


def read(path):
    with quiet_georef(), rasterio.open(path) as src:
        return src.read(1)


def prf(pred, truth, domain):
    pred, truth = pred & domain, truth & domain
    tp = int((pred & truth).sum())
    fp = int((pred & ~truth).sum())
    fn = int((~pred & truth).sum())
    p = tp / (tp + fp) if tp + fp else float("nan")
    r = tp / (tp + fn) if tp + fn else float("nan")
    f1 = 2 * p * r / (p + r) if (p + r) > 0 else float("nan")
    return p, r, f1


def fraction_class(f):
    """Table 2's class of a truth shadow fraction (0: below 10 %)."""
    out = np.zeros(f.shape, np.uint8)
    for cid, lo, hi in ((1, 0.8, 1.01), (2, 0.5, 0.8), (3, 0.2, 0.5), (4, 0.1, 0.2)):
        out[(f >= lo) & (f < hi)] = cid
    return out


def simulate(model, opts, lines, **kw):
    """One scene of ``model`` (1: the simulator, 2: model 2) with the case's options; ``kw``
    goes to the model (``cast_shadows``, and the simulator's ``sky_obstruction``)."""
    if model == 1:
        o = dict(opts)
        return simulate_scene(
            o["preset"],
            lines=lines,
            seed=o.get("seed", 0),
            sun_zenith=o["zenith"],
            sun_azimuth=o.get("azimuth"),
            **({"aot550": o["aot550"]} if "aot550" in o else {}),
            **kw,
        )
    return simulate2(
        rows=lines, seed=opts.get("seed", 0), **{k: v for k, v in opts.items() if k != "seed"}, **kw
    )


def make_scene(model, opts, lines, folder, sky_obstruction=False):
    """Write the scene; return (dark-material mask, material names of sunlit dark pixels,
    material map, sun zenith, sun azimuth as sun-shadow takes it, cell size).
    ``sky_obstruction``: the simulator's walls and crowns hide sky (model 2's always do)."""
    if model == 1:
        o = dict(opts)
        sc = simulate(1, opts, lines, sky_obstruction=sky_obstruction)
        dark, gain = o.get("dark", SIM_DARK), o.get("gain", (1.0, 1.0))
        if dark != SIM_DARK or gain != (1.0, 1.0):

            def redo(cube, old, new, g):
                x = (cube.astype(np.float64) - old) * g + new
                return np.clip(np.rint(x), 0, 4095).astype(np.uint16)

            sc = dataclasses.replace(
                sc,
                vnir=redo(sc.vnir, SIM_DARK[0], dark[0], gain[0]),
                swir=redo(sc.swir, SIM_DARK[1], dark[1], gain[1]),
            )
        write_scene(sc, folder)
        with open(os.path.join(folder, "truth.json")) as fh:
            t = json.load(fh)
        names = sc.material_names
        dark_ids = [k for k, v in names.items() if v in DARK1]
        az = raw_grid_azimuth(t["sun"]["azimuth_deg"])
        return sc.material, names, dark_ids, o["zenith"], az, float(t["gsd_m"])
    sc = simulate(2, opts, lines)
    write_scene2(sc, folder)
    dark_ids = [k for k, v in MATERIALS2.items() if v in DARK2]
    t = sc.truth
    return (
        sc.material,
        MATERIALS2,
        dark_ids,
        t["sun"]["zenith_deg"],
        t["sun"]["azimuth_deg"],
        t["gsd_m"],
    )


def run_case(label, model, opts, lines, folder):
    t0 = time.perf_counter()
    os.makedirs(os.path.dirname(folder), exist_ok=True)
    material, names, dark_ids, zen, az, gsd = make_scene(model, opts, lines, folder)
    j = lambda name: os.path.join(folder, name)  # noqa: E731
    vnir, swir = j("vnir.hdr"), j("swir.hdr")
    sm = shadow_map_file(vnir, swir, output=j("map_classes.tif"), mask=j("map_mask.tif"))
    ratio_file(vnir, swir, output=j("ratio.tif"))
    cl = shadow_cluster_file(j("ratio.tif"), vnir, output=j("cluster.tif"))
    shadow_classes_file(j("ratio.tif"), output=j("table2_classes.tif"), mask=j("table2.tif"))
    dark_pixel_shadow_file(vnir, output=j("dark.tif"))
    ss = sun_shadow_file(
        j("truth_dsm.tif"),
        sun_zenith=zen,
        sun_azimuth=az,
        cell_size=gsd,
        output=j("sun_fraction.tif"),
    )
    f = read(j("truth_shadow_fraction.tif")).astype(float)
    valid = np.isfinite(f) & (read(j("map_mask.tif")) != 255)
    truth = f >= 0.5
    wide = ndimage.binary_opening(truth, np.ones((2, 2), bool))
    domain = valid & ~(truth & ~wide)  # thin (≤ 1 px) shadow left out of the count
    sunlit_dark = np.isin(material, dark_ids) & (f < 0.1) & valid
    row = {
        "label": label,
        "model": model,
        "truth_share": float(truth[valid].mean()),
        "isolation": cl["isolation"],
    }
    for key, path in (
        ("map", "map_mask.tif"),
        ("table2", "table2.tif"),
        ("cluster", "cluster.tif"),
        ("dark", "dark.tif"),
    ):
        m = read(j(path)) == 1
        row[key] = prf(m, truth, valid)
        row[key + "_wide"] = prf(m, truth, domain)[2]
        row[key + "_fa"] = float(m[sunlit_dark].mean()) if sunlit_dark.any() else float("nan")
        row[key + "_fa_by"] = {
            names[k]: float(m[sunlit_dark & (material == k)].mean())
            for k in dark_ids
            if (sunlit_dark & (material == k)).sum() >= 20
        }
    c = read(j("map_classes.tif"))
    tc = fraction_class(f)
    inside = valid & ((tc > 0) | (c > 0))
    row["class_accuracy"] = (
        float((c[inside] == tc[inside]).mean()) if inside.any() else float("nan")
    )
    row["class_counts"] = [int((c == k).sum()) for k in (1, 2, 3, 4)]
    sim = read(j("sun_fraction.tif"))
    a = sim >= 0.5
    row["sun_iou"] = float((a & truth).sum() / max((a | truth).sum(), 1))
    row["sun_surface"] = ss.get("surface", "?")
    row["dark_est"] = (sm["vnir_dark_dn"], sm["swir_dark_dn"])
    row["sunlit_ratio"] = sm["sunlit_ratio"]
    row["warnings"] = sm["warnings"]
    row["seconds"] = time.perf_counter() - t0
    return row


def write_tif(path, array):
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=array.shape[1],
        height=array.shape[0],
        count=1,
        dtype="float32",
    ) as dst:
        dst.write(array.astype("float32"), 1)


def spectra_check(cube_path, dark, f_truth, material, names, twin=None, resolved=None):
    """Per material: the mean de-shadowed spectrum of fully shadowed pixels (truth fraction
    1, one pixel inside the shadow) against the mean spectrum of its sunlit pixels (truth 0,
    two pixels away from any shadow): spectral angle (°) and brightness ratio − 1 (over the
    bands whose sunlit signal is ≥ 2 % of the brightest band's).

    ``twin`` (signal above the dark level, lit mask) from :func:`sunlit_twin`: the reference
    is instead each shadowed pixel's own sunlit signal (its twin's), on the same pixels; pass
    the true dark levels then. ``resolved``: the bands de-shadowing resolves in shadow (the
    others are flagged and left as measured, and not checked)."""
    with quiet_georef(), rasterio.open(cube_path) as src:
        raw = src.read().astype(np.float64)
        nodata = src.nodata
    x = raw - np.asarray(dark)[:, None, None]
    # Pixels with no data in a band (the SWIR's edge beyond the boresight offset) are left out.
    has = np.isfinite(raw).all(axis=0)
    if nodata is not None:
        has &= (raw != nodata).all(axis=0)
    return material_errors(x, has, f_truth, material, names, twin, resolved)


def material_errors(x, has, f_truth, material, names, twin=None, resolved=None):
    """:func:`spectra_check` on a signal cube ``x`` (bands, rows, cols) above the dark level."""
    full = ndimage.binary_erosion(f_truth >= 0.999) & has
    sun = ~ndimage.binary_dilation(f_truth > 0.0, iterations=2) & has
    if twin is not None:
        full &= twin[1]
    out = {}
    for k, name in names.items():
        a = full & (material == k)
        b = sun & (material == k)
        if a.sum() < 20 or b.sum() < 20:
            continue
        ma = x[:, a].mean(axis=1)
        mb = x[:, b].mean(axis=1) if twin is None else twin[0][:, a].mean(axis=1)
        use = mb >= 0.02 * mb.max()
        if resolved is not None:
            use &= np.asarray(resolved, bool)
        cos = np.dot(ma[use], mb[use]) / np.linalg.norm(ma[use]) / np.linalg.norm(mb[use])
        angle = float(np.degrees(np.arccos(np.clip(cos, -1, 1))))
        out[name] = (angle, float(ma[use].mean() / mb[use].mean() - 1), int(a.sum()))
    return out


def sunlit_twin(model, opts, lines):
    """The scene simulated again without cast shadows (``cast_shadows=False``: the same layout,
    sky view, with the simulator's sky obstruction as :func:`run_dsm_case` simulates it, and,
    in model 2, adjacency light): (signal above the true dark level, float64
    (bands, rows, cols); mask of the pixels the twin has in full sun, fraction < 0.02). A
    fully shadowed pixel's twin is its own sunlit signal, which a perfect de-shadowing
    returns; self-shaded (and cloud-shadowed) pixels stay shaded in the twin and are left
    out."""
    if model == 1:
        sc = simulate(1, opts, lines, cast_shadows=False, sky_obstruction=True)
        gain = opts.get("gain", (1.0, 1.0))
        signal = np.concatenate(
            [
                (sc.vnir.astype(np.float64) - SIM_DARK[0]) * gain[0],
                (sc.swir.astype(np.float64) - SIM_DARK[1]) * gain[1],
            ]
        )
        return signal, sc.shadow_fraction < 0.02
    sc = simulate(2, opts, lines, cast_shadows=False)
    dark = np.concatenate([sc.truth["vnir_dark_dn"], sc.truth["swir_dark_dn"]])
    signal = np.concatenate([sc.vnir, sc.swir]).astype(np.float64) - dark[:, None, None]
    return signal, np.ones(sc.material.shape, bool)


def write_dark_reference(folder, dark):
    """Append each instrument's band dark levels (``dark``: VNIR, SWIR, as :func:`true_dark`)
    to vnir.hdr and swir.hdr (ENVI ``dark level = {…}``)."""
    for name, levels in zip(("vnir.hdr", "swir.hdr"), dark, strict=True):
        with open(os.path.join(folder, name), "a", encoding="utf-8") as fh:
            fh.write("dark level = {" + ", ".join(f"{x:.2f}" for x in levels) + "}\n")


def true_dark(model, opts, folder):
    """Each band's true dark level (DN) of the scene written in ``folder``: (VNIR, SWIR)."""
    with open(os.path.join(folder, "truth.json")) as fh:
        t = json.load(fh)
    if model == 2:
        return np.asarray(t["vnir_dark_dn"]), np.asarray(t["swir_dark_dn"])
    out = []
    with quiet_georef():
        for name, level in zip(("vnir.img", "swir.img"), opts.get("dark", SIM_DARK), strict=True):
            with rasterio.open(os.path.join(folder, name)) as src:
                out.append(np.full(src.count, level))
    return tuple(out)


def run_dsm_case(
    label,
    model,
    opts,
    lines,
    folder,
    index,
    deshadow=True,
    additive=False,
    adjacency=False,
    dark_reference=False,
    regions=False,
):
    """The surface-model prior and de-shadowing on one scene (see the module's doc);
    ``deshadow`` False leaves the de-shadow columns empty (the shadow map only);
    ``dark_reference`` writes each band's true dark level into the ENVI headers (``dark level
    = {…}``), as a sensor product's dark reference gives it, before de-shadowing."""
    t0 = time.perf_counter()
    os.makedirs(os.path.dirname(folder), exist_ok=True)
    # De-shadowing is checked on scenes whose shadows get the sky their surroundings leave
    # them (model 2's always do): without it the simulator's street canyons see the whole sky.
    material, names, dark_ids, zen, az, gsd = make_scene(
        model, opts, lines, folder, sky_obstruction=deshadow
    )
    j = lambda name: os.path.join(folder, name)  # noqa: E731
    vnir, swir = j("vnir.hdr"), j("swir.hdr")
    rng = np.random.default_rng([DSM_SEED, index])
    z = read(j("truth_dsm.tif")).astype(np.float64)
    shift = rng.uniform(-DSM_SHIFT_PX, DSM_SHIFT_PX, 2)
    z = ndimage.gaussian_filter(ndimage.shift(z, shift, order=1, mode="nearest"), DSM_SMOOTH_PX)
    z = z + rng.normal(0, DSM_NOISE_M, z.shape)
    write_tif(j("dsm_noisy.tif"), z)
    shadow_map_file(vnir, swir, output=j("map0.tif"), mask=j("map0_mask.tif"))
    shadow_map_file(
        vnir,
        swir,
        output=j("map_exact.tif"),
        mask=j("map_exact_mask.tif"),
        surface=SurfaceModel(j("truth_dsm.tif"), zen, az, gsd),
    )
    sm = shadow_map_file(
        vnir,
        swir,
        output=j("map_dsm.tif"),
        mask=j("map_dsm_mask.tif"),
        fraction=j("map_dsm_fraction.tif"),
        surface=SurfaceModel(j("dsm_noisy.tif"), zen, az, gsd),
    )
    f = read(j("truth_shadow_fraction.tif")).astype(float)
    valid = np.isfinite(f) & (read(j("map_dsm_mask.tif")) != 255)
    truth = f >= 0.5
    wide = ndimage.binary_opening(truth, np.ones((2, 2), bool))
    domain = valid & ~(truth & ~wide)
    sunlit_dark = np.isin(material, dark_ids) & (f < 0.1) & valid
    row = {
        "label": label,
        "model": model,
        "shift": tuple(shift),
        "truth_share": float(truth[valid].mean()),
    }
    for key, path in (
        ("map0", "map0_mask.tif"),
        ("dsm", "map_dsm_mask.tif"),
        ("exact", "map_exact_mask.tif"),
    ):
        m = read(j(path)) == 1
        row[key] = prf(m, truth, valid)
        row[key + "_wide"] = prf(m, truth, domain)[2]
        row[key + "_fa"] = float(m[sunlit_dark].mean()) if sunlit_dark.any() else float("nan")
    row["lit_share"] = sm["dsm_predicted_shadow_lit_share"]
    row["best_shift"] = (sm["dsm_shift_rows"], sm["dsm_shift_columns"])
    row["moved"] = (sm["dsm_registration_rows"], sm["dsm_registration_columns"])
    row["warnings"] = sm["warnings"]
    write_tif(j("truth_fraction.tif"), np.nan_to_num(f, nan=0.0))
    surface = SurfaceModel(j("dsm_noisy.tif"), zen, az, gsd)
    dark_true = true_dark(model, opts, folder)
    if dark_reference:
        write_dark_reference(folder, dark_true)
    n_vnir = len(dark_true[0])
    dark_true = np.concatenate(dark_true)
    if deshadow:
        # The reference a perfect de-shadowing reaches: each shadowed pixel's own sunlit
        # signal; and the floor of the material-mean check (that twin, checked as the output).
        twin = sunlit_twin(model, opts, lines)
        row["floor"] = material_errors(twin[0], np.ones(f.shape, bool), f, material, names)
    for key, frac, surf in (
        ("truth", j("truth_fraction.tif"), SurfaceModel()),
        ("mapf", j("map_dsm_fraction.tif"), SurfaceModel()),
        ("truth_dsm", j("truth_fraction.tif"), surface),
        ("mapf_dsm", j("map_dsm_fraction.tif"), surface),
    ):
        if not deshadow:
            row[key] = row[key + "_own"] = {}
            continue
        out = j(f"deshadow_{key}.tif")
        try:
            # Band-interleaved: a cube of ~200 bands written pixel-interleaved takes 15 × longer.
            with writer_options(co=["INTERLEAVE=BAND"]):
                r = deshadow_file(
                    vnir,
                    swir,
                    shadow=frac,
                    output=out,
                    report=j(f"ds_{key}.json"),
                    surface=surf,
                    light=LightModel(
                        additive=additive,
                        adjacency=adjacency and surf.dsm is not None,
                        regions=regions,
                    ),
                )
        except Exception as e:  # reported, not hidden
            row[key] = row[key + "_own"] = {"error": str(e)}
            continue
        with open(j(f"ds_{key}.json")) as fh:
            bands = json.load(fh)["bands"]
        dark = [b["dark_level_dn"] for b in bands]
        ok = [b["resolved_in_shadow"] for b in bands]
        row[key] = spectra_check(out, dark, f, material, names, resolved=ok)
        row[key + "_own"] = spectra_check(
            out, dark_true, f, material, names, twin=twin, resolved=ok
        )
        row[key + "_flagged"] = _flagged(bands, n_vnir)
        row[key + "_pairs"] = r["pairs_used"]
    row["seconds"] = time.perf_counter() - t0
    return row


def _flagged(bands, n_vnir) -> str:
    """The bands left as measured (unresolved in shadow), VNIR + SWIR, as ``"v+s"``."""
    low = [not b["resolved_in_shadow"] for b in bands]
    return f"{sum(low[:n_vnir])}+{sum(low[n_vnir:])}"


def _worst(d):
    if "error" in d:
        return "error", "error", ""
    if not d:
        return "–", "–", ""
    sa = max(v[0] for v in d.values())
    br = max(abs(v[1]) for v in d.values())
    by = ", ".join(f"{k} {v[0]:.1f}°/{100 * v[1]:+.0f} %" for k, v in d.items())
    return f"{sa:.1f}°", f"{100 * br:.0f} %", by


def _over_exact(r) -> float:
    """The degraded DSM's F1 wide over the exact DSM's (NaN when the exact one finds none)."""
    return r["dsm_wide"] / r["exact_wide"] if r["exact_wide"] else float("nan")


def dsm_table(rows) -> str:
    out = [
        "| scene | truth shadow | no DSM: F1 wide / flagged | DSM: P / R / F1 | DSM F1 wide | "
        "exact DSM: F1 wide / flagged; DSM's F1 wide over it | DSM sunlit dark flagged | predicted shadow lit | registration move; best shift after it "
        "(DSM shift) | deshadow, "
        "truth f: worst SA / brightness | deshadow, map f: worst SA / brightness | "
        "deshadow with the DSM, truth f | deshadow with the DSM, map f | "
        "with the DSM, map f, by material (SA / brightness) | against each pixel's own sunlit "
        "signal: truth f / map f / DSM truth f / DSM map f | a perfect de-shadowing, checked "
        "against the sunlit pixels | bands left as measured, VNIR+SWIR: truth f / map f / DSM "
        "truth f / DSM map f |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        t, m = _worst(r["truth"]), _worst(r["mapf"])
        td, md = _worst(r["truth_dsm"]), _worst(r["mapf_dsm"])
        out.append(
            f"| {r['label']} | {100 * r['truth_share']:.1f} % | {fmt(r['map0_wide'])} / "
            f"{fmt(100 * r['map0_fa'], 1)} % | {' / '.join(fmt(v) for v in r['dsm'])} | "
            f"{fmt(r['dsm_wide'], 3)} | {fmt(r['exact_wide'], 3)} / "
            f"{fmt(100 * r['exact_fa'], 1)} %; {fmt(_over_exact(r), 3)} | "
            f"{fmt(100 * r['dsm_fa'], 1)} % | "
            f"{100 * r['lit_share']:.1f} % | {r['moved'][0]:+.2f}, {r['moved'][1]:+.2f}; "
            f"{r['best_shift'][0]:+d}, {r['best_shift'][1]:+d} "
            f"({r['shift'][0]:+.2f}, {r['shift'][1]:+.2f}) | {t[0]} / {t[1]} | {m[0]} / {m[1]} "
            f"| {td[0]} / {td[1]} | {md[0]} / {md[1]} | {md[2]} | "
            + " · ".join("{} / {}".format(*_worst(r.get(k + "_own", {}))[:2]) for k in DESHADOW)
            + " | {} / {} | ".format(*_worst(r.get("floor", {}))[:2])
            + " · ".join(r.get(k + "_flagged", "–") for k in DESHADOW)
            + " |"
        )
    if any("floor" in r for r in rows):
        out += ["", goal_counts(rows)]
    return "\n".join(out)


#: The keys of run_dsm_case's de-shadow columns.
DESHADOW = ("truth", "mapf", "truth_dsm", "mapf_dsm")


def within(d, angle=5.0, brightness=0.10):
    """(materials within both goals, materials checked) of one column's result."""
    if not d or "error" in d:
        return 0, 0
    return sum(v[0] <= angle and abs(v[1]) <= brightness for v in d.values()), len(d)


def all_within(d) -> bool:
    """Every material of one column's result within both goals (and at least one checked)."""
    ok, n = within(d)
    return n > 0 and ok == n


def goal_counts(rows) -> str:
    """Materials within 5° and 10 % per model and column, checked against the sunlit pixels
    of the material and against each pixel's own sunlit signal, and
    what a perfect de-shadowing gets from the first check (its floor)."""
    out = [
        "| model | check | no DSM, truth f | no DSM, map f | DSM, truth f | DSM, map f | "
        "scenes whole (any column) |",
        "|---|---|---|---|---|---|---|",
    ]
    for model in sorted({r["model"] for r in rows}):
        rs = [r for r in rows if r["model"] == model]
        name = "simulator" if model == 1 else "model 2"
        for check, suffix in (("sunlit pixels", ""), ("own sunlit signal", "_own")):
            cells = []
            for key in DESHADOW:
                n = [within(r.get(key + suffix, {})) for r in rs]
                cells.append(f"{sum(a for a, _ in n)}/{sum(b for _, b in n)}")
            whole = sum(any(all_within(r.get(k + suffix, {})) for k in DESHADOW) for r in rs)
            out.append(f"| {name} | {check} | {' | '.join(cells)} | {whole}/{len(rs)} |")
        n = [within(r.get("floor", {})) for r in rs]
        whole = sum(all_within(r.get("floor", {})) for r in rs)
        out.append(
            f"| {name} | perfect de-shadowing, sunlit pixels | "
            f"{sum(a for a, _ in n)}/{sum(b for _, b in n)} (every column) | | | | "
            f"{whole}/{len(rs)} |"
        )
    return "\n".join(out)


def summary(rows, dsm=False) -> str:
    """Per scene model: the range of F1 wide, the scenes reaching the goal, and the share of
    sunlit dark materials flagged (the goals: F1 wide ≥ 0.85 without a DSM, ≥ 0.90 with one;
    at most 10 % / 5 % flagged)."""
    key, goal, limit = ("dsm_wide", 0.90, 0.05) if dsm else ("map_wide", 0.85, 0.10)
    fa = "dsm_fa" if dsm else "map_fa"
    out = [
        f"| model | scenes | F1 wide: range, mean | F1 wide ≥ {goal:.2f} (unrounded) | sunlit dark flagged: "
        f"range | flagged ≤ {round(100 * limit)} % |"
        + (" F1 wide over the exact DSM's: range, mean | ≥ 0.97 |" if dsm else ""),
        "|---|---|---|---|---|---|" + ("---|---|" if dsm else ""),
    ]
    for model in sorted({r["model"] for r in rows}):
        rs = [r for r in rows if r["model"] == model]
        f1 = np.array([r[key] for r in rs], float)
        flagged = np.array([r[fa] for r in rs], float)
        ok = np.isfinite(flagged)
        out.append(
            f"| {'simulator' if model == 1 else 'model 2'} | {len(rs)} | "
            f"{np.nanmin(f1):.4f}–{np.nanmax(f1):.4f}, {np.nanmean(f1):.3f} | "
            f"{int(np.sum(f1 >= goal))} of {len(rs)} | "
            f"{100 * np.nanmin(flagged):.1f}–{100 * np.nanmax(flagged):.1f} % | "
            f"{int(np.sum(flagged[ok] <= limit))} of {int(ok.sum())} |"
            + (_ratio_cells(rs) if dsm else "")
        )
    return "\n".join(out)


def _ratio_cells(rows) -> str:
    """The summary's cells of the degraded DSM's F1 wide over the exact DSM's."""
    q = np.array([_over_exact(r) for r in rows], float)
    if not np.isfinite(q).any():
        return " – | – |"
    return (
        f" {np.nanmin(q):.3f}–{np.nanmax(q):.3f}, {np.nanmean(q):.3f} | "
        f"{int(np.sum(q >= 0.97))} of {int(np.isfinite(q).sum())} |"
    )


def fmt(x, nd=2):
    return "–" if x is None or (isinstance(x, float) and not np.isfinite(x)) else f"{x:.{nd}f}"


def table(rows) -> str:
    out = [
        "| scene | truth shadow | shadow-map P / R / F1 | F1 wide | Table 2 F1 | cluster F1 | "
        "dark-pixel F1 | sunlit dark flagged: map / Table 2 / cluster / dark-pixel | map flags by "
        "material | class accuracy | sun-shadow IoU (surface) | dark levels found (VNIR/SWIR) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        by = ", ".join(f"{k} {100 * v:.0f} %" for k, v in r["map_fa_by"].items())
        out.append(
            f"| {r['label']} | {100 * r['truth_share']:.1f} % | "
            f"{' / '.join(fmt(v) for v in r['map'])} | {fmt(r['map_wide'])} | "
            f"{fmt(r['table2'][2])} | {fmt(r['cluster'][2])} | {fmt(r['dark'][2])} | "
            f"{fmt(100 * r['map_fa'], 1)} / {fmt(100 * r['table2_fa'], 1)} / "
            f"{fmt(100 * r['cluster_fa'], 1)} / {fmt(100 * r['dark_fa'], 1)} % | {by} | "
            f"{fmt(r['class_accuracy'])} | {fmt(r['sun_iou'])} ({r['sun_surface']}) | "
            f"{r['dark_est'][0]:.0f} / {r['dark_est'][1]:.0f} |"
        )
    return "\n".join(out)


def main(argv=None):
    print(report(argv))
    return 0


def report(argv=None) -> str:
    """Run the validation the arguments (``main``'s) select; the Markdown table."""
    ap = argparse.ArgumentParser(
        prog="python -m validation shadow", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("--lines", type=int, default=128)
    ap.add_argument(
        "--set",
        default="dev",
        choices=("dev", "quick", *SETS),
        help="the scenes: the development scenes (dev), four of them (quick), or a set of "
        "hold-out or seen scenes (SETS)",
    )
    ap.add_argument(
        "--dsm", action="store_true", help="the surface-model prior and de-shadowing (run_dsm_case)"
    )
    ap.add_argument(
        "--no-deshadow", action="store_true", help="with --dsm: the shadow map only (faster)"
    )
    ap.add_argument(
        "--additive",
        action="store_true",
        help="with --dsm: deshadow with the additive signal from the pairs' line (additive=True)",
    )
    ap.add_argument(
        "--adjacency",
        action="store_true",
        help="with --dsm: the columns with the surface model light each pixel by its sunlit "
        "surroundings too (adjacency=True)",
    )
    ap.add_argument(
        "--dark-reference",
        action="store_true",
        help="with --dsm: write each band's true dark level into the scenes' ENVI headers (as "
        "a sensor's dark frames give it) before de-shadowing",
    )
    ap.add_argument(
        "--regions",
        action="store_true",
        help="with --dsm: each neighbourhood's own illumination ratio (LightModel(regions=True)), not one "
        "for the whole scene",
    )
    ap.add_argument("--out", help="keep the scenes and products in this (new) folder")
    ap.add_argument("--markdown", help="also write the table to this file")
    args = ap.parse_args(argv)
    if args.out:
        os.makedirs(args.out, exist_ok=False)
        folder, ctx = args.out, None
    else:
        ctx = tempfile.TemporaryDirectory(prefix="validation_shadow_")
        folder = ctx.name
    try:
        rows = []
        for s, (label, model, opts, i) in enumerate(scene_set(args.set)):
            print(f"… {label}", file=sys.stderr)
            if args.dsm:
                r = run_dsm_case(
                    label,
                    model,
                    opts,
                    args.lines,
                    os.path.join(folder, f"s{s:02d}"),
                    i,
                    deshadow=not args.no_deshadow,
                    additive=args.additive,
                    dark_reference=args.dark_reference,
                    adjacency=args.adjacency,
                    regions=args.regions,
                )
                rows.append(r)
                print(
                    f"    no DSM F1 wide {fmt(r['map0_wide'])} flagged {fmt(100 * r['map0_fa'], 1)} %;"
                    f" DSM F1 wide {fmt(r['dsm_wide'], 3)} flagged {fmt(100 * r['dsm_fa'], 1)} %"
                    f" (exact {fmt(r['exact_wide'], 3)}, {fmt(100 * r['exact_fa'], 1)} %); "
                    f"deshadow truth {_worst(r['truth'])[:2]} map {_worst(r['mapf'])[:2]}, "
                    f"with the DSM truth {_worst(r['truth_dsm'])[:2]} map "
                    f"{_worst(r['mapf_dsm'])[:2]}; own sunlit "
                    + ", ".join(str(_worst(r[k + "_own"])[:2]) for k in DESHADOW)
                    + f"; perfect {_worst(r.get('floor', {}))[:2]}; {r['seconds']:.0f} s",
                    file=sys.stderr,
                )
                continue
            rows.append(run_case(label, model, opts, args.lines, os.path.join(folder, f"s{s:02d}")))
            r = rows[-1]
            print(
                f"    map F1 {fmt(r['map'][2])} (wide {fmt(r['map_wide'])}), sunlit dark flagged "
                f"{fmt(100 * r['map_fa'], 1)} %, dark-pixel F1 {fmt(r['dark'][2])}; "
                f"{r['seconds']:.0f} s; warnings: {r['warnings']}",
                file=sys.stderr,
            )
        text = summary(rows, args.dsm) + "\n\n" + (dsm_table(rows) if args.dsm else table(rows))
        if args.markdown:
            with open(args.markdown, "w", encoding="utf-8") as fh:
                fh.write(text + "\n")
    finally:
        if ctx is not None:
            ctx.cleanup()
    return text


if __name__ == "__main__":
    sys.exit(main())
