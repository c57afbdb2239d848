import math

import numpy as np
import pytest

from fftnav import SIM_ROBOT, Pipeline
from fftnav.observe.codec import decode_message
from fftnav.world.scenes import trunk_scans


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


def test_flat_outputs_and_per_scan_views_agree(scans):
    from fftnav.observe.codec import encode_sigma

    res = Pipeline(SIM_ROBOT).process(scans)
    assert res.offsets[0] == 0 and res.offsets[-1] == len(res.sigma_flat) == len(res.is_min_flat)
    for k, (sig, mins) in enumerate(zip(res.sigma, res.is_min, strict=True)):
        a, z = res.offsets[k], res.offsets[k + 1]
        np.testing.assert_array_equal(sig, res.sigma_flat[a:z])
        np.testing.assert_array_equal(mins, res.is_min_flat[a:z])
        assert res.messages[k] == encode_sigma(sig, is_min=mins, range_m=3.0)
    assert res.sigma is res.sigma  # made once


@pytest.mark.parametrize("mode", ["linear", "circular"])
def test_scans_without_any_extremum_give_empty_sigma_and_even_odds(mode):
    """Blocked (all zero) scans: no extremum in any scan of the batch, so every quadrant area
    is 0 and P_s = sigmoid(0) = 1/2 (an empty interpolation)."""
    res = Pipeline(SIM_ROBOT, mode=mode).process(np.zeros((3, 360)))
    assert [len(s) for s in res.sigma] == [0, 0, 0] and not res.safe_mask.any()
    np.testing.assert_array_equal(res.x0, np.zeros((3, 4)))
    np.testing.assert_array_equal(res.p_s, [0.5, 0.5, 0.5])
    assert all(decode_message(m, range_m=3.0)[0].shape == (0, 2) for m in res.messages)
