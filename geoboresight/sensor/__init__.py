"""The sensor's geometry: navigation, boresight, lever arm, pixel look directions, and the
direct georeferencing that takes them to the ground (Brook & Ben-Dor 2011, §2, Eq. 1–2).

Conventions (held by ``tests/test_direct_georef.py``):

* WGS84, ellipsoidal heights; ECEF is EPSG:4978, geodetic EPSG:4979, every conversion through
  pyproj.
* Body frame x forward, y right, z down. ``R_nb = Rz(heading)·Ry(pitch)·Rx(roll)`` takes the
  body frame to the local north-east-down frame; roll positive right wing down, pitch positive
  nose up, heading clockwise from true north.
* The boresight ``R_bs = Rz(dh)·Ry(dp)·Rx(dr)`` takes the sensor frame to the body frame.
* The lever arm runs from the navigation's reference point to the sensor, in body-frame
  metres.
* A pixel's across-track angle is positive to the right, its along-track angle positive
  forward; its look vector in the sensor frame is ``[tan along, tan across, 1]`` (normalised).
* A line recorded at time ``t`` sees the navigation at ``t + time_offset``.
"""
