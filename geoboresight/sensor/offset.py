"""The boresight offset between a VNIR and a SWIR band, from the images alone (paper §3.2).

The two optics of a dual pushbroom sensor look at slightly different ground: a feature at VNIR
line ``r``, column ``c`` appears in the SWIR image at ``(r + along, c + across)``. Over flat ground
that shift is the boresight offset; relief adds a parallax on top of it (see
:mod:`geoboresight.dem.height`). The global shift is found by Fourier cross-correlation with
upsampled-DFT sub-pixel refinement (Guizar-Sicairos et al., Opt. Lett. 33, 2008), as implemented
by :func:`skimage.registration.phase_cross_correlation` (without phase normalisation, which
amplifies noise on the smooth textures of 1–2 m imagery); no navigation data is needed. The same
estimate per block of lines shows drift along the flight line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError

#: Lines per block of the drift profile (the offset measured block by block).
PROFILE_ROWS = 256
#: Upsampling of the DFT refinement: the offset is resolved to 1/100 px.
UPSAMPLE = 100
#: A block of the drift profile with less valid pixels than this fraction gives no offset.
MIN_VALID_FRACTION = 0.5


@dataclass(frozen=True)
class Offset:
    """SWIR position minus VNIR position of the same ground feature, in pixels.

    ``along`` is along-track (image rows, lines), ``across`` across-track (columns).
    ``error`` is the translation-invariant normalised RMS error of the match (0 = perfect).
    """

    along: float
    across: float
    error: float = float("nan")


@dataclass(frozen=True)
class OffsetProfile:
    """The offset per block of lines along the flight line (to see drift)."""

    rows: np.ndarray  # centre line of each block
    along: np.ndarray
    across: np.ndarray
    error: np.ndarray
    valid_fraction: np.ndarray


def _prepare(image: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Remove the weighted mean, weight (soft mask) and taper the edges (Hann window).

    Cross-correlation in the Fourier domain assumes a periodic image; the window removes the
    wrap-around edges that would otherwise pull the peak to zero shift. The soft weight does the
    same for the edges of masked areas (clouds, nodata).
    """
    img = np.where(weight > 0, np.asarray(image, dtype=np.float64), 0.0)
    x = (img - np.sum(img * weight) / np.sum(weight)) * weight
    win = np.outer(np.hanning(img.shape[0] + 2)[1:-1], np.hanning(img.shape[1] + 2)[1:-1])
    return x * win


@dataclass(frozen=True)
class CrossPower:
    """The cross-power spectrum of a VNIR/SWIR pair of blocks (one or more, summed) and the
    spectral power of each image: what the offset of :func:`offset_of` is found from.

    Blocks of one size add up (``a + b``): the sum is the cross-correlation of the whole
    flight line, block by block, so the global offset is measured in memory bounded by a
    block.
    """

    product: np.ndarray  # F_vnir · conj(F_swir), complex (lines, columns) of a block
    power_vnir: float  # Σ |F_vnir|²
    power_swir: float  # Σ |F_swir|²
    blocks: int = 1

    def __add__(self, other: CrossPower) -> CrossPower:
        return CrossPower(
            self.product + other.product,
            self.power_vnir + other.power_vnir,
            self.power_swir + other.power_swir,
            self.blocks + other.blocks,
        )


def _checked(vnir, swir, valid, upsample):
    a = np.asarray(vnir)
    b = np.asarray(swir)
    if a.ndim != 2 or a.shape != b.shape:
        raise InputError(
            f"VNIR band {a.shape} and SWIR band {b.shape} must be 2-D and on the same pixel grid"
        )
    ok = np.isfinite(a) & np.isfinite(b)
    if valid is not None:
        ok &= valid
    if ok.sum() < 64 or min(a.shape) < 8:
        raise InputError(
            f"only {int(ok.sum())} valid pixels in a {a.shape[0]} × {a.shape[1]} block: too few "
            "to measure the boresight offset (use larger blocks or check the nodata/cloud mask)"
        )
    if upsample < 1:
        raise ParameterError(f"parameter 'upsample': must be >= 1, got {upsample}")
    return a, b, ok


def _spectra(a, b, w_v, w_s) -> CrossPower:
    from scipy.fft import fft2

    fa = fft2(_prepare(a, w_v))
    fb = fft2(_prepare(b, w_s))
    return CrossPower(
        fa * fb.conj(), float(np.sum(np.abs(fa) ** 2)), float(np.sum(np.abs(fb) ** 2))
    )


