"""Spec of de-shadowing: a VNIR + SWIR cube and a shadow fraction in, the cube with shadowed
pixels scaled to their sunlit signal out. Declaration only: ``run`` is
:func:`geoboresight.operations.deshadow.deshadow_file`."""

from __future__ import annotations

from dataclasses import replace

from ..operations.deshadow import LightModel, deshadow_file
from ._common import BLOCK_ROWS, DUAL_PARAMS, OFFSET
from .shadow_map import DARK, GROUP, SURFACE
from .spec import Algorithm, FileOut, Flag, Group, RasterIn, RasterOut, Result

#: The shadow map's surface model and sun (SurfaceModel), described for de-shadowing: the same
#: members (a DSM on a map grid through the line's IGM, the sun from the acquisition time),
#: two of them with their de-shadowing meaning; the shadow map's registration of the DSM to
#: the image is not offered (de-shadowing uses the DSM where it is).
_DESCRIPTIONS = {
    "dsm": "Surface model (DSM, m) on the image's grid, or on a map grid with the line's IGM: "
    "pairs chosen by geometry and each pixel's sky-view factor (empty = one ratio for all)",
    "clearance": "Height an obstacle must rise above a cell to hide its sky: about 3 × the "
    "DSM's height noise (m)",
}
SURFACE_DESHADOW = replace(
    SURFACE,
    params=tuple(
        replace(p, description=_DESCRIPTIONS[p.name]) if p.name in _DESCRIPTIONS else p
        for p in SURFACE.params
        if p.name != "register"
    ),
)

#: What de-shadowing models of the light beyond one ratio per band (LightModel).
LIGHT = Group(
    name="light",
    value=LightModel,
    params=(
        Flag(
            name="additive",
            label="Additive signal",
            description="Also estimate each band's additive signal (path radiance, a dark level "
            "that differs from band to band) from the intercept of the pairs' line (with the "
            "surface model's slopes) and the dark object, and scale only the signal above it "
            "(not the default: see docs/deshadow.md)",
        ),
        Flag(
            name="adjacency",
            label="Adjacency light",
            description="Also light each pixel by its sunlit surroundings (the light they "
            "reflect into the part of its sky they hide, 1 − its sky-view factor; their share "
            "fitted per band on the pairs), so each pixel gets its own ratio; needs the surface "
            "model (not the default: see docs/deshadow.md)",
        ),
        Flag(
            name="regions",
            label="Each neighbourhood's own ratio",
            description="Each neighbourhood of shadows (96 px) gets its own illumination "
            "ratio from the edges of its shadows, the scene's where it has too few (not with "
            "the adjacency light; not the default: see docs/deshadow.md)",
        ),
    ),
)

DESHADOW = Algorithm(
    name="deshadow",
    example={
        "vnir": "vnir.hdr",
        "swir": "swir.hdr",
        "shadow": "shadow_fraction.tif",
        "output": "deshadowed.tif",
    },
    results=(
        Result("pairs", "number", "Pairs of shadowed and sunlit pixels across shadow edges"),
        Result("pairs_used", "number", "Pairs that measured the illumination ratio"),
        Result("pair_spread", "number", "Median RMS log difference of the pairs used"),
        Result("ratio_min", "number", "Smallest sunlit-to-shadow ratio over the bands"),
        Result("ratio_max", "number", "Largest sunlit-to-shadow ratio over the bands"),
        Result("shadowed_pixels", "number", "Pixels corrected (shadow fraction above 0)"),
        Result(
            "bands_unchanged", "number", "Bands left as they are (no illumination ratio measured)"
        ),
        Result(
            "bands_unresolved",
            "number",
            "Bands left as measured: their signal in full shadow below 3 × its noise there",
        ),
        Result(
            "regions", "number", "Tiles of 32 px de-shadowed with their neighbourhood's own ratio"
        ),
        Result("offset_along_px", "number", "Offset along track (pixels)"),
        Result("offset_across_px", "number", "Offset across track (pixels)"),
    ),
    display_name="De-shadow (VNIR + SWIR cube and a shadow fraction)",
    group=GROUP,
    short_help="The cube with shadowed pixels scaled to their sunlit signal, the illumination "
    "ratio measured across the scene's shadow edges.",
    help=(
        "Scales each shadowed pixel to the signal it would have in the sun. A pixel with a "
        "shadow fraction f receives the direct sunlight on (1 − f) of it and the sky's diffuse "
        "light everywhere, so its sunlit signal is L / (1 − f·(1 − 1/k)), with k the band's "
        "ratio of sunlit to shadowed signal of one surface (about 3 in the blue, 10–30 in the "
        "SWIR). k is measured on the scene: pairs of a fully shadowed pixel and a sunlit pixel "
        "2–4 pixels away across a shadow edge (each at least a pixel from it), the pairs most alike once corrected (the same "
        "surface on both sides) kept.\n\n"
        "With a surface model (DSM on the image's grid, and the sun's zenith and azimuth) the "
        "pairs are chosen by geometry: the sunlit pixel down-sun or beside the shadow (not "
        "towards the sun, where the caster is) and at about the same height; and each pixel "
        "gets the sky in proportion to its sky-view factor from the DSM, so shadow in a "
        "courtyard or against a wall is brightened more than open shadow.\n\n"
        "Inputs: the cube (VNIR + SWIR, raw DN or radiance) and a shadow fraction on its grid "
        "(the 'fraction' output of the Boresight shadow map, best with a surface model, or "
        "Sun shadow's fraction). Dark levels as the shadow map finds them (0 for radiance): "
        "the correction scales the signal above the dark level, which is added back, so "
        "pixels out of shadow keep their values. Output: a float cube (VNIR bands then SWIR "
        "bands, wavelengths in the band descriptions and tags), the ratio of each band in the "
        "tags and the optional JSON report. A band whose signal in full shadow is below 3 × its "
        "noise there (measured on neighbouring shadowed pixels) cannot be recovered: it is left "
        "as measured, not amplified, and flagged in the band tags, the report and the optional "
        "mask. Validated on two scene models (docs/deshadow.md); "
        "without a surface model one ratio per scene: shadow lit by sunlit walls or under "
        "little sky is under- or over-corrected."
    ),
    params=(
        *DUAL_PARAMS,
        RasterIn(
            name="shadow",
            label="Shadow fraction",
            description="Shadow fraction (0–1) on the image's grid: the shadow map's 'fraction' or Sun shadow's output",
        ),
        SURFACE_DESHADOW,
        DARK,
        OFFSET,
        LIGHT,
        BLOCK_ROWS,
        RasterOut(
            name="output", label="De-shadowed", description="De-shadowed cube (float32, all bands)"
        ),
        RasterOut(
            name="unresolved",
            label="Bands left as measured",
            description="Byte mask: 1 where a shadowed pixel holds bands left as measured (their "
            "signal in full shadow below 3 × its noise, named in the band tags), 0 elsewhere",
            optional=True,
        ),
        FileOut(
            name="report",
            label="Report",
            description="JSON report: each band's illumination ratio and dark level",
            optional=True,
            extension="json",
        ),
    ),
    run=deshadow_file,
)

ALGORITHMS = (DESHADOW,)
