"""The VNIR/SWIR offset of a flight line as an operation needs it: given by the user, measured
on the central block, or measured over the whole line as ``boresight-offset`` measures it
(remembered between runs). The kernels are :mod:`geoboresight.sensor.offset`'s."""

from __future__ import annotations

from dataclasses import astuple

import numpy as np

from .. import io
from ..errors import InputError
from ..io.bands import BoresightOffset, MatchBands, open_matching_pair
from ..io.cache import cache_dir, files_key, remembered
from ..progress import as_progress
from ..sensor.offset import (
    PROFILE_ROWS,
    Offset,
    OffsetProfile,
    block_power,
    offset_of,
    profile_block_rows,
    profile_of,
)

#: Lines of the central block the boresight offset is measured on.
OFFSET_ROWS = 512

#: How the user gives the offset instead of measuring it (the error of a line too small).
GIVE_OFFSET = ": give it ('offset_along', 'offset_across')"


def boresight_offset(
    dual,
    given: BoresightOffset,
    progress,
    *,
    over: str = "line",
    ratio_bands=None,
    sources=None,
    hint: str = GIVE_OFFSET,
) -> tuple[float, float, str]:
    """(along, across, how): the SWIR's boresight offset δ (px), ``given``, else measured.

    Parameters
    ----------
    dual : DualSensor
        The flight line.
    given : BoresightOffset
        The user's offset; measured when both members are None (one None = 0).
    progress : Progress
    over : {"line", "central"}
        ``"line"``: over the whole line, as ``boresight-offset`` measures it (the matching
        bands, Fourier cross-correlation of blocks merged, remembered between runs); a line too
        small is refused, the message ending with ``hint``. ``"central"``: on the central block
        of at most :data:`OFFSET_ROWS` lines (:func:`central_rows`), the ratio's bands
        ``ratio_bands`` (default: :meth:`~geoboresight.io.DualSensor.ratio_bands`'s) read
        from ``sources`` (the open VNIR and SWIR datasets); 0 when it cannot be measured
        there, and the log gives it.
    """
    if given.offset_along is not None or given.offset_across is not None:
        along, across, how = (
            float(given.offset_along or 0.0),
            float(given.offset_across or 0.0),
            "given",
        )
    elif over == "central":
        rb = dual.ratio_bands() if ratio_bands is None else ratio_bands
        along, across, how = _central_offset(dual, sources, rb, progress)
    else:
        with open_matching_pair(dual, MatchBands()) as pair:
            off, _ = line_offset(pair, 0, progress, given=hint)
        return off.along, off.across, "measured (boresight-offset)"
    if over == "central":
        progress.info(f"boresight offset {along:+.2f} px along, {across:+.2f} px across ({how})")
    return along, across, how


def _central_offset(dual, sources, rb, progress) -> tuple[float, float, str]:
    from ..sensor.offset import estimate_offset

    v_src, s_src = sources
    r0, r1 = central_rows(dual.height)
    vv, vok = io.band_reader(v_src, rb.vnir_band)(r0, r1)
    ss, sok = io.band_reader(s_src, rb.swir_band)(r0, r1)
    try:
        off = estimate_offset(vv, ss, vok & sok)
    except InputError as e:
        progress.info(f"boresight offset not measurable ({e}); the SWIR is used unshifted")
        return 0.0, 0.0, "not measurable: 0"
    return off.along, off.across, f"measured on lines {r0}–{r1}"


