"""File-level sub-pixel anomaly detection and unmixing (paper §3.3): RX, SVDD and the boresight
indicator, score maps as vector features, linear unmixing and ROC curves. Whole flight lines,
streamed block by block.

SciPy's image module, scikit-learn, shapely and matplotlib are imported by the operations that
need them, so listing the operations and running RX load none of them.
"""

from __future__ import annotations

import contextlib
import os
import threading

import numpy as np

from .. import io
from ..anomaly.bands import BandSelection, select_bands
from ..anomaly.indicator import (
    THRESHOLD,
    Eq3Reference,
    check_options,
    indicator_score,
    local_residual,
    robust_location_blocks,
    valid_values,
)
from ..anomaly.physical import Detectability, Dipole
from ..anomaly.polygons import FIELDS
from ..anomaly.roc import PFA, TITLE
from ..anomaly.rx import RXBackground
from ..anomaly.svdd import NU, SAMPLE_SIZE
from ..errors import InputError, ParameterError
from ..io.bands import BoresightOffset, Coregistration
from ..io.cube import as_slice
from ..io.dual import DualLayout
from ..sensor.dark import ESTIMATED, DarkLevels, dark_object, describe_level
from ._dark import sensor_dark_levels
from ._offset import GIVE_OFFSET, boresight_offset

#: Pixels drawn at random for the dark-object estimate of a detector's detectability.
DARK_SAMPLE = 4000

#: Lines per strip of a cube: 16 lines of a 286-sample AISA line = 4,576 pixels, so a strip's
#: float buffers stay within a few MB (cache-friendly; memory is a few strips per worker).
CUBE_BLOCK_ROWS = 16


def open_image(vnir, swir=None, layout=DualLayout(), spectral=BandSelection()):
    """``(cube, bands, wavelengths, fwhm)``: the image, the 0-based cube bands ``spectral``
    chooses among its good bands (an ENVI 'bbl' marks the others bad), and their centres and
    FWHM (nm, or None).

    A dual dataset (an opened :class:`~geoboresight.io.DualSensor`, VNIR and SWIR files, or a
    sensor product holding both) is read through :func:`~geoboresight.io.as_dual` with
    ``layout``: its sensors' bands, stacked VNIR then SWIR, from what GDAL opens for them. One
    plain file (a merged cube, or a VNIR or SWIR cube alone) is read whole, wavelengths or not.
    """
    from ..io.products import recognise

    if isinstance(vnir, io.DualSensor) or swir or recognise(vnir) is not None:
        dual = io.as_dual(vnir, swir, layout)
        cube, good, wl, fwhm = io.open_sensors((dual.vnir, dual.swir))
        label = ", ".join(dual.files)
    else:
        cube = io.open_cube([vnir])
        good = np.flatnonzero(cube.good)  # bands an ENVI 'bbl' marks bad are never used
        wl = None if cube.wavelengths is None else cube.wavelengths[good]
        fwhm = None if cube.fwhm is None else cube.fwhm[good]
        label = vnir
    pick = select_bands(wl, good.size, spectral.include_nm, spectral.exclude_nm)
    if pick.size < 2:
        cube.close()
        raise InputError(
            f"{label}: once the bands its ENVI 'bbl' marks bad are left out, {pick.size} band(s) "
            "remain: a detector needs at least 2 (check the header's 'bbl' and include_nm)"
        )
    return (
        cube,
        good[pick],
        None if wl is None else wl[pick],
        None if fwhm is None else fwhm[pick],
    )


def band_tags(wl, bands) -> dict:
    """Output tags naming the bands (1-based) and wavelengths a detector used."""
    return {
        "bands_used": ",".join(str(int(b) + 1) for b in bands),
        "wavelengths_used_nm": "" if wl is None else ",".join(f"{w:.1f}" for w in wl),
    }


def to_float32(score: np.ndarray) -> np.ndarray:
    """A score as written: float32, nodata -9999 where not finite."""
    return np.where(np.isfinite(score), score, io.FLOAT_NODATA).astype("float32")


def _dual_of(vnir, swir, layout):
    """The dual dataset of the inputs, or None for one plain file (a merged cube without a
    seam, or one instrument alone)."""
    from ..io.products import recognise

    if isinstance(vnir, io.DualSensor) or swir or recognise(vnir) is not None:
        return io.as_dual(vnir, swir, layout)
    return None


def _cube_index(dual, sensor):
    """0-based cube bands of ``sensor``'s file bands, as :func:`io.open_sensors` stacks them."""
    reads = list(dict.fromkeys(s.reads for s in (dual.vnir, dual.swir)))
    counts = []
    for path in reads:
        with io.open_raster(path, "image") as src:
            counts.append(src.count)
    starts = np.cumsum([0, *counts])[:-1]
    return starts[reads.index(sensor.reads)] + np.asarray(sensor.bands, int) - 1


def _sample_reader(read, height, width, seed=0):
    """A random sample of ≤ DARK_SAMPLE pixels of ``read``: ``() -> (values, ok)``."""
    from ..anomaly import svdd

    def sample():
        rng = np.random.default_rng(seed)
        pos = svdd.sample_positions(height * width, DARK_SAMPLE, rng)
        return io.read_pixels(read, pos, height=height, width=width, message=None)

    return sample


def _detectability_result(name, dprime, target, progress, grey=None) -> dict:
    from ..anomaly import physical

    msg, low = physical.describe(name, dprime, target)
    progress.info(msg)
    if grey is not None:
        progress.info(
            f"{name}: expected d′ {grey:.2f} for a grey target of the same fill and contrast"
        )
    # A low d′ is a warning about the result (the result's "warnings", which every face shows
    # as a warning), not a Python warning: that printed the library's source line.
    extra = {} if grey is None else {"dprime_grey": round(float(grey), 4)}
    if low:
        extra["warnings"] = [msg]
    return {
        "dprime": round(float(dprime), 4),
        **extra,
        "dprime_low": bool(low),
        "target_fraction": target.target_fraction,
        "target_contrast": target.target_contrast,
    }


