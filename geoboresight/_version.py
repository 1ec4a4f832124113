"""The version, in one place: the package, its wheel (pyproject.toml), the Makefile and the
QGIS plugin's metadata read it from here."""

__version__ = "0.1.0"
