"""Navigation, line times and sensor models from the files an airborne survey holds.

Navigation (:func:`read_navigation`):

* **Applanix SBET** (``.out``, ``.sbet``): 136-byte records of 17 little-endian float64: GPS
  seconds of week, latitude and longitude (radians), ellipsoidal height, three velocities,
  roll, pitch, platform heading, wander angle (radians), three accelerations, three angular
  rates. The true heading is the platform heading minus the wander angle (as APL's
  ``SBETData::Reader``, github arsf/APL ``src/navfileclasses.cpp``).
* **The documented CSV**: a header ``time,lat,lon,height,roll,pitch,heading``: GPS seconds,
  degrees, WGS84 ellipsoidal metres, degrees (true heading).
* **Specim** ``.nav`` (ASCII NMEA): ``$GPGGA`` position (height = altitude above the geoid
  plus the geoid separation), ``$PRDID`` pitch, roll, heading (degrees), ``$GPZDA`` the date
  (UTC time of day to GPS seconds of week), ``$SPTSMP``/``$SPTSMP2`` the line sync: the first
  line is the sync's whole GPS second minus its delay (APL ``NavigationSyncer``).
* **HySpex per-line navigation text**: whitespace columns ``line time lat lon height roll
  pitch heading`` (a ``#`` header allowed), one row per image line.

Line times (:func:`read_line_times`, :func:`header_line_times`): a text file with one GPS
time per line, or the header's start time and line rate (Specim ``GPS Start Time`` and
``fps``, with ``acquisition date``; HySpex ``gps start time``/``frameperiod``).

Sensor models (:func:`read_sensor_model`): a CSV ``pixel,across_track_rad,along_track_rad``;
the HySpex/NEO text ``pixel vinkelx vinkely`` (as HyPro writes it: EnSpec/hypro
``sensor_model.py``); APL's view-vector ENVI file (3 bands: rotations about x, y and z per
detector pixel, ``spatial binning`` in its header; arsf/APL ``src/viewvectors.cpp``).
"""

from __future__ import annotations

import datetime as _dt
import os
import re

import numpy as np

from ..errors import InputError, ParameterError
from ..sensor.model import SensorModel
from ..sensor.navigation import Navigation
from .tables import read_table, read_text

#: The SBET record: 17 little-endian float64.
SBET_FIELDS = (
    "time", "lat", "lon", "height", "vx", "vy", "vz", "roll", "pitch", "platform_heading",
    "wander", "ax", "ay", "az", "wx", "wy", "wz",
)  # fmt: skip
SBET_DTYPE = np.dtype([(f, "<f8") for f in SBET_FIELDS])
#: The documented navigation CSV's columns.
CSV_COLUMNS = ("time", "lat", "lon", "height", "roll", "pitch", "heading")
#: The GPS epoch (seconds of week count from its Sunday 00:00).
GPS_EPOCH = _dt.date(1980, 1, 6)


def _require_file(path, label):
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(f"{label} {path} does not exist: check the path")
    return path


def read_sbet(path) -> Navigation:
    """An Applanix SBET (see the module's description)."""
    path = _require_file(path, "navigation")
    size = os.path.getsize(path)
    if size == 0 or size % SBET_DTYPE.itemsize:
        raise InputError(
            f"navigation {path} is {size:,} bytes, not a whole number of 136-byte SBET "
            "records (17 float64): is it an SBET?"
        )
    rec = np.fromfile(path, dtype=SBET_DTYPE)
    if not np.all(np.abs(rec["lat"]) <= np.pi / 2) or not np.all(np.abs(rec["lon"]) <= 2 * np.pi):
        raise InputError(
            f"navigation {path}: latitudes or longitudes beyond ±90°/±360° in radians; it is "
            "not a little-endian SBET"
        )
    heading = np.degrees(rec["platform_heading"] - rec["wander"]) % 360.0
    return Navigation(
        rec["time"], np.degrees(rec["lat"]), np.degrees(rec["lon"]), rec["height"],
        np.degrees(rec["roll"]), np.degrees(rec["pitch"]), heading, source=f"navigation {path}",
    ).cleaned()  # fmt: skip