class _Coregistered:
    """The cube's strips with its SWIR bands resampled onto the VNIR grid (the boresight
    offset removed: :func:`geoboresight.sensor.coregister.coregister_stack`, cubic convolution),
    for RX and SVDD.

    Each strip is read in the files' own type with the lines the kernel's taps reach
    (:func:`~geoboresight.sensor.coregister.coregister_halo`), its SWIR bands shifted together in
    float32 (one valid mask for all) and cropped: the strip's values are the whole image's.
    Pixels whose interpolation reaches outside the image or an invalid pixel become invalid.
    Each pass resamples what it reads: a resampled copy of a long line would be as large as
    the line, beyond the memory bound."""

    def __init__(self, cube, bands, is_swir, along, across):
        from ..sensor.coregister import tap_lines

        self.cube, self.bands = cube, np.asarray(bands)
        # A dual dataset stacks VNIR then SWIR: slices, not copies, of each strip.
        self.vnir, self.swir = (
            as_slice(np.flatnonzero(~is_swir)),
            as_slice(np.flatnonzero(is_swir)),
        )
        self.along, self.across = along, across
        self.taps = tap_lines(along)

    def reader(self):
        from ..sensor.coregister import coregister_stack

        cube, (first, stop) = self.cube, self.taps
        k = len(self.bands)
        # The VNIR bands are read straight into the output in float32 (their own lines
        # only), the SWIR bands in float32 from the first line the taps reach to the last:
        # the shift's input as it is, without another copy.
        vnir_bands = self.bands[self.vnir]
        read_swir = cube.reader(self.bands[self.swir], np.float32)  # a buffer per thread
        local = threading.local()  # per worker thread: the output buffer

        def read(row0, row1):
            r0 = min(max(0, row0 + first), cube.height - 1)
            r1 = max(min(cube.height, row1 + stop - 1), r0 + 1)
            if getattr(local, "rows", 0) < row1 - row0:
                local.out = np.empty((k, row1 - row0, cube.width), np.float32)
                local.rows = row1 - row0
            out = local.out[:, : row1 - row0]
            if isinstance(self.vnir, slice):
                _, ok = cube.read(row0, row1, vnir_bands, np.float32, out=out[self.vnir])
            else:
                v, ok = cube.read(row0, row1, vnir_bands, np.float32)
                out[self.vnir] = v
            s, s_ok = read_swir(r0, r1)
            # Output line i of the strip samples image line row0 + i + along, which is
            # line i + (along − (r0 − row0)) of what was read: the same taps.
            _, valid = coregister_stack(
                s,
                self.along - (r0 - row0),
                self.across,
                s_ok,
                out=out[self.swir],
                lines=(0, row1 - row0),
            )
            # Values at invalid pixels are left as they are: RX and SVDD skip them.
            return out, valid & ok

        if cube.samples_by_line:
            read.pixels = self.pixels
        return read

    def pixels(self, positions):
        """``(values (bands, n) float32, valid (n,))`` at sorted flat ``positions``, as the
        strips hold them, reading only the lines of the pixels and of their SWIR taps
        (:meth:`Cube.pixels`): SVDD's training sample of a long line without shifting whole
        strips for one pixel each."""
        from ..sensor.coregister import pixel_taps, shift_sampled

        cube = self.cube
        out = np.empty((len(self.bands), len(positions)), np.float32)
        out[self.vnir], ok = cube.pixels(positions, self.bands[self.vnir], np.float32)
        taps, weights, inside = pixel_taps(
            positions, self.along, self.across, cube.height, cube.width
        )
        at, where = np.unique(taps, return_inverse=True)
        values, valid = cube.pixels(at, self.bands[self.swir], np.float32)
        where = where.reshape(taps.shape)
        out[self.swir], s_ok = shift_sampled(values[:, where], valid[where], weights)
        return out, ok & s_ok & inside


def _detector_input(vnir, swir, layout, spectral, dark, coregistration, target, progress):
    """What RX and SVDD start from: the target checked, the image prepared
    (:func:`_prepare_image`, co-registered as ``coregistration`` says) and the progress left
    for the detection."""
    from ..anomaly import physical

    physical.check_target(target)
    prepared = _prepare_image(
        vnir, swir, layout, spectral, dark, coregistration, coregistration.coregister, progress
    )
    coreg = prepared[4]
    return (*prepared, progress.sub(0.1 if coreg["coregistered"] else 0.0, 1.0))


def _prepare_image(vnir, swir, layout, spectral, dark, offset, coregistered, progress):
    """``(cube, bands, wl, reader, info, dark per band)``: :func:`open_image`, and the strip
    reader RX/SVDD use: the SWIR shifted onto the VNIR grid by the boresight offset (measured,
    or given) when ``coregistered`` and the input is a dual dataset."""
    cube, bands, wl, _ = open_image(vnir, swir, layout, spectral)
    try:
        dual = _dual_of(vnir, swir, layout)
        info = {"coregistered": False, "offset_along_px": None, "offset_across_px": None}
        is_swir = np.zeros(len(bands), bool)
        if dual is not None:
            is_swir = np.isin(bands, _cube_index(dual, dual.swir))
        read = cube.reader(bands, None)
        given = [
            n for n in ("offset_along", "offset_across") if getattr(offset, n, None) is not None
        ]
        if given and not (coregistered and dual is not None and is_swir.any()):
            # The offset only shifts the SWIR: ignored, it would be a silent no-op.
            named = " and ".join(repr(n) for n in given)
            raise ParameterError(
                f"parameter{'s' if len(given) > 1 else ''} {named}: the offset shifts the SWIR onto the VNIR grid, but "
                + (
                    "co-registration is off ('coregister'): leave the offset empty, or turn "
                    "co-registration on"
                    if not coregistered
                    else f"{vnir} is one file whose VNIR and SWIR bands cannot be told apart: "
                    "give the SWIR file separately (or a sensor product), or leave the offset "
                    "empty"
                )
            )
        if coregistered and dual is not None and is_swir.any():
            along, across, how = boresight_offset(
                dual,
                offset,
                progress.sub(0.0, 0.1),
                hint=GIVE_OFFSET + ", or leave the SWIR unshifted ('coregister' off)",
            )
            progress.info(
                f"co-registering: SWIR shifted by {along:+.3f} px along-track, "
                f"{across:+.3f} px across-track ({how})"
            )
            read = _Coregistered(cube, bands, is_swir, along, across).reader()
            info = {
                "coregistered": True,
                "offset_along_px": round(along, 4),
                "offset_across_px": round(across, 4),
            }
        elif coregistered:
            progress.info(
                "not co-registered: one file whose VNIR and SWIR bands cannot be told apart "
                "(give the SWIR file, or a sensor product)"
            )
        dark_per_band = np.zeros(len(bands))
        sample = _sample_reader(cube.reader(bands, "float64"), cube.height, cube.width)
        if dual is not None:
            cache = {}

            def sampled():
                if "s" not in cache:
                    cache["s"] = sample()
                return cache["s"]

            for sensor, mask in ((dual.vnir, ~is_swir), (dual.swir, is_swir)):
                if not mask.any():
                    continue
                index = _cube_index(dual, sensor)
                file_bands = [int(sensor.bands[list(index).index(b)]) for b in bands[mask]]
                detector = "vnir" if sensor is dual.vnir else "swir"

                def sub(mask=mask):
                    v, ok = sampled()
                    return v[mask], ok

                dark_per_band[mask] = sensor_dark_levels(
                    sensor, detector, file_bands, dark, sub, progress
                )
        else:
            v, ok = sample()
            means, n = dark_object(v, ok)
            progress.info(describe_level("image", float(means.min()), ESTIMATED, means, n))
            dark_per_band[:] = float(means.min())
    except BaseException:
        cube.close()
        raise
    return cube, bands, wl, read, info, dark_per_band


