"""``rio boresight``: the geoboresight operations as a rasterio CLI plugin.

Registered in the ``rasterio.rio_plugins`` entry point group (as rio-cogeo does), so after
``pip install geoboresight`` the commands appear under ``rio``::

    rio boresight list
    rio boresight ratio --vnir scene_vnir.hdr --swir scene_swir.hdr -o ratio.tif

The subcommands are the very commands of the ``geoboresight`` CLI (:mod:`geoboresight.cli`),
generated from the same specs: same names, options, defaults, ranges and messages.
"""

from __future__ import annotations

import click

from . import __version__
from .cli import SpecGroup


@click.group(
    cls=SpecGroup,
    name="boresight",
    short_help="Boresight effect of dual VNIR+SWIR sensors (geoboresight).",
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.version_option(__version__, prog_name="rio boresight")
def boresight():
    """geoboresight operations (Brook & Ben-Dor 2011): the boresight band ratio
    b(1010 nm)/b(920 nm) and its statistics, shadow map, relative DEM, sub-pixel anomalies.

    Run `rio boresight list` for the operations and `rio boresight OPERATION --help` for one.
    The same commands are available as `geoboresight OPERATION`.
    """
