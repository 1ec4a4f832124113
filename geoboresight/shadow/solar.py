"""The sun's position at the acquisition: zenith and azimuth from the time and the place.

``shadow-map --dsm`` casts the surface model's shadows from the sun's zenith and azimuth. A
user who knows the flight's time (the navigation file, the product's metadata) gives it
instead of the angles, and the angles are computed here with NREL's Solar Position Algorithm
(Reda & Andreas 2004; ±0.0003° over −2000 to 6000), as implemented by the ``sunposition``
package (numpy only). The observed position is used (atmospheric refraction included): it is
the direction the shadows are cast from.

References
----------
Reda, I.; Andreas, A. Solar position algorithm for solar radiation applications. Solar
Energy 2004, 76, 577–589. https://doi.org/10.1016/j.solener.2003.12.003
"""

from __future__ import annotations

import datetime as dt
import math

import numpy as np

from ..errors import ParameterError

#: Standard atmosphere for the refraction term (SPA's defaults are the same order; the
#: refraction at a zenith below 80° is under 0.1°, so the exact values barely matter).
PRESSURE_MBAR = 1013.25
TEMPERATURE_C = 15.0


def parse_time(value, label: str = "parameter 'acquisition_time'") -> dt.datetime:
    """An ISO 8601 date and time as an aware UTC datetime; a time without a UTC offset is
    read as UTC (the time of GPS navigation files and sensor metadata)."""
    if isinstance(value, dt.datetime):
        t = value
    else:
        text = str(value).strip()
        try:
            t = dt.datetime.fromisoformat(text)
        except ValueError:
            raise ParameterError(
                f"{label}: {text!r} is not an ISO 8601 date and time: give e.g. "
                "2009-06-20T10:32:00Z (UTC) or 2009-06-20T13:32:00+03:00"
            ) from None
        if len(text) <= 10:  # a date alone: the sun's position needs the time of day
            raise ParameterError(
                f"{label}: {text!r} has no time of day: give the acquisition's time too, "
                "e.g. 2009-06-20T10:32:00Z"
            )
    if t.tzinfo is None:
        t = t.replace(tzinfo=dt.UTC)
    return t.astimezone(dt.UTC)


def states_offset(value) -> bool:
    """Whether an acquisition time (as :func:`parse_time` takes it) states its UTC offset."""
    if isinstance(value, dt.datetime):
        return value.tzinfo is not None
    try:
        return dt.datetime.fromisoformat(str(value).strip()).tzinfo is not None
    except ValueError:
        return False


def sun_position(
    time,
    longitude: float,
    latitude: float,
    elevation: float = 0.0,
    *,
    pressure: float = PRESSURE_MBAR,
    temperature: float = TEMPERATURE_C,
    delta_t: float = 0.0,
) -> tuple[float, float]:
    """The sun's (zenith, azimuth) in degrees seen from a place at a time.

    Parameters
    ----------
    time : str or datetime
        ISO 8601; without a UTC offset it is UTC (:func:`parse_time`).
    longitude, latitude : float
        Degrees (east and north positive, WGS 84).
    elevation : float
        Metres above the ellipsoid.
    pressure, temperature : float
        Mean air pressure (mbar) and temperature (°C) for the refraction.
    delta_t : float
        TT − UT in seconds (SPA's ΔT; about 69 s in the 2020s; 0 changes the angles by
        under 0.001°).

    Returns
    -------
    zenith, azimuth : float
        The observed (refracted) zenith angle, and the azimuth clockwise from north towards
        the sun, as ``sun-shadow`` and ``shadow-map`` take them.

    References
    ----------
    Reda & Andreas (2004), the Solar Position Algorithm (SPA).
    """
    import sunposition

    t = parse_time(time)
    lon, lat = float(longitude), float(latitude)
    if not (math.isfinite(lon) and -180.0 <= lon <= 360.0):
        raise ParameterError(f"longitude {longitude!r} is not in −180…360°")
    if not (math.isfinite(lat) and -90.0 <= lat <= 90.0):
        raise ParameterError(f"latitude {latitude!r} is not in −90…90°")
    stamp = np.datetime64(t.replace(tzinfo=None), "us")
    az, zen = sunposition.sunposition(
        stamp,
        lat,
        (lon + 180.0) % 360.0 - 180.0,
        float(elevation),
        temperature=float(temperature),
        pressure=float(pressure),
        delta_t=float(delta_t),
        jit=False,
    )[:2]
    return float(zen), float(az) % 360.0
