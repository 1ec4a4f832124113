"""The boresight offset is measured once per flight line and remembered between operations."""

from __future__ import annotations

import os

import numpy as np
import pytest
from dem_synth import pair
from synth import SWIR_WL, VNIR_WL, write_envi

from geoboresight.io import cache
from geoboresight.io.bands import MatchBands, open_matching_pair
from geoboresight.io.dual import as_dual
from geoboresight.operations import _offset as offset_ops


@pytest.fixture
def line(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path / "cache"))
    v, s, _, _ = pair(96, 80, offset=(0.7, -0.3), noise=2.0)
    vc = np.stack([v] * len(VNIR_WL)).astype("float32")
    sc = np.stack([s] * len(SWIR_WL)).astype("float32")
    paths = (
        write_envi(tmp_path / "vnir.img", vc, VNIR_WL),
        write_envi(tmp_path / "swir.img", sc, SWIR_WL),
    )
    return [str(p) for p in paths], sc


def _offset(paths):
    with open_matching_pair(as_dual(*paths), MatchBands()) as p:
        return offset_ops.line_offset(p)[0]


def test_the_offset_is_read_once_then_remembered(line, monkeypatch):
    paths, _ = line
    first = _offset(paths)
    assert first.along == pytest.approx(0.7, abs=0.05)

    # The second time, the line is not read: a measurement would fail.
    def fail(*a, **k):
        raise AssertionError("measured again")

    monkeypatch.setattr(offset_ops, "measure_line_offset", fail)
    assert _offset(paths) == first


def test_a_rewritten_file_is_measured_again(line, monkeypatch):
    paths, sc = line
    first = _offset(paths)
    # The SWIR data file written again, with the same size: another key.
    data = paths[1][:-4] + ".img" if paths[1].endswith(".hdr") else paths[1]
    write_envi(data, np.roll(sc, 1, axis=1), SWIR_WL)
    os.utime(data, ns=(1, 1))  # even an old modification time differs from the first one's
    again = _offset(paths)
    assert again.along == pytest.approx(first.along + 1.0, abs=0.05)


def test_an_empty_cache_folder_turns_remembering_off(line, monkeypatch):
    paths, _ = line
    monkeypatch.setenv(cache.CACHE_ENV, "")
    _offset(paths)
    calls = []
    real = offset_ops.measure_line_offset
    monkeypatch.setattr(
        offset_ops, "measure_line_offset", lambda *a, **k: calls.append(1) or real(*a, **k)
    )
    _offset(paths)
    assert calls == [1]


def test_a_cache_folder_that_cannot_be_written_costs_only_the_measurement(line, monkeypatch):
    paths, _ = line
    blocker = os.path.join(os.path.dirname(paths[0]), "not-a-folder")
    open(blocker, "w").close()
    monkeypatch.setenv(cache.CACHE_ENV, blocker)
    assert _offset(paths).along == pytest.approx(0.7, abs=0.05)


def test_an_offset_measured_with_its_drift_profile_serves_the_offset_alone(line, monkeypatch):
    """boresight-offset measures the drift profile in the same pass as the global offset: the
    operations that need the offset alone (rx, svdd) then read it from the cache."""
    paths, _ = line
    with open_matching_pair(as_dual(*paths), MatchBands()) as p:
        with_profile, profile = offset_ops.line_offset(p, offset_ops.PROFILE_ROWS)
        alone, no_profile = offset_ops.measure_line_offset(p, 0)
    assert profile is not None and no_profile is None
    assert alone == with_profile  # the same measurement, so the same value from the cache

    def fail(*a, **k):
        raise AssertionError("measured again")

    monkeypatch.setattr(offset_ops, "measure_line_offset", fail)
    assert _offset(paths) == with_profile
    # A profile of another block size is not in the cache: it is measured.
    with open_matching_pair(as_dual(*paths), MatchBands()) as p:
        with pytest.raises(AssertionError, match="measured again"):
            offset_ops.line_offset(p, 32)