def _shift(power: CrossPower, upsample: int) -> tuple[np.ndarray, float]:
    """skimage's shift (registering SWIR onto VNIR) and normalised RMS error of a spectrum."""
    from skimage.registration import phase_cross_correlation

    p = power.product
    # The cross-power spectrum as the "reference" in Fourier space, against a flat "moving"
    # spectrum: skimage's product is then exactly ``p`` (upsampled-DFT refinement included).
    shift, err, _ = phase_cross_correlation(
        p, np.ones(p.shape), upsample_factor=int(upsample), space="fourier", normalization=None
    )
    # skimage normalised the peak by Σ|p|² · (number of samples) (each / size without
    # upsampling): recover |peak|² and normalise by the two images' powers instead.
    scale = p.size if int(upsample) > 1 else 1.0 / p.size
    peak2 = (1.0 - float(err) ** 2) * float(np.sum(np.abs(p) ** 2)) * scale
    amps = power.power_vnir * power.power_swir * (1.0 if int(upsample) > 1 else p.size**-2)
    return shift, math.sqrt(abs(1.0 - peak2 / amps)) if amps > 0 else float("nan")


def cross_power(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    upsample: int = UPSAMPLE,
) -> CrossPower:
    """The cross-power spectrum of one block, masked pixels handled as in
    :func:`estimate_offset` (which is :func:`offset_of` of it); sum blocks of one size to
    measure a flight line's offset block by block."""
    from scipy import ndimage

    a, b, ok = _checked(vnir, swir, valid, upsample)
    weight = ndimage.gaussian_filter(ok.astype(np.float64), 2.0) * ok
    power = _spectra(a, b, weight, weight)
    if not ok.all():
        # A mask at the same pixels of both images removes different ground from each, which
        # biases the shift towards 0. Second pass: keep in each image the ground both see,
        # i.e. move the SWIR weight by the first estimate.
        shift, _ = _shift(power, upsample)
        moved = ndimage.shift(ok.astype(np.float64), shift, order=1, cval=0.0)
        w_v = weight * moved
        w_s = ndimage.shift(w_v, -shift, order=1, cval=0.0) * ok
        if w_v.sum() > 0 and w_s.sum() > 0:
            power = _spectra(a, b, w_v, w_s)
    return power


def offset_of(power: CrossPower, *, upsample: int = UPSAMPLE) -> Offset:
    """The offset whose cross-correlation peak a (summed) cross-power spectrum holds: its
    whole-pixel maximum refined by the upsampled DFT (Guizar-Sicairos et al. 2008)."""
    shift, error = _shift(power, upsample)
    # skimage returns the shift that registers ``moving`` onto ``reference``: the opposite of
    # where the SWIR sees a VNIR feature.
    return Offset(along=float(-shift[0]), across=float(-shift[1]), error=float(error))


def estimate_offset(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    upsample: int = UPSAMPLE,
) -> Offset:
    """Global sub-pixel shift of ``swir`` relative to ``vnir`` by phase correlation.

    Parameters
    ----------
    vnir, swir : 2-D arrays (lines, columns)
        Two bands on the same pixel grid, e.g. 920 nm (VNIR) and 1010 nm (SWIR), the bands of
        the boresight ratio (Eq. 3) whose radiometry is closest across the sensor seam.
    valid : bool array, optional
        Pixels usable in both bands (no nodata, no cloud). Invalid pixels are filled with the
        mean so that they carry no texture.
    upsample : int
        Upsampling factor of the DFT refinement: the shift is resolved to ``1/upsample`` px.

    Returns
    -------
    Offset
        ``(along, across)``: a feature at VNIR ``(r, c)`` is at SWIR ``(r + along, c + across)``
        (pixels, resolved to ``1/upsample``); ``error`` is the normalised RMS error of the match
        (0 = perfect).

    Raises
    ------
    InputError
        When the bands are not 2-D on the same grid, or have fewer than 64 valid pixels (or a
        side under 8 pixels).
    ParameterError
        When ``upsample`` is below 1.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Figure 1: the
    boresight shift between the VNIR and SWIR images; §3.2, Figure 8).
    Guizar-Sicairos, M.; Thurman, S.T.; Fienup, J.R. Efficient subpixel image registration
    algorithms. Opt. Lett. 2008, 33, 156–158. https://doi.org/10.1364/OL.33.000156

    Examples
    --------
    A SWIR image that sees the VNIR's ground two lines later:

    >>> import numpy as np
    >>> import geoboresight as gb
    >>> vnir = np.random.default_rng(0).random((64, 64))
    >>> swir = np.roll(vnir, 2, axis=0)
    >>> offset = gb.estimate_offset(vnir, swir)
    >>> float(offset.along), abs(float(offset.across))
    (2.0, 0.0)
    """
    return offset_of(cross_power(vnir, swir, valid, upsample=upsample), upsample=upsample)


