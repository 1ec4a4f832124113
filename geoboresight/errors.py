"""Errors a user can act on.

Every failure that comes from the user's input (a file, a band, a parameter) is raised as a
:class:`GeoboresightError` whose message names the thing at fault and says what to do. Faces
(CLI, QGIS, rio) print the message alone, without a traceback.
"""


class GeoboresightError(Exception):
    """Base class: a problem the user can fix; the message says how."""


class InputError(GeoboresightError, ValueError):
    """A missing or unreadable file, a band or wavelength that does not exist, mismatched grids."""


class ParameterError(GeoboresightError, ValueError):
    """A parameter outside its range, of the wrong type, or inconsistent with another."""


class OutputError(GeoboresightError, OSError):
    """An output that would overwrite an input, or an existing file without ``overwrite``."""


class ResourceError(GeoboresightError, OSError):
    """The machine ran out of something the run needs (memory); the message says what to lower."""


class Cancelled(GeoboresightError):
    """The user cancelled the run (QGIS cancel button, Ctrl-C); partial outputs were removed."""
