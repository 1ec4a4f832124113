"""The one place an instrument's dark level is found: given > the sensor product's dark
reference > the ENVI header (what io.dark reads) > the dark object of the data (what
sensor.dark chooses)."""

from __future__ import annotations

import numpy as np
import pytest

from geoboresight.errors import InputError, ParameterError
from geoboresight.io.dark import header_dark, product_dark, recorded_dark_levels
from geoboresight.io.dual import SensorFile
from geoboresight.sensor.dark import DarkLevels, find_dark_levels


def sensor(dark=None, source=""):
    return SensorFile(
        "v.hdr", "VNIR", (2, 3, 4), np.array([500.0, 600.0, 700.0]), dark=dark, dark_source=source
    )


class File:
    """An open file's ENVI tags and band count, as rasterio gives them."""

    def __init__(self, header, count=4):
        self.header, self.count = header, count

    def tags(self, ns=None):
        return self.header


def found(sensor, header, given=DarkLevels(), bands=(2, 4)):
    recorded = recorded_dark_levels({"vnir": (sensor, File(header), list(bands))}, given)
    return find_dark_levels(given, recorded, {})


def test_order_given_product_header_none():
    header = {"dark_level": "{10, 20, 30, 40}"}
    dark = np.array([[1.0, 3.0], [5.0, 7.0], [9.0, 11.0]])  # per band and column
    given = found(sensor(dark, "frames"), header, DarkLevels(vnir_dark=0))
    assert (given.vnir_dark, given.vnir_source, given.vnir_bands) == (0.0, "given", None)
    assert given.param("vnir") == "vnir_dark"
    product = found(sensor(dark, "frames"), header)
    assert product.vnir_source == "frames" and product.vnir_pixels == 0
    np.testing.assert_array_equal(product.band_levels("vnir"), [2.0, 10.0])  # mean over columns
    assert product.vnir_dark == 6.0 and product.param("vnir") == ""
    head = found(sensor(), header)
    assert head.vnir_source == "header of v.hdr"
    np.testing.assert_array_equal(head.band_levels("vnir"), [20.0, 40.0])
    assert head.for_bands("vnir", [2, 4], [4]).tolist() == [40.0]
    one = found(sensor(), {"dark_level": "15"})
    assert (one.vnir_dark, one.vnir_bands, one.for_bands("vnir", [2, 4], [4])) == (15.0, None, 15.0)
    assert found(sensor(), {}).vnir_dark is None


def test_a_given_level_is_not_read_from_the_files():
    """A level the user gives wins before the header is read: a header the reader would
    refuse does not stop the run."""
    bad = {"dark_level": "{1, 2}"}
    assert found(sensor(), bad, DarkLevels(vnir_dark=5)).vnir_dark == 5.0
    with pytest.raises(InputError, match="lists 2 values for 4 bands"):
        found(sensor(), bad)


def test_product_dark_leaves_out_non_image_columns():
    dark = np.array([[np.nan, 2.0, 4.0], [1.0, 1.0, 1.0], [np.nan, np.nan, np.nan]])
    np.testing.assert_array_equal(product_dark(sensor(dark), [2, 3]), [3.0, 1.0])
    assert product_dark(sensor(dark), [2, 4]) is None  # a band without any image column
    assert product_dark(sensor(), [2]) is None


def test_bad_levels_are_refused():
    with pytest.raises(InputError, match="lists 2 values for 4 bands"):
        header_dark({"dark_level": "{1, 2}"}, [1], 4, "v.hdr")
    with pytest.raises(ParameterError, match="vnir_dark"):
        found(sensor(), {}, DarkLevels(vnir_dark=float("nan")))
    assert DarkLevels() == DarkLevels(None, None)


def test_a_non_finite_member_of_a_group_is_refused_before_any_work(tmp_path):
    from geoboresight import MapCalibration, shadow_map_file

    scene = "sample_data/scene"
    out = tmp_path / "m.tif"
    for kw, name in (
        (dict(dark=DarkLevels(float("nan"))), "vnir_dark"),
        (dict(calibration=MapCalibration(offset_across=float("inf"))), "offset_across"),
    ):
        with pytest.raises(ParameterError, match=name):
            shadow_map_file(f"{scene}/vnir.hdr", f"{scene}/swir.hdr", output=str(out), **kw)
        assert not out.exists()


def test_calibration_sample_checks_refuse_what_the_physics_cannot_use():
    """shadow-map's physics checks: a saturated or signal-less sample, a dark level
    below the data or above its signal, each refused naming the instrument; a sound sample
    passes and counts its saturated pixels."""
    import numpy as np
    import pytest

    from geoboresight.errors import InputError
    from geoboresight.shadow.darkness import check_sample

    rng = np.random.default_rng(0)
    values = rng.uniform(200, 3000, (4, 500))
    values[:, :7] = 4095  # seven saturated pixels
    ok = np.ones(500, bool)
    c = check_sample(values, ok, DarkLevels(150.0), "vnir", name="VNIR v.img", saturation=4095)
    assert c.saturated == 7 and c.usable.sum() == 493 and c.above_dark == 493
    with pytest.raises(InputError, match="VNIR v.img: 500 of 500 sampled pixels are saturated"):
        check_sample(np.full((4, 500), 4095.0), ok, None, name="VNIR v.img", saturation=4095)
    with pytest.raises(InputError, match="VNIR v.img: every sampled pixel reads 0"):
        check_sample(np.zeros((4, 500)), ok, None, name="VNIR v.img")
    with pytest.raises(InputError, match="above the signal"):
        check_sample(values, ok, DarkLevels(5000.0), "vnir", name="VNIR v.img", saturation=4095)
    with pytest.raises(InputError, match="far below the darkest"):
        check_sample(values, ok, DarkLevels(-400.0), "vnir", name="VNIR v.img", saturation=4095)