def block_offset(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    upsample: int = UPSAMPLE,
    min_valid_fraction: float = MIN_VALID_FRACTION,
) -> tuple[float, float, float, float]:
    """``(along, across, error, valid_fraction)`` of one block of lines of a drift profile.

    The offset is NaN when less than ``min_valid_fraction`` of the block is valid (clouds,
    nodata).
    """
    off, fraction, _ = block_power(
        vnir, swir, valid, upsample=upsample, min_valid_fraction=min_valid_fraction
    )
    return off.along, off.across, off.error, fraction


def block_power(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    upsample: int = UPSAMPLE,
    min_valid_fraction: float = MIN_VALID_FRACTION,
    measure: bool = True,
) -> tuple[Offset, float, CrossPower | None]:
    """One block of a flight line: its offset (NaN when less than ``min_valid_fraction`` is
    valid, or unless ``measure``: its upsampled-DFT refinement is most of the cost), its valid
    fraction, and its cross-power spectrum for the global offset (None when the block has
    under 64 valid pixels)."""
    a = np.asarray(vnir)
    ok = np.isfinite(a) & np.isfinite(swir)
    if valid is not None:
        ok = ok & valid
    fraction = float(ok.mean())
    nan = Offset(float("nan"), float("nan"), float("nan"))
    if ok.sum() < 64 or min(a.shape) < 8:
        return nan, fraction, None
    power = cross_power(a, swir, ok, upsample=upsample)
    if fraction < min_valid_fraction or not measure:
        return nan, fraction, power
    return offset_of(power, upsample=upsample), fraction, power


def merged_offset(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    block_rows: int = PROFILE_ROWS,
    upsample: int = UPSAMPLE,
) -> Offset:
    """The global offset of a flight line from its blocks of lines: the cross-power spectra of
    the blocks of :func:`offset_profile` (each with at least 64 valid pixels) summed, then
    :func:`offset_of` — the cross-correlation of the whole line, measured block by block.

    A line of at most ``block_rows`` lines is one block: :func:`estimate_offset` of it.
    """
    a = np.asarray(vnir)
    rows = profile_block_rows(block_rows, a.shape[0])
    total = None
    for start in profile_starts(a.shape[0], rows):
        block = slice(start, start + rows)
        _, _, power = block_power(
            a[block], swir[block], None if valid is None else valid[block], upsample=upsample
        )
        if power is not None:
            total = power if total is None else total + power
    if total is None:
        _checked(a, swir, valid, upsample)  # raises the reason
        raise InputError("no block of lines has 64 valid pixels: the offset cannot be measured")
    return offset_of(total, upsample=upsample)


def profile_block_rows(block_rows: int, height: int) -> int:
    """Lines per block of a drift profile of a ``height``-line image (at least 8, at most all)."""
    if block_rows < 8:
        raise ParameterError(f"parameter 'block_rows': at least 8 lines, got {block_rows}")
    return min(int(block_rows), height)


def profile_starts(height: int, block_rows: int, step_rows: int | None = None) -> list[int]:
    """First line of each block: every ``step_rows`` lines, the last block flush with the end
    of the line (so that the tail is covered by a whole block)."""
    step = int(step_rows or block_rows)
    if step < 1:
        raise ParameterError(f"parameter 'step_rows': must be >= 1, got {step_rows}")
    starts = list(range(0, max(height - block_rows, 0) + 1, step))
    if starts[-1] + block_rows < height:
        starts.append(height - block_rows)  # cover the tail of the line
    return starts