def _rx_statistics(read, n_bands: int, strips: dict, progress):
    """RX's first pass: the scene mean and covariance of ``n_bands`` bands over the strips,
    read in the files' own type (no float copy). The shift comes from the first strip and the
    strips' products are added in strip order, so the sums do not depend on thread timing:
    the same scores in every run."""
    from ..anomaly import rx

    first, first_valid = read(0, min(strips["block_rows"], strips["height"]))
    acc = rx.CovarianceAccumulator(
        n_bands, shift=rx.CovarianceAccumulator.strip_shift(first, first_valid)
    )
    del first, first_valid
    for _, product in io.map_windows(
        read, acc.strip_product, **strips, progress=progress, message="RX: background statistics"
    ):
        acc.add_product(product)  # in strip order: the same sums in every run
    return acc.stats()


def _rx_scores(det, read, read64, background, precision, strips: dict, progress):
    """RX's second pass: (window, score) of each strip, against the scene mean (global) or
    the mean of ``background``'s windows around each pixel (local, from float64 strips)."""
    from ..anomaly import rx

    if not background.local:
        return io.map_windows(
            read,
            lambda data, valid: det.score_cube(data, valid, precision),
            **strips,
            progress=progress,
            message="RX: scoring",
        )
    inner, outer = background.inner, background.outer

    def score(data, valid, block):
        return rx.local_rx(
            data,
            det,
            inner,
            outer,
            valid,
            first_row=block.row0,
            height=block.height,
            rows=block.rows,
            precision=precision,
        )

    return io.map_windows(
        read64,
        score,
        **strips,
        # Windows are shifted to stay inside the image (as Spectral Python's), so a pixel
        # near the first or last line reaches up to outer - 1 lines away.
        halo=(outer - 1, outer - 1),
        pass_block=True,
        progress=progress,
        message="RX: scoring",
    )


