"""The refinement of a ray's bracketing step, shared by the compiled march and its NumPy
reference: at most ``REFINE_STEPS`` Illinois false-position steps, until the ray's height
above the DEM is within ``TOLERANCE`` metres (or the bracket is 2**-40 of the ray's stretch)."""

REFINE_STEPS = 60
TOLERANCE = 1e-6