def write_sbet(path, navigation: Navigation, *, wander_deg=0.0) -> None:
    """Write ``navigation`` as an SBET whose platform heading is the true heading plus
    ``wander_deg`` (scalar or per record); velocities, accelerations and rates are zero."""
    from .write import atomic_output

    n = len(navigation)
    rec = np.zeros(n, dtype=SBET_DTYPE)
    wander = np.broadcast_to(np.radians(np.asarray(wander_deg, dtype=float)), (n,))
    rec["time"] = navigation.time
    rec["lat"] = np.radians(navigation.lat_deg)
    rec["lon"] = np.radians(navigation.lon_deg)
    rec["height"] = navigation.height
    rec["roll"] = np.radians(navigation.roll_deg)
    rec["pitch"] = np.radians(navigation.pitch_deg)
    rec["wander"] = wander
    ph = np.radians(navigation.heading_deg) + wander
    rec["platform_heading"] = np.arctan2(np.sin(ph), np.cos(ph))
    with atomic_output(os.fspath(path)) as tmp:
        rec.tofile(tmp)


def read_navigation_csv(path) -> Navigation:
    """The documented CSV ``time,lat,lon,height,roll,pitch,heading`` (degrees, metres).
    Angles that look like radians (every roll, pitch and heading within ±2π while the
    heading turns) are refused."""
    path = _require_file(path, "navigation")
    table = read_table(path, "navigation")
    names = [h.strip().lower() for h in table.header]
    missing = [c for c in CSV_COLUMNS if c not in names]
    if missing:
        raise InputError(
            f"navigation {path} has no column {', '.join(missing)}; its header must be "
            f"{','.join(CSV_COLUMNS)} (GPS seconds, degrees, WGS84 ellipsoidal metres)"
        )
    idx = [names.index(c) for c in CSV_COLUMNS]
    try:
        values = np.array([[float(row[i]) for i in idx] for row in table.rows], dtype=float)
    except (ValueError, IndexError):
        for row, line in zip(table.rows, table.line_numbers, strict=True):
            try:
                [float(row[i]) for i in idx]
            except (ValueError, IndexError):
                raise InputError(
                    f"navigation {path}, line {line}: {row!r} is not seven numbers"
                ) from None
        raise
    if values.shape[0] < 2:
        raise InputError(f"navigation {path} holds {values.shape[0]} record(s); at least 2")
    t, lat, lon, h, roll, pitch, heading = values.T
    angles = np.concatenate([roll, pitch, heading])
    if (
        np.all(np.abs(angles) <= 2 * np.pi + 1e-9)
        and np.ptp(heading) > 0
        and (np.max(np.abs(heading)) > 0.2)
    ):
        raise InputError(
            f"navigation {path}: roll, pitch and heading all lie within ±2π ({np.min(angles):.3f}"
            f" to {np.max(angles):.3f}): they look like radians; the CSV takes degrees"
        )
    return Navigation(
        t, lat, lon, h, roll, pitch, heading % 360.0, source=f"navigation {path}"
    ).cleaned()


def write_navigation_csv(path, navigation: Navigation) -> None:
    """Write the documented CSV (full float precision)."""
    from .write import atomic_output

    data = np.stack(
        [navigation.time, navigation.lat_deg, navigation.lon_deg, navigation.height,
         navigation.roll_deg, navigation.pitch_deg, navigation.heading_deg], axis=1,
    )  # fmt: skip
    with atomic_output(os.fspath(path)) as tmp:
        np.savetxt(tmp, data, delimiter=",", header=",".join(CSV_COLUMNS), comments="", fmt="%.17g")


def _nmea_fields(line):
    line = line.strip()
    if "*" in line:
        line = line.split("*", 1)[0]
    return line.split(",")


def _gps_seconds_of_week(date: _dt.date, seconds_of_day: float, leap: float) -> float:
    days = (date - GPS_EPOCH).days % 7
    return days * 86400.0 + seconds_of_day + leap


def _hms(text):
    h, m, s = int(text[0:2]), int(text[2:4]), float(text[4:])
    return h * 3600.0 + m * 60.0 + s


