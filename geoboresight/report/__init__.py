"""The scene report: one HTML page made by running the paper's operations on one scene.

It sits above :mod:`geoboresight.operations` (whose file-level functions it runs, with values
its own spec has checked) and below the specs of :mod:`geoboresight.algorithms`.
"""
