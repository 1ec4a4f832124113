"""Dual pushbroom viewing geometry: lines of sight, ray–surface intersection, boresight truth.

Frame: the aircraft flies along +y at a constant flying height ``H`` above the lowest ground
(z = 0), level, with no attitude changes; line ``t`` (fractional allowed) is exposed with the
aircraft at ``(0, t·Δ, H)``, ``Δ`` being the along-track line spacing (ground speed × frame
period). Column ``c`` of a 286-pixel line looks at the across-track angle
``φ = (c − 142.5) · IFOV`` in the sensor, then through the instrument's boresight rotation
``R = R_yaw · R_pitch · R_roll`` (roll about the flight axis, positive to the right; pitch about
the across-track axis, positive forward; yaw about the vertical, positive clockwise seen from
above). A ray with direction ``d`` meets height ``z`` at ``x = (H − z)·u``,
``y = t·Δ + (H − z)·v`` with ``u = d_x/−d_z``, ``v = d_y/−d_z``.

**Squint and vendor co-registration.** The along-track squint θ is the difference of the two
instruments' pitch angles. The SWIR line then sees the ground ``(H − z)·(v_s − v_v) ≈
(H − z)·tan θ`` ahead of the VNIR line. The vendor's processing co-registers SWIR to VNIR with a
fixed shift computed for the nominal altitude ``H_nom`` on flat ground (Specim: 6,000 ft), i.e.
it removes a ground distance ``H_nom·tan θ`` (converted to lines with the flight's line
spacing) and the across-track angle difference. What is delivered, and simulated here, is
therefore the residual

    along offset (SWIR row − VNIR row of one feature) = −(H − H_nom − z)·tan θ / Δ

so a feature at VNIR row r appears at SWIR row r + along, and the offset changes by
+tan θ / Δ per metre of surface height (relief parallax). Across-track the offset does not
depend on height at all (both instruments see from the same point at a given time; only the
time differs, along the track), so the across-track disparity is 0 in this model.

Each instrument's pixel is sampled by rays spread over its instantaneous field of view and its
line period, each intersected with the DSM by ray marching (occlusion by buildings and hills
included) and refined by bisection: the two images are sampled at their own true footprints,
never shifted.

Not modelled: aircraft attitude changes (roll/pitch/yaw jitter), GPS/INS, lever arm between the
two optics, smile/keystone and other optical distortion, Earth curvature, refraction,
different IFOV or pixel counts of the two instruments.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

COLS = 286
IFOV_MRAD = 1.0
FEET = 0.3048
#: Specim's nominal altitude for the AISA-Dual co-registration (the paper: 6,000 ft).
NOMINAL_ALTITUDE_M = 6000 * FEET


def _rotation(roll_deg: float, pitch_deg: float, yaw_deg: float) -> np.ndarray:
    r, p, y = np.radians([roll_deg, pitch_deg, yaw_deg])
    # Roll about +y (flight axis): positive turns a nadir ray towards +x.
    r_roll = np.array([[np.cos(r), 0, -np.sin(r)], [0, 1, 0], [np.sin(r), 0, np.cos(r)]])
    # Pitch about +x: positive turns a nadir ray towards +y (forward).
    r_pitch = np.array([[1, 0, 0], [0, np.cos(p), -np.sin(p)], [0, np.sin(p), np.cos(p)]])
    # Yaw about +z, clockwise seen from above: +y turns towards +x.
    r_yaw = np.array([[np.cos(y), np.sin(y), 0], [-np.sin(y), np.cos(y), 0], [0, 0, 1]])
    return r_yaw @ r_pitch @ r_roll


@dataclass(frozen=True)
class Instrument:
    """One pushbroom line camera: boresight angles (deg) and IFOV (mrad)."""

    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    yaw_deg: float = 0.0
    ifov_mrad: float = IFOV_MRAD
    cols: int = COLS

    def uv(self, col) -> tuple[np.ndarray, np.ndarray]:
        """Ground displacement per metre below the aircraft (u across, v along) for columns."""
        phi = (np.asarray(col, float) - 0.5 * (self.cols - 1)) * self.ifov_mrad * 1e-3
        d0 = np.stack([np.tan(phi), np.zeros_like(phi), -np.ones_like(phi)])
        d = _rotation(self.roll_deg, self.pitch_deg, self.yaw_deg) @ d0.reshape(3, -1)
        d = d.reshape(d0.shape)
        return d[0] / -d[2], d[1] / -d[2]


@dataclass(frozen=True)
class Geometry:
    """The flight and the two instruments, plus the vendor's co-registration of SWIR to VNIR."""

    flying_height: float
    nominal_altitude: float
    vnir: Instrument
    swir: Instrument
    line_spacing: float

    @property
    def gsd_m(self) -> float:
        """Across-track ground sampling distance at nadir on the lowest ground."""
        return self.flying_height * self.vnir.ifov_mrad * 1e-3

    @property
    def centre_col(self) -> float:
        return 0.5 * (self.vnir.cols - 1)

    def coregistration(self) -> tuple[float, float]:
        """(along, across) shift in pixels that the vendor applies to SWIR (raw = delivered + k).

        Chosen so that the centre pixel of a SWIR line and of a VNIR line see the same point of
        flat ground at the nominal altitude.
        """
        c0 = self.centre_col
        u_v, v_v = self.vnir.uv(c0)
        # Across: the SWIR column whose angle gives the same u (height-independent).
        cs = c0
        for _ in range(50):
            u_s, _ = self.swir.uv(cs)
            du = (self.swir.uv(cs + 1e-3)[0] - u_s) / 1e-3
            cs = cs - (u_s - u_v) / du
        k_across = float(cs - c0)
        _, v_s = self.swir.uv(cs)
        k_along = float(self.nominal_altitude * (v_v - v_s) / self.line_spacing)
        return k_along, k_across

    def rays(self, instrument: str, lines, cols, sub: int):
        """Line times t and (u, v) of ``sub × sub`` rays per pixel, shape (lines, cols, sub²).

        ``lines``/``cols`` are delivered pixel indices (1-D); for SWIR the vendor shift is added
        so that the delivered image is sampled at its true, co-registered footprint.
        """
        inst = self.vnir if instrument == "vnir" else self.swir
        k_along, k_across = self.coregistration() if instrument == "swir" else (0.0, 0.0)
        offs = (np.arange(sub) + 0.5) / sub - 0.5
        t = np.asarray(lines, float)[:, None, None, None] + k_along + offs[None, None, :, None]
        c = np.asarray(cols, float)[None, :, None, None] + k_across + offs[None, None, None, :]
        u, v = inst.uv(c)
        shape = (len(lines), len(cols), sub, sub)
        t = np.broadcast_to(t, shape).reshape(len(lines), len(cols), sub * sub)
        u = np.broadcast_to(u, shape).reshape(len(lines), len(cols), sub * sub)
        v = np.broadcast_to(v, shape).reshape(len(lines), len(cols), sub * sub)
        return t, u, v

    def truth(self) -> dict:
        """Boresight truth at the centre column: offsets, disparity per metre, σ_h, squint."""
        c0 = self.centre_col
        _, k_across = self.coregistration()
        _, v_v = self.vnir.uv(c0)
        _, v_s = self.swir.uv(c0 + k_across)
        tan_theta = float(v_s - v_v)
        along = (self.nominal_altitude - self.flying_height) * tan_theta / self.line_spacing
        along = along + 0.0  # no negative zero in truth.json
        per_m = tan_theta / self.line_spacing
        return {
            "offset_px": {"along": float(along), "across": 0.0},
            "disparity_px_per_m": {"along": float(per_m), "across": 0.0},
            "tan_squint": tan_theta,
            "height_precision_m_per_px": float(self.line_spacing / abs(tan_theta))
            if tan_theta
            else None,
        }