def _deg(value, hemi, width):
    deg = float(value[:width]) + float(value[width:]) / 60.0
    return -deg if hemi in ("S", "W") else deg


def read_specim_nav(path, *, leap_seconds: float = 0.0):
    """A Specim ``.nav`` (NMEA text): the :class:`Navigation` (one record per ``$GPGGA``
    followed by a ``$PRDID``) and the first line's GPS time from its sync message (None
    without one). Times of day become seconds of week from the ``$GPZDA`` date, as APL reads
    them; ``leap_seconds`` shifts them (UTC to GPS: the leap seconds of the date)."""
    path = _require_file(path, "navigation")
    text = read_text(path, "navigation")
    date = None
    rows, sync = [], None
    pending = None
    for n, line in enumerate(text.splitlines(), start=1):
        f = _nmea_fields(line)
        key = f[0]
        try:
            if key == "$GPZDA" and len(f) >= 5:
                date = _dt.date(int(f[4]), int(f[3]), int(f[2]))
            elif key == "$GPGGA" and len(f) >= 12 and f[2] and f[4]:
                sep = float(f[11]) if f[11] else 0.0
                pending = [_hms(f[1]), _deg(f[2], f[3], 2), _deg(f[4], f[5], 3), float(f[9]) + sep]
            elif key == "$PRDID" and len(f) >= 4 and pending is not None:
                pitch, roll, heading = float(f[1]), float(f[2]), float(f[3])
                rows.append((*pending, roll, pitch, heading, date))
                pending = None
            elif key in ("$SPTSMP", "$SPTSMP2") and sync is None and rows:
                delay = float(f[-1])
                # the sync falls on the GPS second after the last fix; the first line
                # was taken ``delay`` seconds before it
                sync = (rows[-1][0], delay, rows[-1][7])
        except (ValueError, IndexError):
            raise InputError(f"navigation {path}, line {n}: cannot read {line.strip()!r}") from None
    if not rows:
        raise InputError(f"navigation {path} holds no $GPGGA record followed by $PRDID")
    if rows[0][7] is None and date is None:
        raise InputError(f"navigation {path} holds no $GPZDA date: GPS time cannot be known")
    first_date = next((r[7] for r in rows if r[7] is not None), date)
    t = np.array([_gps_seconds_of_week(r[7] or first_date, r[0], leap_seconds) for r in rows])
    vals = np.array([r[1:7] for r in rows], dtype=float)
    nav = Navigation(
        t, vals[:, 0], vals[:, 1], vals[:, 2], vals[:, 3], vals[:, 4], vals[:, 5] % 360.0,
        source=f"navigation {path}",
    ).cleaned()  # fmt: skip
    first = None
    if sync is not None:
        tod, delay, d = sync
        whole = np.floor(_gps_seconds_of_week(d or first_date, tod, leap_seconds)) + 1.0
        first = float(whole - delay)
    return nav, first


def read_hyspex_nav(path) -> tuple[Navigation, np.ndarray]:
    """HySpex per-line navigation text: ``line time lat lon height roll pitch heading``
    (whitespace, ``#`` comments). Returns the navigation and each line's time."""
    path = _require_file(path, "navigation")
    try:
        data = np.loadtxt(path, comments="#", ndmin=2)
    except ValueError as exc:
        raise InputError(f"navigation {path}: not a table of numbers ({exc})") from None
    if data.shape[1] != 8:
        raise InputError(
            f"navigation {path} has {data.shape[1]} columns; HySpex per-line navigation has 8: "
            "line time lat lon height roll pitch heading"
        )
    nav = Navigation(*data[:, 1:8].T, source=f"navigation {path}")
    return nav.cleaned(), data[:, 1].copy()


