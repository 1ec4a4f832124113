"""Automatic georeferencing against the simulator's true IGM, as a function of attitude jitter.

For each jitter (standard deviation of roll, pitch and yaw, correlated over 24 lines) and
seed: simulate a 256-line urban line with its orthophoto (``simulate_ortho``), place it
roughly from its four corners moved by 4–6 m, run the automatic tie points
(``match_tie_points``, SIFT, blocks of 16 lines and thin-plate spline), and measure the
fitted coordinates of every raw pixel against the true IGM, in pixels (1.5 m). A run is
"refused" as ``auto-georeference`` would refuse it: fewer than 12 inliers or a cross-validated
RMSE above 1 px. Accuracy, not speed: no peer exists (QGIS's Georeferencer is manual).

    python benchmarks/georef_jitter.py [--jitter 0 0.05 0.1 0.2 0.3] [--seeds 3]
"""

from __future__ import annotations

import argparse

import numpy as np

from geoboresight.georef.tiepoints import corrected, match_tie_points
from geoboresight.georef.transforms import fit_transform
from geoboresight.io.orthoscene import true_corners
from geoboresight.simulate.ortho import simulate_ortho

ERROR = np.array([[6.0, -4.0], [-5.0, 3.0], [4.0, 5.0], [-3.0, -6.0]])


def run(jitter: float, seed: int, model: str, lines: int = 256) -> dict:
    s = simulate_ortho("urban", lines, jitter_deg=jitter, seed=seed)
    h, w = s.raw.shape
    pl = np.array([[0, 0], [w, 0], [w, h], [0, h]], float)
    place = fit_transform(pl, true_corners(s.igm) + ERROR, order=1)
    jj, ii = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    px, py = place(jj, ii)
    before = np.hypot(px - s.igm[0], py - s.igm[1]) / 1.5
    tie = match_tie_points(
        s.raw, s.ortho[3], ref_transform=s.ortho_transform, placement=place, model=model, seed=seed
    )
    fx, fy = corrected(place, tie.displacement)(jj, ii)
    err = np.hypot(fx - s.igm[0], fy - s.igm[1]) / 1.5
    return {
        "placement_rmse": float(np.sqrt(np.mean(before**2))),
        "inliers": tie.inliers,
        "cv_rmse": tie.rmse_px,
        "rmse": float(np.sqrt(np.mean(err**2))),
        "within1": float(np.mean(err < 1.0)),
        "refused": tie.inliers < 12 or tie.rmse_px > 1.0,
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--jitter", type=float, nargs="+", default=[0.0, 0.05, 0.1, 0.2, 0.3])
    ap.add_argument("--seeds", type=int, default=3)
    args = ap.parse_args()
    print(
        "| jitter (°, std) | model | rough placement RMSE (px) | inliers | cross-validated RMSE (px) "
        "| RMSE vs true IGM (px) | pixels within 1 px | refused |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for jitter in args.jitter:
        for model in ("blocks", "tps"):
            rows = [run(jitter, seed, model) for seed in range(args.seeds)]
            m = {k: np.mean([r[k] for r in rows]) for k in rows[0] if k != "refused"}
            refused = sum(r["refused"] for r in rows)
            print(
                f"| {jitter:g} | {model} | {m['placement_rmse']:.2f} | {m['inliers']:.0f} | "
                f"{m['cv_rmse']:.2f} | {m['rmse']:.2f} (max {max(r['rmse'] for r in rows):.2f}) | "
                f"{100 * m['within1']:.1f} % | {refused} of {len(rows)} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