def rx_file(
    vnir,
    swir=None,
    *,
    output,
    layout=DualLayout(),
    spectral=BandSelection(),
    background=RXBackground(),
    regularize=0.0,
    precision="float64",
    coregistration=Coregistration(),
    dark=DarkLevels(),
    detectability=Detectability(),
    block_rows=CUBE_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the RX anomaly score (squared Mahalanobis distance to the background) of an image.

    Pass 1 accumulates the scene mean and covariance over strips (float64, worker threads);
    pass 2 scores each strip: against the scene mean (global) or the mean of an ``outer``
    window minus an ``inner`` guard window around each pixel (local; strips read with
    ``outer - 1`` lines of halo, since windows are shifted to stay inside the image).

    Parameters
    ----------
    vnir : path or DualSensor
        Hyperspectral image (ENVI or GeoTIFF): a merged cube, the VNIR file, a sensor
        product, or a dataset opened with :func:`geoboresight.open_dual`.
    swir : path, optional
        SWIR file on the same pixel grid, stacked after the VNIR bands.
    output : path
        float32 score GeoTIFF on the image's grid, nodata -9999.
    layout : DualLayout
        How to read VNIR and SWIR files that do not say it all (band centres).
    spectral : BandSelection
        Wavelength ranges to use / leave out, e.g. ``include_nm="400-900,1000-1300"``
        (default: leave out the water-vapour absorption bands).
    background : RXBackground
        Scene mean (``mode="global"``), or a windowed mean (``"local"``, ``inner`` and
        ``outer`` window sizes); the covariance stays the scene's.
    regularize : float
        Ridge added to the covariance diagonal, as a fraction of the mean band variance.
    precision : {"float64", "float32"}
        Arithmetic of the scoring pass.
    coregistration : Coregistration
        ``coregister``: shift the SWIR bands onto the VNIR grid by the boresight offset first
        (default): a sub-pixel target's VNIR and SWIR signals then fall in one pixel. Needs a
        dual dataset (VNIR and SWIR files, or a sensor product); one plain cube is used as it
        is. The offset to remove (``offset_along``, ``offset_across`` px); empty: measured as
        ``boresight-offset`` measures it.
    dark : DarkLevels
        Dark levels for the detectability (given, else the product's, the header's, or the
        dark object of a random sample), as ``shadow-map`` finds them.
    detectability : Detectability
        The target (fill fraction, contrast) whose expected d′ is reported
        (:func:`geoboresight.anomaly.physical.spectral_dprime`); a warning below 3.
    block_rows : int
        Lines per strip.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the number of ``bands`` used and of ``background_pixels``, whether the
        SWIR was ``coregistered`` and by which offset (``offset_along_px``,
        ``offset_across_px``), the expected ``dprime`` and ``dprime_low`` (below 3).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 11B).
    Reed, I.S.; Yu, X. Adaptive multiple-band CFAR detection of an optical pattern with unknown
    spectral distribution. IEEE Trans. Acoust. Speech Signal Process. 1990, 38, 1760–1770.

    Examples
    --------
    RX scores of the sample scene, the SWIR co-registered onto the VNIR first:

    >>> import geoboresight as gb
    >>> result = gb.rx_file(
    ...     "sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr", output="out/rx.tif"
    ... )
    >>> result["bands"], result["coregistered"], result["offset_along_px"]
    (176, True, 0.87)
    """
    from ..anomaly import physical, rx

    cube, bands, wl, read, coreg, dark_dn, progress = _detector_input(
        vnir, swir, layout, spectral, dark, coregistration, detectability, progress
    )
    read64 = read if coreg["coregistered"] else cube.reader(bands, "float64")
    inner, outer = background.inner, background.outer
    with cube:
        local = background.local
        if local:
            rx.check_windows(inner, outer, cube.height, cube.width)
        strips = {
            "height": cube.height,
            "width": cube.width,
            "block_rows": block_rows,
            "workers": io.windows.default_workers(),
        }
        stats = _rx_statistics(read, len(bands), strips, progress.sub(0.0, 0.5))
        det = rx.RXDetector(stats, regularize, wavelengths=wl, band_numbers=bands + 1)
        progress.info(f"RX on {len(bands)} bands, {stats.n} background pixels")
        dp = _detectability_result(
            "RX",
            physical.spectral_dprime(stats.mean, stats.cov, dark_dn, detectability),
            detectability,
            progress,
            physical.spectral_dprime(stats.mean, stats.cov, dark_dn, detectability, shape="grey"),
        )
        tags = {
            "product": "RX anomaly score (squared Mahalanobis distance; paper §3.3)",
            **band_tags(wl, bands),
            **_coreg_tags(coreg),
            "dprime": f"{dp['dprime']:.4g}",
        }
        if local:
            tags["window"] = f"inner {inner} px, outer {outer} px"
        scored = _rx_scores(
            det, read, read64, background, precision, strips, progress.sub(0.5, 1.0)
        )
        with io.create_raster(output, cube.grid, tags=tags, band_names=["RX score"]) as dst:
            for win, s in scored:
                dst.write(to_float32(s), 1, window=win)
    return {
        "output": output,
        "bands": len(bands),
        "background_pixels": stats.n,
        **coreg,
        **dp,
    }


def _coreg_tags(coreg: dict) -> dict:
    if not coreg["coregistered"]:
        return {"coregistered": "no"}
    return {
        "coregistered": "yes: SWIR shifted onto the VNIR grid by the boresight offset",
        "offset_along_px": f"{coreg['offset_along_px']:.4f}",
        "offset_across_px": f"{coreg['offset_across_px']:.4f}",
    }


def svdd_file(
    vnir,
    swir=None,
    *,
    output,
    layout=DualLayout(),
    spectral=BandSelection(),
    sigma=0.0,
    nu=NU,
    sample_size=SAMPLE_SIZE,
    seed=0,
    coregistration=Coregistration(),
    dark=DarkLevels(),
    detectability=Detectability(),
    block_rows=CUBE_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the SVDD anomaly score ``‖Φ(y) − a‖² − R²`` (Gaussian RBF kernel) of an image.

    The description is trained on pixels drawn uniformly at random over the whole flight line
    (``1.5 × sample_size + 10`` positions, nodata ones dropped, then at most ``sample_size``
    kept), then every strip is scored in worker threads.

    Parameters
    ----------
    vnir : path or DualSensor
        Hyperspectral image (ENVI or GeoTIFF): a merged cube, the VNIR file, a sensor
        product, or a dataset opened with :func:`geoboresight.open_dual`.
    swir : path, optional
        SWIR file on the same pixel grid, stacked after the VNIR bands.
    output : path
        float32 score GeoTIFF on the image's grid (positive outside the description), nodata
        -9999.
    layout : DualLayout
        How to read VNIR and SWIR files that do not say it all (band centres).
    spectral : BandSelection
        Wavelength ranges to use / leave out.
    sigma : float
        Kernel width in image units; 0: the median pairwise distance of the sample.
    nu : float
        Fraction of training pixels allowed outside the description (0–1].
    sample_size : int
        Background pixels drawn for training.
    seed : int
        Random seed of the sample (same seed, same result).
    coregistration : Coregistration
        ``coregister``: shift the SWIR bands onto the VNIR grid by the boresight offset first
        (default): a sub-pixel target's VNIR and SWIR signals then fall in one pixel. Needs a
        dual dataset (VNIR and SWIR files, or a sensor product); one plain cube is used as it
        is. The offset to remove (``offset_along``, ``offset_across`` px); empty: measured as
        ``boresight-offset`` measures it.
    dark : DarkLevels
        Dark levels for the detectability (given, else the product's, the header's, or the
        dark object of a random sample), as ``shadow-map`` finds them.
    detectability : Detectability
        The target (fill fraction, contrast) whose expected d′ is reported
        (:func:`geoboresight.anomaly.physical.spectral_dprime` of the training sample); a warning below 3.
    block_rows : int
        Lines per strip.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the kernel width ``sigma``, the number of ``support_vectors``, whether
        the SWIR was ``coregistered`` and by which offset, the expected ``dprime`` and
        ``dprime_low``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Eq. 7–9, Figure 11C).
    Tax, D.M.J.; Duin, R.P.W. Support vector data description. Mach. Learn. 2004, 54, 45–66.

    Examples
    --------
    >>> import geoboresight as gb
    >>> result = gb.svdd_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                       output="out/svdd.tif")
    >>> result["support_vectors"], result["coregistered"]
    (23, True)
    """
    from ..anomaly import physical, svdd

    cube, bands, wl, read, coreg, dark_dn, progress = _detector_input(
        vnir, swir, layout, spectral, dark, coregistration, detectability, progress
    )
    with cube:
        strips = {"height": cube.height, "width": cube.width, "block_rows": block_rows}
        rng = np.random.default_rng(seed)
        positions = svdd.sample_positions(cube.height * cube.width, sample_size, rng)

        # Only the lines holding drawn pixels are read (a thousand lines, not the line).
        values, ok = io.read_pixels(
            read,
            positions,
            **strips,
            progress=progress.sub(0.0, 0.2),
            message="SVDD: background sample",
        )
        picked = values[:, ok].T.astype(np.float64)
        sample = svdd.keep_at_most(picked, sample_size, rng)
        model = svdd.fit_svdd(sample, sigma=sigma or None, nu=nu)
        progress.info(
            f"SVDD: {len(sample)} training pixels, σ = {model.sigma:.4g}"
            f"{'' if sigma else ' (median pairwise distance)'}, ν = {model.nu}, "
            f"{len(model.alpha)} support vectors"
        )
        tags = {
            "product": "SVDD anomaly score ||Φ(y)−a||² − R² (RBF kernel; paper Eq. 7–9)",
            "sigma": f"{model.sigma:.6g}",
            "nu": model.nu,
            "support_vectors": len(model.alpha),
            **band_tags(wl, bands),
            **_coreg_tags(coreg),
        }
        cov = np.cov(sample.T) if len(sample) > 2 else np.eye(len(bands))
        dp = _detectability_result(
            "SVDD",
            physical.spectral_dprime(sample.mean(axis=0), cov, dark_dn, detectability),
            detectability,
            progress,
            physical.spectral_dprime(
                sample.mean(axis=0), cov, dark_dn, detectability, shape="grey"
            ),
        )
        tags["dprime"] = f"{dp['dprime']:.4g}"
        with io.create_raster(output, cube.grid, tags=tags, band_names=["SVDD score"]) as dst:
            # Strips in the files' own type, scored in worker threads (thread-safe model).
            for win, s in io.map_windows(
                read,
                model.score_cube,
                **strips,
                workers=io.windows.default_workers(),
                progress=progress.sub(0.2, 1.0),
                message="SVDD: scoring",
            ):
                dst.write(to_float32(s), 1, window=win)
    return {
        "output": output,
        "sigma": model.sigma,
        "support_vectors": len(model.alpha),
        **coreg,
        **dp,
    }