def read_navigation(path) -> Navigation:
    """The navigation in ``path``, by its layout: SBET (binary), CSV (a header naming
    ``time``), Specim ``.nav`` (``$GP`` sentences) or HySpex per-line text."""
    path = _require_file(path, "navigation")
    with open(path, "rb") as f:
        head = f.read(512)
    if b"\0" in head or path.lower().endswith((".out", ".sbet")):
        return read_sbet(path)
    text = head.decode("utf-8", errors="replace")
    if "$GP" in text or "$PRDID" in text:
        return read_specim_nav(path)[0]
    first = next((ln for ln in text.splitlines() if ln.strip() and not ln.startswith("#")), "")
    if re.search(r"[A-Za-z]", first):
        return read_navigation_csv(path)
    return read_hyspex_nav(path)[0]


def read_line_times(path, lines: int) -> np.ndarray:
    """One GPS time per image line, one per text line; refused unless there are ``lines``."""
    path = _require_file(path, "line times")
    try:
        t = np.loadtxt(path, comments="#", ndmin=1, dtype=float)
    except ValueError as exc:
        raise InputError(f"line times {path}: not one number per line ({exc})") from None
    if t.ndim != 1:
        raise InputError(f"line times {path}: one number per line, not {t.shape[1]} columns")
    if t.size != int(lines):
        raise InputError(
            f"line times {path} holds {t.size} times but the image has {lines} lines; give "
            "the line times of this image"
        )
    if not np.isfinite(t).all() or np.any(np.diff(t) <= 0):
        raise InputError(f"line times {path}: the times must be finite and increasing")
    return t


def header_line_times(keys: dict, lines: int, label: str = "the image header") -> np.ndarray:
    """Line times from a header's start time and line rate: Specim ``gps start time``
    (``UTC hh:mm:ss.sss``, taken as GPS time of day as APL does) with ``acquisition date``
    (``dd-mm-yyyy``) and ``fps``; HySpex-style ``frameperiod`` (µs) instead of ``fps``; a
    plain number of seconds of week is taken as it is."""
    start = keys.get("gps start time")
    rate = keys.get("fps")
    period = None
    if rate:
        try:
            period = 1.0 / float(rate)
        except (ValueError, ZeroDivisionError):
            period = None
    elif keys.get("frameperiod"):
        period = float(keys["frameperiod"]) * 1e-6
    if start is None or period is None or period <= 0:
        raise InputError(
            f"{label} has no GPS start time and line rate (gps start time and fps); give "
            "the line times as a file"
        )
    t0 = _start_seconds(start, keys.get("acquisition date", ""), label)
    y0 = float(keys.get("y start", "0") or 0)
    return t0 + (y0 + np.arange(int(lines))) * period


def _start_seconds(start: str, date_text: str, label: str) -> float:
    try:
        return float(start)
    except ValueError:
        pass
    m = re.search(r"(\d{1,2}):(\d{2}):(\d{2}(?:\.\d*)?)", start)
    d = re.search(r"(\d{1,2})-(\d{1,2})-(\d{4})", date_text)
    if not m or not d:
        raise InputError(
            f"{label}: cannot read the GPS start time {start!r} with the acquisition date "
            f"{date_text!r} (dd-mm-yyyy)"
        )
    tod = int(m.group(1)) * 3600 + int(m.group(2)) * 60 + float(m.group(3))
    date = _dt.date(int(d.group(3)), int(d.group(2)), int(d.group(1)))
    return _gps_seconds_of_week(date, tod, 0.0)


def read_sensor_model(path) -> SensorModel:
    """A sensor model from a CSV ``pixel,across_track_rad,along_track_rad``, a HySpex/NEO
    ``pixel vinkelx vinkely`` text, or APL's view-vector ENVI file (by its ``.hdr``)."""
    path = _require_file(path, "sensor model")
    from .envi import envi_header

    keys = envi_header(path)
    if keys is not None:
        return _apl_view_vectors(path, keys)
    text = read_text(path, "sensor model")
    first = next((ln for ln in text.splitlines() if ln.strip()), "")
    if "," in first or ";" in first:
        return _sensor_csv(path)
    try:
        data = np.loadtxt(path, comments="#", ndmin=2)
    except ValueError as exc:
        raise InputError(f"sensor model {path}: not a table of numbers ({exc})") from None
    if data.shape[1] != 3:
        raise InputError(
            f"sensor model {path} has {data.shape[1]} columns; the HySpex model has 3: "
            "pixel vinkelx vinkely (radians)"
        )
    order = np.argsort(data[:, 0])
    return SensorModel(data[order, 1], data[order, 2], source=f"sensor model {path}")