def central_rows(height: int) -> tuple[int, int]:
    """The central block of at most :data:`OFFSET_ROWS` lines of a flight line of ``height``
    lines: where the boresight offset is measured and the surface model registered."""
    r0 = max(0, height // 2 - OFFSET_ROWS // 2)
    return r0, min(height, r0 + OFFSET_ROWS)


#: The smallest block the offset is measured on (lines and columns; sensor.offset.block_power).
MIN_BLOCK = 8


def line_offset(pair, profile_rows: int = 0, progress=None, *, given: str = ""):
    """:func:`measure_line_offset`, remembered between runs for the same files and bands
    (:func:`geoboresight.io.cache.remembered`): the operations of a flight line that need
    the offset then read the line for it once."""
    progress = as_progress(progress)
    dual = getattr(pair, "dual", None)
    files = None
    if dual is not None and cache_dir() is not None:  # no files opened for a cache turned off
        files = files_key([dual.vnir.reads, dual.swir.reads, pair.cloud_mask])
    key = None
    if files is not None:
        key = {
            "files": files,
            "bands": [list(map(int, pair.vnir_bands)), list(map(int, pair.swir_bands))],
            "profile_rows": int(profile_rows),
            "block_rows": PROFILE_ROWS,
        }

    def measure():
        off, prof = measure_line_offset(pair, profile_rows, progress, given=given)
        encoded = {"offset": [off.along, off.across, off.error]}
        if prof is not None:
            encoded["profile"] = [v.tolist() for v in astuple(prof)]
        return encoded

    value, cached = remembered("boresight-offset", key, measure)
    if cached:
        progress.info("boresight offset as measured earlier on these files (cached)")
    elif key is not None and profile_rows:
        # The global offset is the same pass whatever the drift profile: remembered for the
        # operations that need it alone too (rx and svdd after boresight-offset).
        remembered(
            "boresight-offset", {**key, "profile_rows": 0}, lambda: {"offset": value["offset"]}
        )
    prof = value.get("profile")
    return Offset(*value["offset"]), None if prof is None else OffsetProfile(
        *(np.asarray(v, dtype=float) for v in prof)
    )


def measure_line_offset(pair, profile_rows: int = 0, progress=None, *, given: str = ""):
    """The global offset of a flight line and its drift, block by block through
    :func:`~geoboresight.io.map_windows` (memory bounded by a block, whatever the line's length).

    Every block of ``PROFILE_ROWS`` lines (the last one flush with the end of the line) gives its
    cross-power spectrum (:func:`~geoboresight.sensor.offset.block_power`); their sum gives the
    global offset (:func:`~geoboresight.sensor.offset.merged_offset` on whole arrays). With
    ``profile_rows`` > 0 the offset of each block of that many lines is the drift profile
    (:func:`~geoboresight.sensor.offset.offset_profile`; the same pass when it is
    ``PROFILE_ROWS``). ``pair`` is a :class:`~geoboresight.io.bands.MatchingReader`.
    ``given`` says how the caller's user can give the offset instead (added to the error of
    images too small to measure it). Returns ``(Offset, OffsetProfile or None)``.
    """
    progress = as_progress(progress)
    if min(pair.height, pair.width) < MIN_BLOCK:
        raise InputError(
            f"the images are {pair.width} × {pair.height} pixels (columns × lines): the "
            f"boresight offset is measured on blocks of at least {MIN_BLOCK} × {MIN_BLOCK} "
            f"pixels{given}"
        )
    same = profile_rows == PROFILE_ROWS
    total, blocks = None, []
    for line, off, fraction, power in _blocks(
        pair, PROFILE_ROWS, progress.sub(0.0, 1.0 if same or not profile_rows else 0.5), same
    ):
        if power is not None:
            total = power if total is None else total + power
        blocks.append((line, off.along, off.across, off.error, fraction))
    if total is None:
        read, cloudy = getattr(pair, "pixels_read", 0), getattr(pair, "cloud_pixels", 0)
        if read and cloudy > 0.5 * read:
            raise InputError(
                f"cloud mask {pair.cloud_mask} marks {100 * cloudy / read:.0f} % of the pixels "
                "as cloud (non-zero), too many to measure the boresight offset on: a clear-sky "
                "mask (1 = clear) must be inverted; a cloud mask holds 1 for cloud, 0 for clear"
            )
        raise InputError(
            "no block of lines of the matching images has 64 valid pixels: the boresight offset "
            "cannot be measured (check the nodata values and the cloud mask)"
        )
    profile = None
    if profile_rows and not same:
        blocks = [
            (line, off.along, off.across, off.error, fraction)
            for line, off, fraction, _ in _blocks(pair, profile_rows, progress.sub(0.5, 1.0), True)
        ]
    if profile_rows:
        profile = profile_of(blocks)
    return offset_of(total), profile


def _blocks(pair, rows: int, progress, measure: bool):
    """``(centre line, Offset, valid fraction, CrossPower or None)`` per block of ``rows`` lines
    of :func:`~geoboresight.sensor.offset.offset_profile`, the last block flush with the end (the
    offset NaN unless ``measure``)."""
    height, width = pair.height, pair.width
    rows = profile_block_rows(rows, height)

    def read(row0: int, row1: int):
        # Each block is the ``rows`` lines ending with its strip (the last one reaches into
        # the block above): read only those.
        return pair.read(max(0, row1 - rows), row1)

    def one(v, s, ok, *, block):
        first = min(block.window.row_off, height - rows)
        start = block.rows[1] - v.shape[0]
        own = slice(first - start, first - start + rows)
        off, fraction, power = block_power(v[own], s[own], ok[own], measure=measure)
        return first + (rows - 1) / 2, off, fraction, power

    for _, part in io.map_windows(
        read,
        one,
        height=height,
        width=width,
        block_rows=rows,
        halo=(rows, 0),
        pass_block=True,
        progress=progress,
        message="offset per block of lines",
    ):
        yield part


def drift_profile(pair, rows: int, progress=None):
    """The offset per block of ``rows`` lines of a flight line (:func:`line_offset`'s blocks:
    those of :func:`~geoboresight.sensor.offset.offset_profile`)."""
    return profile_of(
        (line, off.along, off.across, off.error, fraction)
        for line, off, fraction, _ in _blocks(pair, rows, as_progress(progress), True)
    )
