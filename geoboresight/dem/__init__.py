"""Relative DEM and 3-D view (Brook & Ben-Dor 2011, §3.2), boresight offset and co-registration.

- :mod:`.bands`: the images matched, one band or the mean of a band range.
- :mod:`.offset`: the global sub-pixel VNIR→SWIR shift (and per block, to see drift), in
  pixels and angles.
- :mod:`.coregister`: resample SWIR onto the VNIR grid (correct the effect after using it).
- :mod:`.disparity`: dense sub-pixel matching with per-pixel reliability.
- :mod:`.height`: disparity → relative height, σ_h = σ_d · GSD / tan θ; the ground sample
  distance and the height-to-disparity factor of a flight.
- :mod:`.kriging`: PyKrige ordinary kriging in bounded memory (local neighbourhoods, blocks).
- :mod:`.relative`: the whole chain, array in, DEM out.
- :mod:`.view3d`: the image draped on the DEM (Figure 9E).
"""
