"""Relative DEM and 3-D view (Brook & Ben-Dor 2011, §3.2), from the instrument's offset and
co-registration (:mod:`geoboresight.sensor`).

- :mod:`.disparity`: dense sub-pixel matching with per-pixel reliability.
- :mod:`.height`: disparity → relative height, σ_h = σ_d · GSD / tan θ; the ground sample
  distance and the height-to-disparity factor of a flight.
- :mod:`.kriging`: PyKrige ordinary kriging in bounded memory (local neighbourhoods, blocks).
- :mod:`.relative`: the whole chain, array in, DEM out.
- :mod:`.view3d`: the image draped on the DEM (Figure 9E).
"""