def _sensor_csv(path):
    table = read_table(path, "sensor model")
    names = [h.strip().lower() for h in table.header]
    need = ("pixel", "across_track_rad", "along_track_rad")
    if any(c not in names for c in need):
        raise InputError(
            f"sensor model {path}: its header must be pixel,across_track_rad,along_track_rad"
        )
    idx = [names.index(c) for c in need]
    try:
        v = np.array([[float(r[i]) for i in idx] for r in table.rows], dtype=float)
    except (ValueError, IndexError):
        raise InputError(f"sensor model {path}: a row is not three numbers") from None
    order = np.argsort(v[:, 0])
    return SensorModel(v[order, 1], v[order, 2], source=f"sensor model {path}")


def _apl_view_vectors(path, keys):
    import rasterio

    if int(keys.get("bands", "0")) != 3:
        raise InputError(
            f"sensor model {path}: an APL view-vector file has 3 bands (rotations about x, y, z)"
        )
    with rasterio.open(path) as src:
        rot = src.read().astype(np.float64)
    # one row per detector pixel; x is the flight axis (the across-track angle), y the
    # along-track angle; the first line holds the vectors
    return SensorModel(rot[0, 0], rot[1, 0], source=f"sensor model {path}")


def write_sensor_model_csv(path, model: SensorModel) -> None:
    """Write the CSV sensor model."""
    from .write import atomic_output

    data = np.stack([np.arange(model.n_pixels), model.across_rad, model.along_rad], axis=1)
    with atomic_output(os.fspath(path)) as tmp:
        np.savetxt(tmp, data, delimiter=",", header="pixel,across_track_rad,along_track_rad",
                   comments="", fmt=["%d", "%.17g", "%.17g"])  # fmt: skip


def write_line_times(path, times) -> None:
    """Write one GPS time per line."""
    from .write import atomic_output

    with atomic_output(os.fspath(path)) as tmp:
        np.savetxt(tmp, np.asarray(times, dtype=float), fmt="%.9f")


def _spatial_binning(keys) -> int | None:
    text = keys.get("binning")
    if not text:
        return None
    parts = [p for p in text.strip("{} ").replace(",", " ").split() if p]
    try:
        # Specim writes binning = {spectral, spatial}
        return int(float(parts[-1]))
    except (ValueError, IndexError):
        return None


def sensor_model_for(sensor_model, fov, samples, keys, label="input"):
    """The sensor model trimmed and binned to the image (its header's ``x start`` in binned
    pixels and spatial ``binning``, as APL's view vectors are), or the ideal array of
    ``fov`` degrees."""
    if (sensor_model is None) == (fov is None):
        raise ParameterError(
            "give a sensor model or a field of view (fov), one of them",
            params=("sensor_model", "fov"),
        )
    if fov is not None:
        return SensorModel.ideal(samples, fov)
    model = read_sensor_model(sensor_model)
    binning = _spatial_binning(keys)
    x_start = int(float(keys.get("x start", "0") or 0))
    if binning and binning > 1 and model.n_pixels != samples + x_start:
        if model.n_pixels % binning == 0:
            model = model.binned(binning)
    if model.n_pixels == samples + x_start and x_start:
        return model.trimmed(x_start, samples)
    return model.for_image(samples, offset=0)


def line_times_for(line_times, keys, lines, navigation_path, label):
    """Each line's GPS time: the file, else the Specim ``.nav`` sync with the header's ``fps``,
    else the header's start time and line rate."""
    if line_times:
        return read_line_times(line_times, lines)
    if str(navigation_path).lower().endswith(".nav") and keys.get("fps"):
        _, first = read_specim_nav(navigation_path)
        if first is not None:
            y0 = float(keys.get("y start", "0") or 0)
            return first + (y0 + np.arange(lines)) / float(keys["fps"])
    return header_line_times(keys, lines, label)
