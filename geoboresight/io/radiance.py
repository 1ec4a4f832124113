"""A raw capture as radiance: what turns its DN into radiance (:class:`RadiancePlan`, from
the readers of :mod:`geoboresight.io.calibration`), the same image read as radiance by GDAL
with no file written in between (:func:`radiance_image`: every operation on a flight line
reads it so with ``vnir_calibration``/``swir_calibration``), and what ``info`` says about its
values (:func:`radiometry`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, ParameterError
from ..sensor.calibration import Calibration
from .calibration import (
    binning_of,
    capture_dark,
    capture_tints,
    hyspex_calibration,
    read_calibration,
    require_match,
    saturation_of,
    sensor_family,
)
from .products._raw import RawCube


# ------------------------------------------------------------------------- a capture's plan
@dataclass(frozen=True, eq=False)
class RadiancePlan:
    """What turns a raw capture into radiance, on the capture's grid: its raw ``cube`` (image
    lines ``0 … lines − 1``), and per band (and sample) its ``wavelengths``, ``fwhm``,
    ``gain``, ``dark``, ``tint`` (ms), ``saturation`` DN, ``bad`` cells and the Eagle smear
    factor ``smear``; ``tags`` record every choice and where it came from."""

    kind: str
    path: str
    cube: RawCube
    lines: int
    wavelengths: np.ndarray
    fwhm: np.ndarray | None
    gain: np.ndarray
    dark: np.ndarray
    tint: np.ndarray
    saturation: np.ndarray
    bad: np.ndarray | None
    smear: float
    tags: dict = field(default_factory=dict)

    def dn(self, row0: int, row1: int) -> np.ndarray:
        """Raw DN of image lines ``row0:row1``, shape (lines, bands, samples)."""
        mm = self.cube.memmap()
        out = np.array(mm[row0:row1])
        del mm
        return out


#: How the Eagle's frame-transfer smear is treated: "auto" (an Eagle's), "on", "off".
SMEAR_CHOICES = ("auto", "on", "off")


def radiance_plan(
    path, calibration=None, smear: str = "auto", param: str = "calibration"
) -> RadiancePlan:
    """The :class:`RadiancePlan` of the raw Specim capture or HySpex file at ``path``.

    ``calibration`` is the Specim calibration (a path or a :class:`Calibration`); a HySpex
    file carries its own. Raises :class:`InputError`/:class:`ParameterError` with one line for
    what does not fit: another product, no calibration, another sensor or binning, bands
    without a calibration band, no integration time, a dark file at another tint.
    """
    from .products import recognise

    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError(f"input {path} does not exist: check the path")
    if smear not in SMEAR_CHOICES:
        raise ParameterError(
            f"parameter 'smear': {smear!r} is not one of {', '.join(SMEAR_CHOICES)}",
            params=("smear",),
        )
    return _plan(recognise(path), path, calibration, smear, param)


def _plan(product, path: str, calibration, smear: str, param: str) -> RadiancePlan:
    """:func:`radiance_plan` of the product recognised at ``path`` (None: not one)."""
    kind = product.kind if product is not None else None
    if kind == "HySpex":
        if calibration is not None:
            raise ParameterError(
                f"parameter '{param}': {path} is a HySpex file, which carries its own "
                "calibration: leave 'calibration' empty",
                params=(param,),
            )
        return _hyspex_plan(product)
    if kind != "Specim raw ENVI":
        raise InputError(
            f"input {path}: radiance is made from a raw Specim capture (ENVI with its Specim "
            "header: autodarkstartline, sensorid, tint) or a HySpex .hyspex file; this is "
            "neither"
        )
    if calibration is None:
        raise ParameterError(
            f"parameter '{param}': {path} is a raw Specim capture in DN: give its "
            "calibration file (the .cal or .dat of the sensor's calibration pack)",
            params=(param,),
        )
    cal = calibration
    if not isinstance(cal, Calibration):
        cal = read_calibration(cal, "calibration")
    return _specim_plan(product, cal, smear, param)


def _specim_plan(product, cal: Calibration, smear: str, param: str) -> RadiancePlan:
    from ..sensor.calibration import (
        FRAME_TRANSFER_MS,
        bin_gain,
        binned_wavelengths,
        match_bands,
    )

    path, capture, image = product.path, product.capture, product.images[0]
    hdr, keys, cube, lines = capture.header, capture.keys, capture.layout, capture.lines
    where = f"Specim header {hdr}"
    wl = np.asarray(image.wavelengths, float)
    sensorid = keys.get("sensorid", "").strip()
    binning = binning_of(keys, where)
    family = sensor_family(sensorid, keys, wl)
    ratio = require_match(cal, sensorid, binning, path, param)
    gain_b = bin_gain(cal.gain, *ratio)
    wl_b = binned_wavelengths(cal.wavelengths, ratio[0])
    if gain_b.shape[1] != cube.samples:
        raise ParameterError(
            f"parameter '{param}': {cal.source} has {cal.samples} samples (binned "
            f"{ratio[1]}×: {gain_b.shape[1]}) but {path} has {cube.samples}: use the "
            "calibration of this sensor and binning",
            params=(param,),
        )
    index, ok = match_bands(wl, wl_b)
    if not ok.all():
        b = int(np.flatnonzero(~ok)[0])
        raise ParameterError(
            f"parameter '{param}': band {b + 1} of {path} ({wl[b]:.2f} nm) has no band "
            f"of {cal.source} within half a band (nearest {wl_b[index[b]]:.2f} nm): the "
            "calibration is for another band set",
            params=(param,),
        )
    tint, tint_note = capture_tints(keys, where, cube.bands)
    dark, dark_note = capture_dark(product, tint)
    bad = None
    if cal.bad:
        bad = np.zeros((cube.bands, cube.samples), bool)
        for cb, cs in cal.bad:
            raw = np.flatnonzero(index == cb // ratio[0])
            if raw.size and cs // ratio[1] < cube.samples:
                bad[raw, cs // ratio[1]] = True
    fsc = 0.0
    if smear == "on" or (smear == "auto" and family == "Eagle"):
        fsc = FRAME_TRANSFER_MS / float(tint[0]) * binning[0]
    saturation = saturation_of(family, keys, wl, binning)
    tags = {
        "product": "radiance (L = (DN - dark) * gain / tint[ms])",
        "units": cal.units,
        "input_units": "DN",
        "sensor": family,
        "calibration_file": cal.source,
        "calibration_sensorid": cal.sensorid or "(none)",
        "capture_sensorid": sensorid or "(none)",
        "calibration_binning": f"{cal.binning[0]}x{cal.binning[1]}",
        "capture_binning": f"{binning[0]}x{binning[1]}",
        "binning_ratio": f"{ratio[0]}x{ratio[1]} (gains summed / ratio squared, APL)",
        "integration_time": tint_note,
        "dark": dark_note,
        "saturation_dn": ", ".join(f"{v:g}" for v in np.unique(saturation)),
        "smear": f"Eagle frame-transfer smear, fsc = {fsc:.6g}" if fsc else "none",
        "bad_pixels": f"{int(bad.sum())} from {cal.bad_source}" if bad is not None else "none",
        "nodata": "saturated, bad, frame counter and zero pixel (band 1, samples 1-2)",
    }
    return RadiancePlan(
        "Specim raw ENVI",
        path,
        cube,
        lines,
        wl,
        None if image.fwhm is None else np.asarray(image.fwhm, float),
        gain_b[index].astype(np.float64),
        dark,
        tint,
        saturation,
        bad,
        fsc,
        tags,
    )


def _hyspex_plan(product) -> RadiancePlan:
    path, cube = product.path, product.capture.layout
    bands, lines = cube.bands, product.capture.lines
    cal, bg, sat, order = hyspex_calibration(path)
    tags = {
        "product": "radiance (HyPro: L = (DN - background) * h c / (RE QE SF tint A omega "
        "dlambda lambda))",
        "units": cal.units,
        "input_units": "DN",
        "sensor": "HySpex",
        "calibration_file": f"{path} (its own header: QE, RE, background)",
        "calibration_arrays": order,
        "dark": "background matrix of the header",
        "saturation_dn": f"{sat:g}",
        "nodata": "saturated pixels",
    }
    return RadiancePlan(
        "HySpex",
        path,
        cube,
        lines,
        cal.wavelengths,
        None,
        cal.gain.astype(np.float64),
        bg,
        np.ones(bands),
        np.full(bands, sat),
        None,
        0.0,
        tags,
    )


# ------------------------------------------------------------------------ radiance on the fly
_ON_THE_FLY: dict[tuple, object] = {}


def _stamp(path) -> tuple:
    st = os.stat(path)
    return (os.path.realpath(path), st.st_size, st.st_mtime_ns)


def radiance_image(product, calibration, param: str = "calibration"):
    """The image of a raw capture as radiance, read by GDAL with no file written in between:
    a :class:`~geoboresight.io.products.SensorImage` whose ``source`` is a VRT of
    ``L = (DN − dark) · gain / tint`` per band (GDAL's ``sum`` and ``mul`` pixel functions
    over the capture's own bytes and one line of coefficients per band); returns
    ``(SensorImage, RadiancePlan)``. NaN where a pixel is
    saturated, a bad cell or the frame counter; ``units`` radiance, ``dark`` 0.

    ``product`` is the capture as :func:`~geoboresight.io.products.recognise` found it (its
    files are not looked for again), or its path. ``calibration`` is the Specim calibration
    (a path or :class:`Calibration`), or, for a HySpex file, the file itself (its own
    calibration); ``param`` names it in messages. The Eagle's frame-transfer smear is
    left out here (each band would need every band before it): ``radiance`` applies it.
    """
    from .products import Product, recognise

    if not isinstance(product, Product):
        path = os.fspath(product)
        product = recognise(path)
    else:
        path = product.path
    if product is not None and product.kind == "HySpex":
        given = calibration.source if isinstance(calibration, Calibration) else calibration
        if given is not None and os.path.realpath(os.fspath(given)) != os.path.realpath(path):
            raise ParameterError(
                f"parameter '{param}': {path} is a HySpex file, which carries its own "
                f"calibration: give the file itself as its calibration, not {given}",
                params=(param,),
            )
        calibration = None
    from . import _pixel

    cal_key = id(calibration) if isinstance(calibration, Calibration) else calibration
    if isinstance(cal_key, str | os.PathLike) and os.path.exists(cal_key):
        cal_key = _stamp(cal_key)
    key = (_stamp(path), cal_key, _pixel.python_allowed())
    found = _ON_THE_FLY.get(key)
    if found is None:
        if calibration is not None and not isinstance(calibration, Calibration):
            if not os.path.exists(os.fspath(calibration)):
                raise InputError(f"calibration {calibration} does not exist: check the path")
        plan = _plan(product, path, calibration, "off", param)
        found = _ON_THE_FLY[key] = _radiance_vrt(plan, product.images[0])
    return found


def _radiance_vrt(plan: RadiancePlan, image):
    """A SensorImage reading ``image`` (DN) as radiance through two VRTs (see
    :func:`radiance_image`)."""
    import dataclasses
    from xml.sax.saxutils import escape

    from . import _pixel
    from .products._calibrated import temp_path
    from .products.vrt import write_vrt

    nb, ns, h = plan.cube.bands, plan.cube.samples, plan.lines
    dark = np.asarray(plan.dark, np.float64).copy()
    scale = plan.gain / plan.tint[:, None]
    if plan.bad is not None:
        scale[plan.bad] = np.nan
    # The coefficients, one line per band (dark, then gain / tint), repeated down every line
    # of the image by a raw band whose line offset is 0: read 1:1 with the pixels, nothing
    # resampled (a one-line source stretched over the image cost 4× the pixels' own read).
    coef_path = temp_path("radiance-coefficients", ".bin")
    np.concatenate([dark, scale]).astype("<f8").tofile(coef_path)
    coef_xml = [f'<VRTDataset rasterXSize="{ns}" rasterYSize="{h}">']
    for i in range(2 * nb):
        coef_xml.append(
            f'<VRTRasterBand dataType="Float64" band="{i + 1}" subClass="VRTRawRasterBand">'
            f'<SourceFilename relativeToVRT="0">{escape(coef_path)}</SourceFilename>'
            f"<ImageOffset>{i * ns * 8}</ImageOffset><PixelOffset>8</PixelOffset>"
            "<LineOffset>0</LineOffset><ByteOrder>LSB</ByteOrder></VRTRasterBand>"
        )
    rows = escape(write_vrt("".join(coef_xml) + "</VRTDataset>\n", "radiance-coefficients"))
    src = escape(os.path.abspath(image.source))
    full = f'xOff="0" yOff="0" xSize="{ns}" ySize="{h}"'

    def source(name, band, rect, extra=""):
        return (
            f'<ComplexSource><SourceFilename relativeToVRT="0">{name}</SourceFilename>'
            f"<SourceBand>{band}</SourceBand><SrcRect {rect}/><DstRect {full}/>{extra}"
            "</ComplexSource>"
        )

    def band(i, function, dtype, sources, meta="", python=False):
        # A source pixel at its NODATA (the saturated DN) reads as the band's NaN nodata,
        # which the arithmetic carries through.
        language = "<PixelFunctionLanguage>Python</PixelFunctionLanguage>" if python else ""
        return (
            f'<VRTRasterBand dataType="{dtype}" band="{i}" subClass="VRTDerivedRasterBand">'
            f"{meta}<NoDataValue>nan</NoDataValue><PixelFunctionType>{function}"
            f"</PixelFunctionType>{language}<SourceTransferType>Float64</SourceTransferType>"
            f"{sources}</VRTRasterBand>"
        )

    head = f'<VRTDataset rasterXSize="{ns}" rasterYSize="{h}">'

    def meta(b):
        return (
            f"<Description>{plan.wavelengths[b]:.3f} nm</Description><Metadata>"
            f'<MDI key="wavelength">{plan.wavelengths[b]:.6f}</MDI>'
            '<MDI key="wavelength_units">nm</MDI>'
            f'<MDI key="units">{escape(plan.tags["units"])}</MDI></Metadata>'
        )

    def saturated(b):
        return f"<NODATA>{plan.saturation[b]:.17g}</NODATA>"

    out = []
    if _pixel.python_allowed():
        # One level: NumPy's (DN − dark) · scale in this package's trusted pixel function.
        _pixel.trust()
        for b in range(nb):
            sources = (
                source(src, b + 1, full, saturated(b))
                + source(rows, b + 1, full)
                + source(rows, nb + b + 1, full)
            )
            out.append(
                band(
                    b + 1,
                    f"{_pixel.MODULE}.radiance",
                    "Float32",
                    sources,
                    meta(b),
                    python=True,
                )
            )
    else:
        # GDAL's own functions: sum (DN − dark), then mul (· scale).
        signal = []
        for b in range(nb):
            minus = "<ScaleOffset>0</ScaleOffset><ScaleRatio>-1</ScaleRatio>"
            signal.append(
                band(
                    b + 1,
                    "sum",
                    "Float64",
                    source(src, b + 1, full, saturated(b)) + source(rows, b + 1, full, minus),
                )
            )
        l1 = escape(write_vrt(head + "".join(signal) + "</VRTDataset>\n", "radiance-signal"))
        for b in range(nb):
            sources = source(l1, b + 1, full) + source(rows, nb + b + 1, full)
            out.append(band(b + 1, "mul", "Float32", sources, meta(b)))
    l2 = write_vrt(head + "".join(out) + "</VRTDataset>\n", "radiance")
    return dataclasses.replace(
        image,
        source=l2,
        nodata=None,
        units=plan.tags["units"],
        gains=None,
        offsets=None,
        dark=np.zeros((nb, ns)),
        dark_source="radiance (" + plan.tags["dark"] + ", subtracted)",
    ), plan


def radiometry(path, calibration=None, param: str = "vnir_calibration") -> dict | None:
    """What the values of the raw capture at ``path`` are, as ``info`` states it: ``values``
    ("DN" or the radiance units), its integration time(s), and with ``calibration`` the file,
    whether its ``sensorid`` and binning match the capture's (a mismatch is refused, naming
    both) and the binning ratio. None for anything but a raw Specim capture or HySpex file."""
    from .products import hyspex, specim

    path = os.fspath(path)
    if hyspex.read(path) is not None:
        out = {"values": "DN", "calibration": "in the file's header (QE, RE, background)"}
        if calibration is not None and calibration != "":
            _, plan = radiance_image(path, calibration, param)
            out.update(values=plan.tags["units"], arrays=plan.tags["calibration_arrays"])
        return out
    found = specim.capture(path)
    if found is None:
        return None
    hdr, keys, cube = found
    where = f"Specim header {hdr}"
    out = {"values": "DN", "sensorid": keys.get("sensorid", "").strip() or None}
    try:
        out["integration_time"] = capture_tints(keys, where, cube.bands)[1]
    except InputError as exc:
        out["integration_time"] = f"unknown ({exc})"
    out["binning"] = "{}x{}".format(*binning_of(keys, where))
    if calibration is not None and calibration != "":
        _, plan = radiance_image(path, calibration, param)
        t = plan.tags
        out.update(
            values=t["units"],
            calibration_file=t["calibration_file"],
            sensorid=f"capture {t['capture_sensorid']}, calibration {t['calibration_sensorid']}"
            " (match)",
            binning=f"capture {t['capture_binning']}, calibration {t['calibration_binning']} "
            f"(ratio {t['binning_ratio'].split(' ')[0]})",
            dark=t["dark"],
            bad_pixels=t["bad_pixels"],
        )
    return out


__all__ = [
    "SMEAR_CHOICES",
    "RadiancePlan",
    "radiance_image",
    "radiance_plan",
    "radiometry",
]