def offset_profile(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    block_rows: int = PROFILE_ROWS,
    step_rows: int | None = None,
    upsample: int = UPSAMPLE,
    min_valid_fraction: float = MIN_VALID_FRACTION,
) -> OffsetProfile:
    """The offset per block of ``block_rows`` lines, every ``step_rows`` lines (drift).

    Blocks with less than ``min_valid_fraction`` valid pixels (clouds, nodata) get NaN. This is
    the whole-array form; the file-level operation maps :func:`block_offset` over the same
    blocks of a flight line.

    Parameters
    ----------
    vnir, swir : 2-D arrays (lines, columns)
        Two bands on the same pixel grid, e.g. 920 nm (VNIR) and 1010 nm (SWIR).
    valid : bool array, optional
        Pixels usable in both bands (no nodata, no cloud).
    block_rows : int
        Lines per block (at least 8; at most the image's height).
    step_rows : int, optional
        Lines from one block's start to the next (default ``block_rows``: adjacent blocks); the
        last block ends with the image.
    upsample : int
        Upsampling factor of the DFT refinement (see :func:`estimate_offset`).
    min_valid_fraction : float
        Blocks with a smaller fraction of valid pixels give NaN.

    Returns
    -------
    OffsetProfile
        Per block: ``rows`` (centre line), ``along`` and ``across`` (the offset in pixels, as in
        :class:`Offset`), ``error`` (normalised RMS error of the match) and
        ``valid_fraction``; float arrays, the offsets NaN for blocks left out.

    Raises
    ------
    ParameterError
        When ``block_rows`` is below 8 or ``step_rows`` below 1.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Figure 1: the
    boresight shift "defined on an image-by-image basis"; §3.2).
    Guizar-Sicairos, M.; Thurman, S.T.; Fienup, J.R. Efficient subpixel image registration
    algorithms. Opt. Lett. 2008, 33, 156–158. https://doi.org/10.1364/OL.33.000156
    """
    a = np.asarray(vnir)
    height = a.shape[0]
    block_rows = profile_block_rows(block_rows, height)
    blocks = [
        (s + (block_rows - 1) / 2,)
        + block_offset(
            a[s : s + block_rows],
            swir[s : s + block_rows],
            None if valid is None else valid[s : s + block_rows],
            upsample=upsample,
            min_valid_fraction=min_valid_fraction,
        )
        for s in profile_starts(height, block_rows, step_rows)
    ]
    return profile_of(blocks)


def profile_of(blocks) -> OffsetProfile:
    """An :class:`OffsetProfile` from ``(centre line, along, across, error, valid fraction)``
    per block."""
    rows, al, ac, err, frac = zip(*blocks, strict=True)
    return OffsetProfile(*(np.asarray(v, dtype=float) for v in (rows, al, ac, err, frac)))


def profile_figure(profile: OffsetProfile):
    """A figure of the offset per block of lines along the flight line (drift)."""
    from ..figures import new_figure

    fig, ax = new_figure()
    ax.plot(profile.rows, profile.along, "o-", label="along-track")
    ax.plot(profile.rows, profile.across, "s-", label="across-track")
    ax.set_xlabel("Line (along the flight)")
    ax.set_ylabel("SWIR − VNIR offset (pixels)")
    ax.set_title("Boresight offset per block of lines")
    ax.legend()
    return fig


def offset_angles(
    along_px: float,
    across_px: float,
    ifov_mrad: float,
    flying_height: float | None = None,
) -> dict:
    """An offset in pixels as angles between the two lines of sight (and metres on the ground).

    One pixel subtends the IFOV at the sensor, so a shift of ``p`` pixels is the angle
    ``atan(p · tan(IFOV))`` ≈ ``p · IFOV``; on flat ground at flying height ``H`` it is
    ``p · GSD`` metres with ``GSD = H · IFOV`` at nadir.
    """
    if not (ifov_mrad > 0):
        raise ParameterError(f"parameter 'ifov_mrad': must be > 0, got {ifov_mrad}")
    ifov = ifov_mrad * 1e-3
    out = {}
    for name, p in (("along", along_px), ("across", across_px)):
        ang = math.atan(p * math.tan(ifov))
        out[f"{name}_mrad"] = ang * 1e3
        out[f"{name}_deg"] = math.degrees(ang)
    if flying_height is not None:
        if not (flying_height > 0):
            raise ParameterError(f"parameter 'flying_height': must be > 0 m, got {flying_height}")
        gsd = flying_height * ifov
        out["gsd_m"] = gsd
        out["along_m"] = along_px * gsd
        out["across_m"] = across_px * gsd
    return out
