"""What the sunlit-to-shadow ratio of each fully shadowed pixel is, and which model of it holds.

On each development scene (both scene models, noise-free), the true ratio of a fully shadowed
pixel (truth fraction ≥ 0.99, two pixels inside its shadow) is ``r = twin / shadowed`` per
band, each signal above its true dark level; the twin is the scene simulated without cast
shadows (:func:`validation.shadow.sunlit_twin`'s scene). The bands are those whose median
shadowed signal is at least 3 × the noise there (the noisy scene against the noise-free one).

It reports how ``log r`` varies (the share of its variance, centred per band, that the means
of each material, of each shadow (8-connected), of each shadow × material, one flat scale per
pixel, a line in the pixel's sky-view factor, and the best 1, 2 and 3 spectral shapes of
``1/r`` explain), and, per material with ≥ 20 such pixels, the de-shadowed mean against the
twin's mean (worst spectral angle / brightness, and the materials within 5° and 10 %) for:

* ratios with their parameters taken from the truth (an upper bound of each model): one ratio
  per band for the scene; one scale of it per shadow; per shadow a mix
  ``1/r = a·s + b`` of the scene's shape ``s`` and a flat one (light from grey surroundings);
  a line ``twin = k·shadowed + m`` per band (an additive term);
* the scene ratio measured from the pairs across the shadows' edges on the noisy scene
  (:func:`geoboresight.shadow.deshadow.pair_indices` and ``illumination_ratio``, on the raw
  grids), with all directions, without the pairs whose sunlit pixel lies towards the sun, and
  without them and the pairs across a height step (the exact surface model).

A third table runs ``deshadow`` itself on each scene (the truth fraction; without and with
the exact surface model), once with the dark levels it estimates (one per instrument, the
dimmest band's dark object) and once with each band's true dark level in the ENVI headers,
and checks it against each pixel's own sunlit signal as ``python -m validation shadow --dsm``
does (:func:`validation.shadow.spectra_check`).

Run: ``python -m validation.deshadow_ratio [--lines 128]``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile

import numpy as np
from scipy import ndimage

from geoboresight import SurfaceModel, deshadow_file
from geoboresight.io.raster import writer_options
from geoboresight.shadow import deshadow as ds
from geoboresight.simulate.shadow import raw_grid_azimuth

from .scene_model2 import MATERIALS as MATERIALS2
from .scene_model2 import _sky_view
from .shadow import (
    CASES,
    SIM_DARK,
    make_scene,
    read,
    simulate,
    spectra_check,
    sunlit_twin,
    true_dark,
    write_dark_reference,
    write_tif,
)


def signals(model, opts, lines):
    """(noisy, noise-free, twin) signal above the true dark level, each (bands, rows, cols);
    truth fraction, material, names, twin lit mask, sky-view factor, surface heights, sun
    azimuth on the grid."""
    if model == 1:
        kw = dict(sky_obstruction=True)
        n = simulate(1, opts, lines, **kw)
        c = simulate(1, opts, lines, noise_free=True, **kw)
        t = simulate(1, opts, lines, noise_free=True, cast_shadows=False, **kw)
        d = np.r_[np.full(n.vnir.shape[0], SIM_DARK[0]), np.full(n.swir.shape[0], SIM_DARK[1])]
        sig = lambda s: np.concatenate([s.vnir, s.swir]).astype(np.float64) - d[:, None, None]  # noqa: E731
        az = raw_grid_azimuth(n.truth["sun"]["azimuth_deg"])
        lit, names = t.shadow_fraction < 0.02, n.material_names
    else:
        n = simulate(2, opts, lines)
        c = simulate(2, opts, lines, noise=False)
        t = simulate(2, opts, lines, noise=False, cast_shadows=False)

        def sig(s):
            dark = np.r_[s.truth["vnir_dark_dn"], s.truth["swir_dark_dn"]]
            return np.concatenate([s.vnir, s.swir]).astype(np.float64) - dark[:, None, None]

        az, lit, names = n.truth["sun"]["azimuth_deg"], np.ones(c.material.shape, bool), MATERIALS2
    svf = _sky_view(c.dsm, 1.0)
    return sig(n), sig(c), sig(t), c.shadow_fraction, c.material, names, lit, svf, c.dsm, az


def material_errors(est, twin, material, names):
    """Per material: (spectral angle °, brightness − 1) of the mean of ``est`` against the
    mean of ``twin`` (pixels × bands), over the bands with ≥ 2 % of the brightest."""
    out = {}
    for k, name in names.items():
        m = material == k
        if m.sum() < 20:
            continue
        a, b = est[m].mean(0), twin[m].mean(0)
        u = b >= 0.02 * b.max()
        cos = a[u] @ b[u] / np.linalg.norm(a[u]) / np.linalg.norm(b[u])
        out[name] = (
            float(np.degrees(np.arccos(min(cos, 1.0)))),
            float(a[u].mean() / b[u].mean() - 1),
        )
    return out


def variance_shares(lr, groups, svf):
    """Share of the variance of ``lr`` (pixels × bands, centred per band) each grouping explains."""
    lc = lr - lr.mean(0)
    tot = (lc**2).sum()
    out = {}
    for name, g in groups.items():
        fit = np.zeros_like(lc)
        for v in np.unique(g):
            fit[g == v] = lc[g == v].mean(0)
        out[name] = 1 - ((lc - fit) ** 2).sum() / tot
    out["pixel scale"] = 1 - ((lc - lc.mean(1, keepdims=True)) ** 2).sum() / tot
    a = np.c_[np.ones_like(svf), svf]
    out["sky view"] = 1 - ((lc - a @ np.linalg.lstsq(a, lc, rcond=None)[0]) ** 2).sum() / tot
    u, s, vt = np.linalg.svd(np.exp(-lr), full_matrices=False)
    for r in (1, 2, 3):
        q = np.clip((u[:, :r] * s[:r]) @ vt[:r], 1e-6, None)
        out[f"{r} shape{'s' if r > 1 else ''}"] = 1 - ((lr + np.log(q)) ** 2).sum() / tot
    return out


def oracle_estimates(x, t, region):
    """De-shadowed signals (pixels × bands) of each model with its parameters from the truth."""
    k = t.sum(0) / x.sum(0)
    est = {"scene ratio": x * k}
    scaled, mixed = np.empty_like(x), np.empty_like(x)
    shapes = np.c_[1 / k, np.ones_like(k)]
    for r in np.unique(region):
        m = region == r
        kr = t[m].sum(0) / x[m].sum(0)
        scaled[m] = x[m] * k * np.exp(np.mean(np.log(kr / k)))
        ab = np.linalg.lstsq(shapes * kr[:, None], np.ones_like(k), rcond=None)[0]
        mixed[m] = x[m] / (shapes @ ab)
    est["scale per shadow"] = scaled
    est["sky + flat mix per shadow"] = mixed
    line = np.array([np.polyfit(x[:, b], t[:, b], 1) for b in range(x.shape[1])])
    est["additive line"] = x * line[:, 0] + line[:, 1]
    return est


def pair_estimates(noisy, fraction, bands, x, dsm, az):
    """De-shadowed signals with the scene ratio from the edge pairs of the noisy scene."""
    a = np.radians(az)
    toward = (-np.cos(a), np.sin(a))
    flat = noisy.reshape(noisy.shape[0], -1)
    out = {}
    for name, kw in (
        ("pairs, all directions", {}),
        ("pairs, none towards the sun", dict(toward_sun=toward)),
        (
            "pairs, none towards the sun nor across a height step",
            dict(toward_sun=toward, heights=dsm),
        ),
    ):
        ia, ib = ds.pair_indices(fraction, None, **kw)
        try:
            k = ds.illumination_ratio(flat[:, ia].T, flat[:, ib].T)[0]
        except Exception:  # too few pairs: reported as such
            continue
        out[name] = x * k[bands]
    return out


def study(label, model, opts, lines):
    noisy, clean, twin, f, material, names, lit, svf, dsm, az = signals(model, opts, lines)
    full = ndimage.binary_erosion(f >= 0.99, iterations=2) & lit
    noise = (noisy[:, full] - clean[:, full]).std(1)
    bands = np.median(clean[:, full], 1) >= 3 * noise
    x, t = clean[:, full][bands].T, twin[:, full][bands].T
    ok = (x > 0).all(1) & (t > 0).all(1)
    x, t, mat = x[ok], t[ok], material[full][ok]
    region = ndimage.label(full, np.ones((3, 3)))[0][full][ok]
    lr = np.log(t / x)
    shares = variance_shares(
        lr,
        {"material": mat, "shadow": region, "shadow × material": region * 1000 + mat},
        svf[full][ok],
    )
    est = oracle_estimates(x, t, region) | pair_estimates(noisy, f, bands, x, dsm, az)
    errors = {k: material_errors(v, t, mat, names) for k, v in est.items()}
    with tempfile.TemporaryDirectory(prefix="deshadow_ratio_") as folder:
        product = product_errors(model, opts, lines, folder)
    return dict(
        label=label,
        model=model,
        pixels=len(x),
        bands=int(bands.sum()),
        shares=shares,
        errors=errors,
        product=product,
    )


def product_errors(model, opts, lines, folder):
    """``deshadow`` (truth fraction) against each pixel's own sunlit signal, per material, with
    the estimated and with the true per-band dark levels, without and with the exact DSM."""
    twin = sunlit_twin(model, opts, lines)
    out = {}
    for given in (False, True):
        here = os.path.join(folder, f"dark{int(given)}")
        material, names, _, zen, az, gsd = make_scene(
            model, opts, lines, here, sky_obstruction=True
        )
        j = lambda name, here=here: os.path.join(here, name)  # noqa: E731
        f = read(j("truth_shadow_fraction.tif")).astype(float)
        write_tif(j("fraction.tif"), np.nan_to_num(f, nan=0.0))
        dark = true_dark(model, opts, here)
        if given:
            write_dark_reference(here, dark)
        for key, surface in (
            ("no DSM", SurfaceModel()),
            ("exact DSM", SurfaceModel(j("truth_dsm.tif"), zen, az, gsd)),
        ):
            with writer_options(co=["INTERLEAVE=BAND"]):
                deshadow_file(
                    j("vnir.hdr"),
                    j("swir.hdr"),
                    shadow=j("fraction.tif"),
                    output=j(f"{key}.tif"),
                    report=j(f"{key}.json"),
                    surface=surface,
                )
            with open(j(f"{key}.json")) as fh:
                ok = [b["resolved_in_shadow"] for b in json.load(fh)["bands"]]
            e = spectra_check(
                j(f"{key}.tif"), np.concatenate(dark), f, material, names, twin=twin, resolved=ok
            )
            label = f"deshadow, {key}, {'true per-band' if given else 'estimated'} dark levels"
            out[label] = {k: v[:2] for k, v in e.items()}
    return out


def cell(e):
    if not e:
        return "—"
    n = sum(a <= 5 and abs(b) <= 0.10 for a, b in e.values())
    a = max(v[0] for v in e.values())
    b = max(e.values(), key=lambda v: abs(v[1]))[1]
    return f"{n}/{len(e)}: {a:.1f}° / {100 * b:+.0f} %"


def markdown(rows) -> str:
    shares = list(rows[0]["shares"])
    models = list(rows[0]["errors"])
    out = [
        "| scene | pixels | bands | " + " | ".join(shares) + " |",
        "|---" * (3 + len(shares)) + "|",
    ]
    for r in rows:
        s = " | ".join(f"{r['shares'][k]:.2f}" for k in shares)
        out.append(f"| {r['label']} | {r['pixels']} | {r['bands']} | {s} |")
    out += ["", "| scene | " + " | ".join(models) + " |", "|---" * (1 + len(models)) + "|"]
    for r in rows:
        out.append(
            f"| {r['label']} | " + " | ".join(cell(r["errors"].get(m)) for m in models) + " |"
        )
    runs = list(rows[0]["product"])
    out += ["", "| scene | " + " | ".join(runs) + " |", "|---" * (1 + len(runs)) + "|"]
    for r in rows:
        out.append(
            f"| {r['label']} | " + " | ".join(cell(r["product"].get(m)) for m in runs) + " |"
        )
    out += ["", "| model | " + " | ".join([*models, *runs]) + " |"]
    out.append("|---" * (1 + len(models) + len(runs)) + "|")
    for model, name in ((1, "simulator"), (2, "model 2")):
        mine = [r for r in rows if r["model"] == model]
        cells = [count([r["errors"].get(m) for r in mine]) for m in models]
        cells += [count([r["product"].get(m) for r in mine]) for m in runs]
        out.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def count(errors) -> str:
    """Materials within 5° and 10 % over the scenes, of those checked."""
    got = [v for e in errors if e for v in e.values()]
    return f"{sum(a <= 5 and abs(b) <= 0.10 for a, b in got)}/{len(got)}"


def main(argv=None):
    ap = argparse.ArgumentParser(
        prog="python -m validation.deshadow_ratio", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--lines", type=int, default=128)
    args = ap.parse_args(argv)
    print(markdown([study(label, model, opts, args.lines) for label, model, opts in CASES]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