#: The indicator's methods: the paper's Eq. 3 z-score of the ratio raster, or the physical
#: dipole indicator on the cube; "auto" is "physical" when the cube is given, else "eq3".
INDICATOR_METHODS = ("auto", "eq3", "physical")


def boresight_indicator_file(
    ratio=None,
    vnir=None,
    swir=None,
    *,
    output,
    anomalies=None,
    method="auto",
    threshold=THRESHOLD,
    reference=Eq3Reference(),
    dipole=Dipole(),
    layout=DualLayout(),
    dark=DarkLevels(),
    detectability=Detectability(),
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the boresight anomaly indicator: the paper's Eq. 3 z-score of the boresight ratio,
    or its physical variant, the dipole of the dark-corrected log ratio along the offset.

    ``method="eq3"`` (a reproduction of the paper, §3.3): ``z = (r − median) / (1.4826 · MAD)``
    of the ratio raster over the scene (the exact median and MAD, in a few passes over the
    strips: memory does not grow with the line); with ``window`` > 1, ``r`` is first replaced
    by its difference to the median of its ``window`` × ``window`` neighbourhood (strips read
    with ``window // 2`` lines of halo; the residuals are spilled once to a temporary file
    beside ``output`` for their median and MAD).

    ``method="physical"`` (docs/anomaly.md, :mod:`geoboresight.anomaly.physical`): from the
    cube, y = ln(S̄ − d_s) − ln(V̄ − d_v) of the band means 1,000–1,100 nm and 900–975 nm
    minus their dark levels (found as ``shadow-map`` finds them), D = y − y(· + δ) along the
    boresight offset δ (measured as ``boresight-offset`` measures it, or given), scored
    against the median and spread of D in a ``dipole_window`` neighbourhood; one-sided when
    ``target_sign`` is known. Strips read with the lines δ and the window reach.

    ``"auto"`` (default): "physical" when ``vnir`` is given, else "eq3". Pixels whose score
    exceeds ``threshold`` are anomalies.

    Parameters
    ----------
    ratio : path, optional
        Boresight ratio raster (the ``ratio_file`` output); needed by "eq3".
    vnir : path or DualSensor, optional
        VNIR file, a merged cube or a sensor product; needed by "physical".
    swir : path, optional
        SWIR file on the same pixel grid.
    output : path
        float32 score GeoTIFF, nodata -9999.
    anomalies : path, optional
        uint8 GeoTIFF, 1 = anomaly, 0 = background, 255 = nodata.
    method : {"auto", "eq3", "physical"}
    threshold : float
        Threshold on the score (σ units; the paper's 3σ rule).
    reference : Eq3Reference
        "eq3": which side of the ratio's distribution stands out (``tail``), and the odd
        ``window`` of the local median reference (0 or 1: the whole scene).
    dipole : Dipole
        "physical": the targets' sign at 900–1,100 nm against their ground when known
        (``target_sign``), the odd ``dipole_window`` of D's local median and spread, and the
        offset δ (``offset_along``, ``offset_across`` px; empty: measured).
    layout : DualLayout
        How to read VNIR and SWIR files that do not say it all.
    dark : DarkLevels
        "physical": dark levels (given, else the product's, the header's, or estimated).
    detectability : Detectability
        The target whose expected d′ is reported (a warning below 3).
    block_rows : int
        Lines per strip.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, ``anomalies``, the anomaly ``count``, the ``method`` used, the reference
        ``median`` and ``robust_sigma`` (eq3: of the ratio or its residual; physical: D's
        median 0 and median local spread), and, with the cube, the expected ``dprime`` and
        ``dprime_low`` (physical: also the offset used).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 11D).

    Examples
    --------
    >>> import geoboresight as gb
    >>> _ = gb.ratio_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                   output="out/ratio.tif")
    >>> result = gb.boresight_indicator_file("out/ratio.tif", output="out/indicator.tif")
    >>> result["method"], round(result["median"], 3)
    ('eq3', 2.163)
    """
    method = _indicator_method(method, vnir, swir, ratio, dipole, dark)
    if method == "physical":
        return _physical_indicator_file(
            vnir,
            swir,
            output=output,
            anomalies=anomalies,
            threshold=threshold,
            sign=dipole.target_sign,
            window=dipole.dipole_window,
            layout=layout,
            dark=dark,
            offset=BoresightOffset(dipole.offset_along, dipole.offset_across),
            target=detectability,
            block_rows=block_rows,
            progress=progress,
        )
    progress.info(
        "method eq3: the paper's robust z-score of the raw-DN ratio (a reproduction; "
        "docs/anomaly.md explains why it scores grey sub-pixel targets below chance)"
    )
    return {
        **_eq3_indicator_file(
            ratio,
            output,
            anomalies,
            threshold,
            reference.tail,
            reference.window,
            block_rows,
            progress,
        ),
        "method": "eq3",
    }


def _indicator_method(method: str, vnir, swir, ratio, dipole, dark) -> str:
    """The indicator's method ("auto": physical with the cube, else eq3), its inputs checked:
    each method refuses what only the other one uses."""
    from ..errors import ParameterError

    if method not in INDICATOR_METHODS:
        raise ParameterError(
            f"parameter 'method' must be one of {', '.join(INDICATOR_METHODS)}, got {method!r}"
        )
    if method == "auto":
        method = "physical" if vnir else "eq3"
    if method == "physical":
        if not vnir:
            raise ParameterError(
                "method 'physical' needs the cube: give 'vnir' (and 'swir'), or use method 'eq3' "
                "with the ratio raster"
            )
        if ratio:
            # The physical statistic is computed from the cube alone: a ratio raster given
            # with it would be believed used.
            raise ParameterError(
                "parameter 'ratio' is not used by method 'physical' (the default when the cube "
                "is given): leave 'ratio' empty, or choose method 'eq3' for the paper's Eq. 3 "
                "on the ratio raster"
            )
        return method
    unused = [
        n
        for n, v in (
            ("vnir", vnir),
            ("swir", swir),
            ("offset_along", dipole.offset_along),
            ("offset_across", dipole.offset_across),
            ("vnir_dark", dark.vnir_dark),
            ("swir_dark", dark.swir_dark),
        )
        if v is not None and v != ""
    ]
    if unused:
        # Ignored by eq3: a user who set them would believe they were used.
        raise ParameterError(
            f"parameter{'s' if len(unused) > 1 else ''} {', '.join(repr(n) for n in unused)} "
            f"only used by method 'physical': leave {'them' if len(unused) > 1 else 'it'} empty "
            "for method 'eq3' (the ratio raster), or use method 'physical'"
        )
    if not ratio:
        raise ParameterError(
            "method 'eq3' needs the boresight ratio raster: give 'ratio' (the 'ratio' operation's "
            "output)"
        )
    return "eq3"


def _physical_indicator_file(
    vnir,
    swir,
    *,
    output,
    anomalies,
    threshold,
    sign,
    window,
    layout,
    dark,
    offset,
    target,
    block_rows,
    progress,
) -> dict:
    from ..anomaly import physical
    from ..io.bands import MatchBands, open_matching_pair

    physical.check_sign(sign)
    physical.check_window(window)
    physical.check_target(target)
    dual = io.as_dual(vnir, swir, layout)
    along, across, how = boresight_offset(dual, offset, progress.sub(0.0, 0.3))
    progress.info(
        f"boresight offset δ: {along:+.3f} px along-track, {across:+.3f} px across ({how})"
    )
    means = MatchBands(
        physical.VNIR_NM[0], physical.SWIR_NM[0], physical.VNIR_NM[1], physical.SWIR_NM[1]
    )
    with open_matching_pair(dual, means) as pair:

        def read(row0, row1):
            v, s, ok = pair.read(row0, row1)
            return np.stack([v, s]), ok

        sample = _sample_reader(read, dual.height, dual.width)
        cache = {}

        def part(i):
            def get():
                if "s" not in cache:
                    cache["s"] = sample()
                values, ok = cache["s"]
                return values[i : i + 1], ok

            return get

        dv = sensor_dark_levels(dual.vnir, "vnir", pair.vnir_bands, dark, part(0), progress)
        ds = sensor_dark_levels(dual.swir, "swir", pair.swir_bands, dark, part(1), progress)
        vd, sd = float(np.mean(dv)), float(np.mean(ds))

        def kernel(data, ok):
            y, yok = physical.log_ratio(data[0], data[1], ok, vnir_dark=vd, swir_dark=sd)
            d, dok = physical.dipole(y, yok, along=along, across=across)
            z, sig = physical.local_z(d, dok, window=window)
            score = physical.score_of(z, sign)
            with np.errstate(invalid="ignore"):
                return score, score > threshold, dok, sig

        tags = {
            "product": (
                "boresight indicator (physical): local z of the dipole of the dark-corrected "
                "log ratio along the boresight offset (docs/anomaly.md)"
            ),
            "method": "physical",
            "bands_vnir_nm": f"{physical.VNIR_NM[0]:g}-{physical.VNIR_NM[1]:g}",
            "bands_swir_nm": f"{physical.SWIR_NM[0]:g}-{physical.SWIR_NM[1]:g}",
            "dark_vnir_dn": f"{vd:.6g}",
            "dark_swir_dn": f"{sd:.6g}",
            "offset_along_px": f"{along:.4f}",
            "offset_across_px": f"{across:.4f}",
            "target_sign": sign,
            "window": window,
            "threshold": threshold,
        }
        h = physical.halo(along, across, window)
        count, spreads = 0, []
        with (
            io.create_raster(
                output, dual.grid, tags=tags, band_names=["boresight dipole z"]
            ) as dst,
            _optional_mask(anomalies, dual.grid, tags) as mask,
        ):
            for win, (s, flags, ok, sig) in io.map_windows(
                read,
                kernel,
                height=dual.height,
                width=dual.width,
                block_rows=block_rows,
                halo=(h, h),
                progress=progress.sub(0.3, 1.0),
                message="indicator: dipole along the offset",
            ):
                dst.write(to_float32(s), 1, window=win)
                if mask is not None:
                    mask.write(np.where(ok, flags, 255).astype("uint8"), 1, window=win)
                count += int(np.sum(flags & ok))
                if ok.any():
                    spreads.append((float(np.median(sig[ok])), int(ok.sum())))
            if not spreads:
                raise InputError(
                    "no pixel of the line is above both dark levels with its offset partner "
                    "inside the image: check the dark levels ('vnir_dark', 'swir_dark'), or "
                    "leave them empty to estimate them",
                    params=("vnir_dark", "swir_dark"),
                )
            # The median local spread: strips' medians weighted by their pixels.
            vals = np.array([v for v, _ in spreads])
            wts = np.array([n for _, n in spreads], float)
            order = np.argsort(vals)
            cum = np.cumsum(wts[order])
            sigma = float(vals[order][np.searchsorted(cum, cum[-1] / 2)])
            dprime = physical.dipole_dprime(target, along, across, sigma)
            dst.update_tags(DPRIME=f"{dprime:.4g}", MEDIAN_LOCAL_SIGMA=f"{sigma:.6g}")
    progress.info(f"{count} pixel(s) beyond {threshold:g} σ")
    dp = _detectability_result("boresight indicator (physical)", dprime, target, progress)
    return {
        "output": output,
        "anomalies": anomalies,
        "count": count,
        "method": "physical",
        "median": 0.0,
        "robust_sigma": sigma,
        "offset_along_px": round(along, 4),
        "offset_across_px": round(across, 4),
        **dp,
    }


def _eq3_indicator_file(ratio, output, anomalies, threshold, tail, window, block_rows, progress):
    check_options(threshold, tail, window)
    local = bool(window and window > 1)
    passes = 3 if local else 2
    with io.open_raster(ratio, "ratio raster") as src:
        grid = io.Grid.of(src)
        read = io.band_reader(src, 1)
        strips = {"height": grid.height, "width": grid.width, "block_rows": block_rows}
        # The scene's median and MAD are exact order statistics found in a few passes over
        # the strips (memory flat in the line's length), as `stats` finds its percentiles.
        stats_share = progress.sub(0.0, 1 - 1 / passes)
        raw = io.windows.value_passes(
            read,
            valid_values,
            **strips,
            progress=stats_share.sub(0.0, 0.5 if local else 1.0),
            message="indicator: scene statistics",
            passes=5,  # count and extremes, then the median and the MAD, two passes each
        )
        median, sigma = robust_location_blocks(raw)
        fill = None
        halo = (0, 0)
        if local:
            # The scene's median fills nodata in every strip's median filter, as in one
            # whole-image filter; the residuals' own median and MAD are the reference. The
            # residuals (a median filter per strip) are computed once and spilled to disk.
            fill = median
            halo = (window // 2, window // 2)
            with io.Spill(near=output) as spill:
                for _, res in io.map_windows(
                    read,
                    lambda r, ok: local_residual(r, ok, window=window, fill=fill),
                    **strips,
                    halo=halo,
                    progress=stats_share.sub(0.5, 0.75),
                    message="indicator: local residuals",
                ):
                    spill.append(valid_values(res))
                median, sigma = robust_location_blocks(spill.blocks)
        progress.info(f"boresight ratio median {median:.5g}, robust σ {sigma:.4g}")

        def score(r, ok):
            x = local_residual(r, ok, window=window, fill=fill) if local else r
            s = indicator_score(x, ok, median=median, sigma=sigma, tail=tail)
            with np.errstate(invalid="ignore"):
                return s, s > threshold, ok

        tags = {
            "product": "boresight indicator: robust z-score of the boresight ratio (paper §3.3)",
            "median": f"{median:.8g}",
            "robust_sigma": f"{sigma:.8g}",
            "tail": tail,
            "threshold": threshold,
        }
        count = 0
        with (
            io.create_raster(output, grid, tags=tags, band_names=["boresight z-score"]) as dst,
            _optional_mask(anomalies, grid, tags) as mask,
        ):
            for win, (s, flags, ok) in io.map_windows(
                read,
                score,
                **strips,
                halo=halo,
                progress=progress.sub(1 - 1 / passes, 1.0),
                message="indicator: scoring",
            ):
                dst.write(to_float32(s), 1, window=win)
                if mask is not None:
                    mask.write(np.where(ok, flags, 255).astype("uint8"), 1, window=win)
                count += int(flags.sum())
    progress.info(f"{count} pixel(s) beyond {threshold:g} σ")
    return {
        "output": output,
        "anomalies": anomalies,
        "count": count,
        "median": median,
        "robust_sigma": sigma,
    }


def _optional_mask(path, grid, tags):
    """The anomaly mask raster being written, or a context giving None without a path."""
    if not path:
        return contextlib.nullcontext(None)
    return io.create_raster(
        path,
        grid,
        dtype="uint8",
        nodata=255,
        tags=tags,
        band_names=["anomaly (1) / background (0)"],
    )


def anomaly_polygons_file(
    score,
    *,
    output,
    threshold=None,
    geometry="polygon",
    min_pixels=1,
    progress=None,
) -> dict:
    """Write the groups of pixels of a score map at or above a threshold as a vector layer.

    Pixels are grouped 8-connected; each group becomes its pixel outline (polygon) or the
    centre of its highest-scoring pixel (point), with ``n_pixels``, ``score_max``,
    ``score_mean`` and the peak's ``row`` and ``col``. Coordinates follow the raster's CRS and
    geotransform; raw sensor geometry gives pixel coordinates and an undefined CRS.

    Parameters
    ----------
    score : path
        Anomaly score raster (RX, SVDD, boresight indicator), higher = more anomalous.
    output : path
        GeoPackage (or GeoJSON) layer ``anomalies``.
    threshold : float
        Score at or above which a pixel is an anomaly (required).
    geometry : {"polygon", "point"}
        Pixel outlines, or peak pixel centres.
    min_pixels : int
        Groups with fewer pixels are dropped.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` and the number of ``features``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 11 as vectors).

    Examples
    --------
    The pixels of the sample scene's RX score above 5, as polygons:

    >>> import geoboresight as gb
    >>> _ = gb.rx_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                output="out/rx.tif")
    >>> gb.anomaly_polygons_file("out/rx.tif", threshold=5, output="out/anomalies.gpkg")
    {'output': 'out/anomalies.gpkg', 'features': 1}
    """
    from ..anomaly.polygons import check_geometry, label_anomalies
    from ..io.anomaly import label_polygons, pixel_points
    from ..io.vector import write_vector

    if threshold is None:
        from ..errors import ParameterError

        raise ParameterError("parameter 'threshold' is required (the anomaly score threshold)")
    check_geometry(geometry)
    with io.open_raster(score, "score raster") as src:
        s, valid = io.read_masked(src, 1)
        grid = io.Grid.of(src)
    labels, table = label_anomalies(s, valid, threshold=threshold, min_pixels=min_pixels)
    if geometry == "point":
        geoms = pixel_points(table["row"], table["col"], grid.transform)
    else:
        outlines = label_polygons(labels, grid.transform)
        geoms = [outlines[int(i)] for i in table["id"]]
    write_vector(
        output,
        geoms,
        {k: table[k] for k in FIELDS},
        crs=grid.crs,
        layer="anomalies",
        description="anomalies (score ≥ threshold)",
    )
    progress.info(f"{len(geoms)} anomaly feature(s) at score ≥ {threshold:g}")
    return {"output": output, "features": len(geoms)}


def unmix_file(
    vnir,
    endmembers,
    swir=None,
    *,
    output,
    layout=DualLayout(),
    spectral=BandSelection(),
    names="",
    method="fcls",
    image_scale=1.0,
    block_rows=CUBE_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the abundance of each endmember per pixel and the residual (linear unmixing).

    The endmember spectra are resampled to the image's band centres with Gaussian responses
    of the image's FWHM, then every strip is unmixed in worker threads.

    Parameters
    ----------
    vnir : path or DualSensor
        Hyperspectral image with wavelength metadata: a merged cube, the VNIR file, a sensor
        product, or a dataset opened with :func:`geoboresight.open_dual`.
    endmembers : path
        Endmember spectra: CSV (wavelength in nm first, one column per material) or an ENVI
        spectral library (.sli + .hdr).
    swir : path, optional
        SWIR file on the same pixel grid, stacked after the VNIR bands.
    output : path
        float32 GeoTIFF: one abundance band per endmember, then the residual RMS over bands;
        nodata -9999.
    layout : DualLayout
        How to read VNIR and SWIR files that do not say it all (band centres).
    spectral : BandSelection
        Wavelength ranges to use / leave out.
    names : str
        Endmembers to use, comma-separated (empty: all in the library).
    method : {"fcls", "nnls", "ucls"}
        Fully constrained (≥ 0, sum to 1; Eq. 11), non-negative, or unconstrained.
    image_scale : float
        Factor turning image values into the library's units (e.g. 0.0001).
    block_rows : int
        Lines per strip.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` and the ``endmembers`` used.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Eq. 10–11).
    Heinz, D.C.; Chang, C.-I. Fully constrained least squares linear spectral mixture analysis
    method for material quantification in hyperspectral imagery. IEEE Trans. Geosci. Remote
    Sens. 2001, 39, 529–545.
    """
    from ..anomaly import unmix
    from ..errors import InputError
    from ..io.spectra import read_spectral_library

    wl_lib, spectra, lib_names = read_spectral_library(endmembers)
    try:
        spectra, chosen = unmix.select_endmembers(
            spectra, lib_names, [n.strip() for n in (names or "").split(",")]
        )
    except InputError as exc:
        raise InputError(f"{endmembers}: {exc}") from None
    cube, bands, wl, fwhm = open_image(vnir, swir, layout, spectral)
    with cube:
        if wl is None:
            raise InputError(
                f"{vnir} has no wavelength metadata: endmembers cannot be resampled to its bands"
            )
        E = unmix.resample(wl_lib, spectra, wl, fwhm, chosen)
        unmix.check_endmembers(E, chosen)
        tags = {
            "product": f"linear unmixing ({method}; paper Eq. 10–11)",
            "endmembers": ",".join(chosen),
            "image_scale": image_scale,
            **band_tags(wl, bands),
        }
        band_names = [f"abundance {n}" for n in chosen] + ["residual RMS (phi)"]
        with io.create_raster(
            output, cube.grid, count=len(chosen) + 1, tags=tags, band_names=band_names
        ) as dst:
            for win, stack in io.map_windows(
                cube.reader(bands, "float64"),
                lambda data, valid: unmix.unmix_cube(
                    data, valid, endmembers=E, method=method, scale=image_scale
                ),
                height=cube.height,
                width=cube.width,
                block_rows=block_rows,
                workers=io.windows.default_workers(),
                progress=progress,
                message="unmixing",
            ):
                dst.write(to_float32(stack), window=win)
    return {"output": output, "endmembers": chosen}


def roc_file(
    scores,
    truth,
    *,
    output,
    csv=None,
    names="",
    truth_threshold=None,
    guard_px=0,
    pfa=PFA,
    title=TITLE,
    progress=None,
) -> dict:
    """Draw the ROC curves (Pd against Pfa) of several score maps against a truth raster.

    Parameters
    ----------
    scores : list of paths, or str
        Score rasters, higher = more anomalous (a list, or paths separated by commas).
    truth : path
        0/1 target mask, or an abundance raster, on the scores' grid.
    output : path
        PNG figure (linear and logarithmic Pfa).
    csv : path, optional
        The curves as CSV (detector, pfa, pd, threshold).
    names : str
        Detector names for the legend, comma-separated (default: the file names).
    truth_threshold : float, optional
        Truth value at or above which a pixel is a target (default: > 0).
    guard_px : int
        Pixels within this distance of a target are left out of the background.
    pfa : float
        False-alarm rate at which Pd is reported.
    title : str
        Figure title.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, ``csv``, and per detector ``auc_<name>`` and ``pd_at_pfa_<name>``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 12).

    Examples
    --------
    RX against the sample scene's true sub-pixel targets:

    >>> import geoboresight as gb
    >>> _ = gb.rx_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                output="out/rx.tif")
    >>> result = gb.roc_file(["out/rx.tif"], "sample_data/scene/truth_target_abundance.tif",
    ...                      output="out/roc.png")
    >>> round(result["auc_rx"], 2)
    0.61
    """
    from ..anomaly import roc
    from ..errors import InputError, ParameterError
    from ..io.anomaly import write_roc_csv
    from ..io.write import save_figure

    paths = io.split_paths(scores)
    labels = [n.strip() for n in (names or "").split(",") if n.strip()]
    if labels and len(labels) != len(paths):
        raise ParameterError(
            f"parameter 'names': {len(labels)} name(s) for {len(paths)} score raster(s)"
        )
    labels = labels or [os.path.splitext(os.path.basename(p))[0] for p in paths]
    with io.open_raster(truth, "truth raster") as src:
        t, t_valid = io.read_masked(src, 1)
        grid = io.Grid.of(src)
    targets, background = roc.truth_mask(t, t_valid, threshold=truth_threshold, guard_px=guard_px)
    curves = {}
    for i, (name, path) in enumerate(zip(labels, paths, strict=True)):
        with io.open_raster(path, "score raster") as src:
            s, s_valid = io.read_masked(src, 1)
            io.Grid.of(src).require_same(grid, f"score raster {path}", f"truth {truth}")
        try:
            curves[name] = roc.roc_curve(np.where(s_valid, s, np.nan), targets, background)
        except InputError as exc:
            raise InputError(f"{truth}: {exc}") from None
        progress.update((i + 1) / len(paths), f"ROC {name}")
    save_figure(roc.roc_figure(curves, title=title, pfa_marker=pfa), output)
    if csv:
        write_roc_csv(csv, curves)
    result = {"output": output, "csv": csv}
    for name, c in curves.items():
        result[f"auc_{name}"] = round(c.auc, 6)
        result[f"pd_at_pfa_{name}"] = round(c.pd_at(pfa), 6)
        progress.info(
            f"{name}: AUC {c.auc:.4f}, Pd {c.pd_at(pfa):.3f} at Pfa {pfa:g} ({c.n_targets} target px)"
        )
    return result
