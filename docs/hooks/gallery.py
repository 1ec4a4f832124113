"""The gallery of the paper's figures as the sample scene makes them: each figure is the
commands and code below, run from the repository's top folder (outputs in ``out/``), and the
image they draw. The site's build runs exactly this text (docs/hooks/site.py), so what the page
shows is what drew the picture.
"""

from __future__ import annotations

SCENE = "sample_data/scene"

#: Python that draws a row of image panels (the gallery's own figures: Fig. 2 and 11).
PANELS = '''
import numpy as np
import rasterio
from matplotlib.figure import Figure


def panels(images, path, cmap="gray"):
    """A row of images, each stretched between its 2nd and 98th percentile."""
    fig = Figure(figsize=(3.2 * len(images), 2.6), layout="constrained", dpi=110)
    for ax, (image, title) in zip(fig.subplots(1, len(images)), images):
        image = np.ma.masked_invalid(np.where(image == -9999, np.nan, image.astype(float)))
        if image.ndim == 3:  # an RGB: each channel stretched
            lo, hi = np.nanpercentile(image.filled(np.nan), [2, 98], axis=(0, 1))
            ax.imshow(np.clip((image.filled(0) - lo) / (hi - lo), 0, 1))
        else:
            lo, hi = np.nanpercentile(image.compressed(), [2, 98])
            ax.imshow(image, cmap=cmap, vmin=lo, vmax=hi)
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
    fig.savefig(path)
'''

