import math

import numpy as np
import pytest

from fftnav import SIM_ROBOT, Pipeline
from fftnav.codec import decode_message
from fftnav.scene import trunk_scans


@pytest.fixture(scope="module")
def scans():
    return trunk_scans(np.random.default_rng(5), 15)


def test_batch_equals_single_scans_and_input_is_untouched(scans):
    pipe = Pipeline(SIM_ROBOT)
    scans = scans.copy()
    scans[0, 10] = np.nan
    scans[1, 20] = -2.0
    keep = scans.copy()
    batch = pipe.process(scans)
    np.testing.assert_array_equal(scans, keep)
    for k in (0, 1, 7, 14):
        one = pipe.process(scans[k])
        np.testing.assert_array_equal(one.safe_mask[0], batch.safe_mask[k])
        np.testing.assert_allclose(one.y2[0], batch.y2[k], atol=1e-12)
        np.testing.assert_allclose(one.sigma[0], batch.sigma[k], atol=1e-12)
        assert one.messages[0] == batch.messages[k]
        assert one.p_s[0] == pytest.approx(batch.p_s[k])
    np.testing.assert_array_equal(pipe.safe_mask(scans[3]), batch.safe_mask[3])


def test_messages_decode_to_sigma_and_results_are_consistent(scans):
    res = Pipeline(SIM_ROBOT).process(scans)
    assert res.safe_mask.shape == res.y1.shape == res.y2.shape == (15, 360)
    assert res.x0.shape == (15, 4) and res.p_s.shape == (15,)
    for sig, mins, msg in zip(res.sigma, res.is_min, res.messages, strict=True):
        got, got_min = decode_message(msg, range_m=3.0)
        np.testing.assert_allclose(got[:, 1], sig[:, 1], atol=3.0 / 4094 + 1e-12)
        np.testing.assert_array_equal(got_min, mins)
        assert len(msg) == 4 + 3 * len(sig)
    assert not res.safe_mask[:, np.r_[:8, 353:360]].any()  # blind sector reads 0


def test_special_readings():
    pipe = Pipeline(SIM_ROBOT, mode="circular")
    open_scan = np.full(360, np.inf)
    assert pipe.safe_mask(open_scan).all()
    nan_scan = open_scan.copy()
    nan_scan[180] = np.nan
    mask = pipe.safe_mask(nan_scan)
    assert not mask[150:211].any() and mask[:149].all() and mask[212:].all()
    far = np.full(360, 50.0)
    np.testing.assert_array_equal(pipe.safe_mask(far), pipe.safe_mask(open_scan))


def test_nearest_safe_headings_via_pipeline(scans):
    pipe = Pipeline(SIM_ROBOT)
    res = pipe.process(scans)
    left, right = pipe.nearest_safe_headings(res.safe_mask, np.zeros(15))
    assert left.shape == right.shape == (15,)
    ok = ~np.isnan(left)
    assert (left[ok] >= -1e-12).all() or (left[ok] < 0).any()  # left may wrap past the back
    idx = np.rint((left[ok] + math.pi) / math.radians(1)).astype(int)
    assert res.safe_mask[ok][np.arange(ok.sum()), idx].all()


@pytest.mark.parametrize(
    ("ranges", "match"),
    [
        (np.ones(100), r"ranges must have beams=360 readings per scan, got shape=\(100,\)"),
        (np.ones((2, 2, 360)), r"got shape=\(2, 2, 360\)"),
    ],
)
def test_bad_scans(ranges, match):
    with pytest.raises(ValueError, match=match):
        Pipeline(SIM_ROBOT).process(ranges)


def test_bad_layout():
    with pytest.raises(ValueError, match="layout must be one of .* got layout='json'"):
        Pipeline(SIM_ROBOT, layout="json")
