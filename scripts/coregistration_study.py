"""How RX's AUC changes with the way the SWIR is co-registered (issue 24, goal A).

The study behind docs/anomaly.md, "Co-registration methods compared". On the scenes of
``scripts/validate_anomaly.py`` (same seeds, offsets measured the same way), RX on the raw stack
(``none``) against RX after co-registering with:

* ``cubic``: the SWIR resampled by the offset with a cubic spline (the operations' default,
  :func:`geoboresight.dem.coregister.coregister`);
* ``linear``: the same with order 1;
* ``round``: the SWIR moved by the offset rounded to whole pixels (a permutation of pixels:
  the noise is untouched; the residual ≤ 0.5 px is left);
* ``split-cubic`` / ``split-linear``: whole pixels exactly, and the fractional part φ shared
  between the instruments, VNIR by −φ/2 and SWIR by +φ/2 with the same kernel, so that both
  are smoothed by the same noise gain (the kernel at t and at −t is the same, mirrored); the
  score is then on a grid φ/2 off the VNIR's;
* ``both``: RX on the VNIR, the raw SWIR and the cubic co-registered SWIR stacked (the
  Mahalanobis distance never drops when variables are added, but the background gains degrees
  of freedom);
* ``vnir``, ``swir``, ``swir-cubic``: RX on one instrument's bands alone (the SWIR raw or
  co-registered): what each carries of the targets.

Each method is built from :func:`~geoboresight.dem.coregister.coregister` (a whole-pixel
offset is an exact move of pixels at any order: tests/test_dem.py). AUC on the pixels valid for
every method; truth as in the validation (abundance > 0, guard 2 px).

    python scripts/coregistration_study.py [--group dev --group holdout] [--methods cubic,round]
        [--seed 4061]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

import validate_anomaly as va  # noqa: E402

from geoboresight.anomaly import roc  # noqa: E402
from geoboresight.anomaly import rx as rxmod  # noqa: E402
from geoboresight.anomaly.bands import select_bands  # noqa: E402
from geoboresight.dem.coregister import coregister  # noqa: E402
from geoboresight.dem.offset import estimate_offset  # noqa: E402
from geoboresight.io.wavelengths import nearest_band  # noqa: E402

METHODS = ("cubic", "linear", "round", "split-cubic", "split-linear", "both")
SINGLE = ("vnir", "swir", "swir-cubic")
ORDER = {"cubic": 3, "linear": 1}


def _shift(cube, along, across, order):
    out = np.empty_like(cube)
    for i in range(cube.shape[0]):
        out[i], _ = coregister(cube[i], along, across, order=order)
    return out


def stacks(vnir, swir, along, across, method):
    """(VNIR, SWIR) as ``method`` co-registers them."""
    if method == "none":
        return vnir, swir
    if method in ORDER:
        return vnir, _shift(swir, along, across, ORDER[method])
    if method == "vnir":
        return vnir, swir[:0]
    if method.startswith("swir"):
        return vnir[:0], stacks(vnir, swir, along, across, method[5:] or "none")[1]
    if method == "both":
        return vnir, np.concatenate([swir, _shift(swir, along, across, 3)])
    n, m = round(along), round(across)
    if method == "round":
        return vnir, _shift(swir, float(n), float(m), 0)
    order = ORDER[method.split("-")[1]]
    fa, fc = along - n, across - m
    return _shift(vnir, -fa / 2, -fc / 2, order), _shift(swir, n + fa / 2, m + fc / 2, order)


def rx_score(vnir, swir, wl_v, wl_s):
    wl_s = np.resize(wl_s, swir.shape[0])  # "both" stacks the SWIR twice
    wl_v = wl_v[: vnir.shape[0]]  # "swir" keeps no VNIR band
    bands = select_bands(np.concatenate([wl_v, wl_s]), vnir.shape[0] + swir.shape[0])
    cube = np.concatenate([vnir, swir])[bands]
    good = np.all(np.isfinite(cube), axis=0)
    score = np.full(good.shape, np.nan)
    score[good] = rxmod.rx(cube[:, good][:, None, :])[0]
    return score


def main(groups, methods, only_seed=None):
    gains = {g: {m: [] for m in methods} for g in groups}
    for group in groups:
        sim_seeds, m2_seeds = va.GROUPS[group]
        scenes = [
            ("simulate", label, s, off, preset)
            for label, preset in va.SIM_SCENES.items()
            for s in sim_seeds
            for off in va.SIM_OFFSETS
        ] + [("model2", "mixed", s, off, None) for s in m2_seeds for off in va.M2_OFFSETS]
        for model, label, seed, off, preset in scenes:
            if only_seed is not None and seed != only_seed:
                continue
            if model == "simulate":
                v, s, wv, ws, ab, _ = va.sim_scene(preset, off, seed)
            else:
                v, s, wv, ws, ab, _ = va.m2_scene(off, seed)
            o = estimate_offset(v[nearest_band(wv, 920.0, 15.0)], s[nearest_band(ws, 1010.0, 25.0)])
            scores = {
                m: rx_score(*stacks(v, s, o.along, o.across, m), wv, ws) for m in ("none", *methods)
            }
            common = np.logical_and.reduce([np.isfinite(x) for x in scores.values()])
            targets, background = roc.truth_mask(ab, guard_px=2)
            auc = {
                m: roc.roc_curve(x, targets & common, background & common).auc
                for m, x in scores.items()
            }
            for m in methods:
                gains[group][m].append(auc[m] - auc["none"])
            print(
                f"{group:8s} {model:8s} {label:5s} {seed:5d} δ {o.along:+.2f},{o.across:+.2f} "
                f"none {auc['none']:.3f}  "
                + "  ".join(f"{m} {auc[m] - auc['none']:+.3f}" for m in methods),
                flush=True,
            )
    print("method: worst, within 0.01 (n/N), mean change of AUC against RX on the raw stack")
    pools = {"dev + holdout": [g for g in groups if g != "holdout2"], "holdout2": ["holdout2"]}
    for pool, members in pools.items():
        members = [g for g in members if g in gains]
        if not members:
            continue
        print(pool)
        for m in methods:
            g = np.concatenate([gains[k][m] for k in members])
            if not g.size:
                continue
            print(f"  {m:13s} {g.min():+.4f}  {np.sum(g >= -0.01)}/{g.size}  {g.mean():+.4f}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--group", action="append", choices=tuple(va.GROUPS))
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--seed", type=int, help="only this seed's scenes")
    a = ap.parse_args()
    methods = a.methods.split(",")
    bad = [m for m in methods if m not in METHODS + SINGLE]
    if bad:
        ap.error(
            f"parameter 'methods': unknown {', '.join(bad)} (choose from {', '.join(METHODS)})"
        )
    t = time.perf_counter()
    main(tuple(a.group or ("dev", "holdout")), methods, a.seed)
    print(f"{time.perf_counter() - t:.0f} s")