FIGURES = [
    {
        "figure": "Figure 2",
        "title": "The boresight band",
        "caption": "(A) the VNIR band nearest 948 nm, (B) the SWIR band nearest 1,010 nm, "
        "(C) their ratio, the boresight band (Eq. 3): high in core shadow and where the two "
        "optics see different ground.",
        "steps": [
            (
                "sh",
                f"geoboresight ratio --vnir {SCENE}/vnir.hdr --swir {SCENE}/swir.hdr "
                "-o out/ratio.tif",
            ),
            (
                "python",
                PANELS
                + f'''
import geoboresight as gb

dual = gb.open_dual("{SCENE}/vnir.hdr", "{SCENE}/swir.hdr")
v, s = dual.vnir.band_for(948, 10), dual.swir.band_for(1010, 10)
with (
    rasterio.open("{SCENE}/vnir.img") as vnir,
    rasterio.open("{SCENE}/swir.img") as swir,
    rasterio.open("out/ratio.tif") as ratio,
):
    panels(
        [
            (vnir.read(v), f"(A) VNIR {{dual.vnir.wavelength_of(v):.0f}} nm"),
            (swir.read(s), f"(B) SWIR {{dual.swir.wavelength_of(s):.0f}} nm"),
            (ratio.read(1), "(C) boresight band"),
        ],
        "out/figure2.png",
    )
''',
            ),
        ],
        "image": "out/figure2.png",
    },
    {
        "figure": "Figure 3",
        "title": "Distribution of the boresight values",
        "caption": "The histogram of the boresight ratio with its mean and ±3σ; the statistics "
        "of Table 1 (N, mean, standard deviation, skewness with its standard error) are in "
        "the JSON.",
        "steps": [
            (
                "sh",
                "geoboresight stats -i out/ratio.tif -o out/ratio_stats.json "
                "--histogram out/figure3.png",
            )
        ],
        "image": "out/figure3.png",
    },
    {
        "figure": "Figure 4",
        "title": "The shadow cluster",
        "caption": "The boresight ratio against the 941 nm band; the isolated cluster, found "
        "by a Gaussian mixture, is the shadow.",
        "steps": [
            (
                "sh",
                f"geoboresight shadow-cluster --ratio out/ratio.tif --vnir {SCENE}/vnir.hdr "
                "-o out/shadow_cluster.tif --plot out/figure4.png",
            )
        ],
        "image": "out/figure4.png",
    },
    {
        "figure": "Figure 5",
        "title": "Shadow fraction and the boresight ratio",
        "caption": "The ratio of detected shadow against the scene's true shadow fraction, "
        "with the fitted line ratio = a · fraction + b.",
        "steps": [
            (
                "sh",
                f"geoboresight shadow-fraction-fit --ratio out/ratio.tif "
                f"--truth {SCENE}/truth_shadow_fraction.tif --report out/fraction_fit.json "
                "--plot out/figure5.png",
            )
        ],
        "image": "out/figure5.png",
    },
    {
        "figure": "Figure 9",
        "title": "The relative DEM in 3-D",
        "caption": "Heights from the VNIR/SWIR parallax, kriged onto the grid, with the image "
        "draped on them (the sample's flight: 3° squint, 1,500 m, 1 mrad IFOV).",
        "steps": [
            (
                "sh",
                f"geoboresight relative-dem --vnir {SCENE}/vnir.hdr --swir {SCENE}/swir.hdr "
                f"--cloud-mask {SCENE}/truth_cloud_mask.tif --squint-deg 3 "
                "--flying-height 1500 --ifov-mrad 1 -o out/relative_dem.tif",
            ),
            (
                "sh",
                f"geoboresight view-3d --dem out/relative_dem.tif --vnir {SCENE}/vnir.hdr "
                f"--swir {SCENE}/swir.hdr -o out/figure9.png",
            ),
        ],
        "image": "out/figure9.png",
    },
    {
        "figure": "Figure 11",
        "title": "Anomaly detection",
        "caption": "(A) RGB of the scene (630, 550, 430 nm), (B) RX, (C) SVDD, (D) the "
        "boresight indicator; the sample scene holds 24 sub-pixel plastic bags.",
        "steps": [
            (
                "sh",
                f"geoboresight rx --vnir {SCENE}/vnir.hdr --swir {SCENE}/swir.hdr -o out/rx.tif",
            ),
            (
                "sh",
                f"geoboresight svdd --vnir {SCENE}/vnir.hdr --swir {SCENE}/swir.hdr "
                "-o out/svdd.tif",
            ),
            (
                "sh",
                "geoboresight boresight-indicator --ratio out/ratio.tif -o out/indicator.tif",
            ),
            (
                "python",
                PANELS
                + f'''
import geoboresight as gb

dual = gb.open_dual("{SCENE}/vnir.hdr", "{SCENE}/swir.hdr")
with rasterio.open("{SCENE}/vnir.img") as vnir:
    rgb = np.dstack([vnir.read(dual.vnir.band_for(nm, 10)) for nm in (630, 550, 430)])
scores = []
for name, title in (("rx", "(B) RX"), ("svdd", "(C) SVDD"), ("indicator", "(D) boresight")):
    with rasterio.open(f"out/{{name}}.tif") as src:
        scores.append((src.read(1), title))
panels([(rgb, "(A) RGB"), *scores], "out/figure11.png", cmap="magma")
''',
            ),
        ],
        "image": "out/figure11.png",
    },
    {
        "figure": "Figure 12",
        "title": "ROC curves",
        "caption": "Probability of detection against false alarm for RX, SVDD and the boresight "
        "indicator, against the scene's true target abundance.",
        "steps": [
            (
                "sh",
                "geoboresight roc --scores out/rx.tif --scores out/svdd.tif "
                "--scores out/indicator.tif --names RX,SVDD,boresight "
                f"--truth {SCENE}/truth_target_abundance.tif -o out/figure12.png "
                "--csv out/roc.csv",
            )
        ],
        "image": "out/figure12.png",
    },
    {
        "figure": "Radiance",
        "title": "The ratio of an AisaFENIX capture in DN and in radiance",
        "caption": "A raw capture of both detectors in one file, the VNIR bands integrated for "
        "10 ms and the SWIR bands for 3 ms (simulate --capture, with its calibration file). "
        "(A) the ratio b(1010)/b(920) of the raw DN: dark levels, gains and the two tints are "
        "in it, and the dark offsets make it rise in shadow; (B) the same ratio in radiance "
        "(L = (DN − dark) · gain / tint, µW cm⁻² sr⁻¹ nm⁻¹) read on the fly through the "
        "calibration: the tints and offsets are gone, what stands out is where the two optics "
        "see different ground (the edges), and its values compare between flights "
        "(docs/sensors.md, Radiance).",
        "steps": [
            (
                "sh",
                "geoboresight simulate --preset mixed --lines 96 --seed 4 --capture "
                "--output out/capture_scene",
            ),
            ("sh", "geoboresight ratio --vnir out/capture_scene/capture.hdr -o out/ratio_dn.tif"),
            (
                "sh",
                "geoboresight ratio --vnir out/capture_scene/capture.hdr "
                "--vnir-calibration out/capture_scene/capture_cal.cal -o out/ratio_radiance.tif",
            ),
            (
                "python",
                PANELS
                + """
with rasterio.open("out/ratio_dn.tif") as dn, rasterio.open("out/ratio_radiance.tif") as rad:
    a, b = dn.read(1), rad.read(1)
median = [float(np.median(x[x != -9999])) for x in (a, b)]
panels(
    [
        (a, f"(A) DN ratio (median {median[0]:.2f})"),
        (b, f"(B) radiance ratio (median {median[1]:.2f})"),
    ],
    "out/radiance_ratio.png",
)
""",
            ),
        ],
        "image": "out/radiance_ratio.png",
    },
    {
        "figure": "Eq. 1–2",
        "title": "From navigation to the map",
        "caption": "Each sensor's IGM from the aircraft's files (SBET, line times, sensor "
        "model, lever arm, boresight angles, DEM): the VNIR (blue) and SWIR (orange) "
        "footprints of the sample's simulated flight on the DEM's shaded relief, every "
        "20th line drawn; the two boresights (about a degree apart) put the two sensors' "
        "pixels on different ground.",
        "steps": [
            (
                "sh",
                f"geoboresight direct-georeference -i {SCENE}/vnir.hdr "
                f"--navigation {SCENE}/flight/flight.out "
                f"--line-times {SCENE}/flight/line_times.txt "
                f"--sensor-model {SCENE}/flight/vnir_model.csv "
                "--boresight 0.42 -0.31 0.55 --lever-arm 0.35 -0.12 0.28 "
                f"--dem {SCENE}/flight/dem.tif -o out/vnir_igm.tif",
            ),
            (
                "sh",
                f"geoboresight direct-georeference -i {SCENE}/swir.hdr "
                f"--navigation {SCENE}/flight/flight.out "
                f"--line-times {SCENE}/flight/line_times.txt "
                f"--sensor-model {SCENE}/flight/swir_model.csv "
                "--boresight -0.27 0.48 -0.36 --lever-arm 0.35 0.14 0.30 "
                f"--dem {SCENE}/flight/dem.tif -o out/swir_igm.tif",
            ),
            (
                "python",
                f'''
import numpy as np
import rasterio
from matplotlib.colors import LightSource
from matplotlib.figure import Figure

with rasterio.open("{SCENE}/flight/dem.tif") as dem:
    z, b = dem.read(1), dem.bounds
fig = Figure(figsize=(6.4, 5.2), layout="constrained", dpi=110)
ax = fig.subplots()
shade = LightSource(azdeg=315, altdeg=45).hillshade(z, vert_exag=2, dx=2, dy=2)
ax.imshow(shade, cmap="gray", extent=(b.left, b.right, b.bottom, b.top))
for name, colour in (("vnir", "tab:blue"), ("swir", "tab:orange")):
    with rasterio.open(f"out/{{name}}_igm.tif") as igm:
        x, y = igm.read(1), igm.read(2)
    ax.plot(x[::20].T, y[::20].T, color=colour, lw=0.8)
    ax.plot([], [], color=colour, label=name.upper())
ax.set_xlim(x.min() - 60, x.max() + 60)
ax.set_ylim(y.min() - 60, y.max() + 60)
ax.set_xlabel("easting (m)")
ax.set_ylabel("northing (m)")
ax.legend(loc="upper left")
fig.savefig("out/navigation.png")
''',
            ),
        ],
        "image": "out/navigation.png",
    },
]