class Heights:
    """Surface height lookup on a fine window: smooth terrain plus flat-topped objects.

    The terrain is interpolated bilinearly (smooth slopes); objects (buildings, crowns) are
    constant over each cell, so walls are vertical at cell boundaries, exactly where the
    material raster changes (no spurious one-cell ramps).
    """

    def __init__(self, ground, dsm, win):
        self.ground = np.asarray(ground, "float32")
        self.objects = np.asarray(dsm, "float32") - self.ground
        self.win = win

    def __call__(self, x, y):
        win = self.win
        i, j = win.ij(x, y)
        i = np.clip(i, 0, win.ny - 1.000001)
        j = np.clip(j, 0, win.nx - 1.000001)
        i0 = np.floor(i).astype(np.intp)
        j0 = np.floor(j).astype(np.intp)
        fi = i - i0
        fj = j - j0
        g = self.ground
        z = (
            g[i0, j0] * (1 - fi) * (1 - fj)
            + g[i0, j0 + 1] * (1 - fi) * fj
            + g[i0 + 1, j0] * fi * (1 - fj)
            + g[i0 + 1, j0 + 1] * fi * fj
        )
        return z + self.objects[np.rint(i).astype(np.intp), np.rint(j).astype(np.intp)]


def intersect(t, u, v, geometry: Geometry, heights: Heights, z_lo: float, z_hi: float):
    """Positions and heights where rays first meet the surface (ray march, then bisection).

    ``t, u, v``: flat arrays of ray line times and directions; ``heights``: the surface
    (:class:`Heights`); ``z_lo``/``z_hi`` bound it. Returns (x, y, z) of the hits.
    """
    H = geometry.flying_height
    y0 = t * geometry.line_spacing
    cell = heights.win.cell
    slope = float(np.max(np.hypot(u, v))) + 1e-9
    dz = max(min(cell / slope, 4.0), 0.05)  # never step over more than a cell sideways
    steps = int(np.ceil((z_hi - z_lo) / dz)) + 1
    above = np.full(t.shape, z_hi)
    below = np.full(t.shape, z_lo)
    todo = np.arange(t.size)
    z_prev = np.full(t.shape, z_hi)
    for k in range(1, steps + 1):
        if todo.size == 0:
            break
        zk = max(z_hi - k * dz, z_lo)
        h = heights((H - zk) * u[todo], y0[todo] + (H - zk) * v[todo])
        hit = zk <= h
        done = todo[hit]
        above[done] = z_prev[done]
        below[done] = zk
        todo = todo[~hit]
        z_prev[todo] = zk
    # Bisection between the last height above the surface and the first below it.
    for _ in range(9):  # a step of <= 4 m halved 9 times: < 1 cm
        mid = 0.5 * (above + below)
        hit = mid <= heights((H - mid) * u, y0 + (H - mid) * v)
        below = np.where(hit, mid, below)
        above = np.where(hit, above, mid)
    z = 0.5 * (above + below)
    return (H - z) * u, y0 + (H - z) * v, z
