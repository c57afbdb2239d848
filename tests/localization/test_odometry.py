"""The sampled odometry motion model against its definition, and the drift presets against
their stated drift."""

import numpy as np
import pytest

from fftnav.errors import FftnavError
from fftnav.localization import (
    DRIFT_PRESETS,
    OdometryNoise,
    compose,
    drift_percent,
    odometry_motion,
    reference_path,
    sample_motion_model_odometry,
)

STATED_PERCENT = {"low": 0.5, "typical": 2.0, "high": 5.0}


def _read_back(noise, rng, motion, n=40_000):
    """The errors of ``n`` noisy readings of one motion, read back from the estimates."""
    before = np.zeros((n, 3))
    rot1, trans, rot2 = motion
    after = compose(before, np.full(n, rot1), np.full(n, trans), np.full(n, rot2))
    est = sample_motion_model_odometry(before, before, after, noise=noise, dt_s=0.1, rng=rng)
    r1, t, r2 = odometry_motion(before, est, min_trans_m=0.0)
    return r1 - rot1, t - trans, r2 - rot2


def _fit_alphas(noise, rng):
    """Moment estimates of the alphas from the variances of the read-back errors of a straight
    drive (alpha2 from the rotation error, alpha3 from the translation error) and of a turn on
    the spot (alpha1 from the rotation error, alpha4 from the translation error)."""
    trans, turn = 0.1, 0.5
    e_rot1, e_trans, _ = _read_back(noise, rng, (0.0, trans, 0.0))
    _, e_spot, e_rot2 = _read_back(noise, rng, (0.0, 0.0, turn))
    return np.array([np.mean(e_rot2**2) / turn**2, np.mean(e_rot1**2) / trans**2,
                     np.mean(e_trans**2) / trans**2, np.mean(e_spot**2) / turn**2])


@pytest.mark.parametrize("alphas", [(0.05, 0.02, 0.04, 0.01), (0.2, 0.005, 0.01, 0.05)])
def test_error_statistics_match_the_configured_alphas_within_10_percent(alphas):
    noise = OdometryNoise(*alphas)
    fitted = _fit_alphas(noise, np.random.default_rng(3))
    assert fitted == pytest.approx(alphas, rel=0.10)


@pytest.mark.parametrize("preset", ["low", "typical", "high"])
def test_each_preset_drifts_within_20_percent_of_its_stated_percentage(preset):
    measured = drift_percent(DRIFT_PRESETS[preset], runs=4000, seed=11)
    assert measured == pytest.approx(STATED_PERCENT[preset], rel=0.20)


def test_noise_free_odometry_follows_the_truth_and_draws_nothing():
    path = reference_path(length_m=5.0)
    rng = np.random.default_rng(0)
    state = rng.bit_generator.state
    est = path[:1].copy()
    for k in range(1, len(path)):
        est = sample_motion_model_odometry(est, path[k - 1:k], path[k:k + 1],
                                           noise=DRIFT_PRESETS["none"], dt_s=0.1, rng=rng)
    assert np.allclose(est, path[-1:], atol=1e-9)
    assert rng.bit_generator.state == state


def test_the_gyro_bias_turns_the_estimate_at_its_rate():
    path = np.array([[0.0, 0.0, 0.0], [0.05, 0.0, 0.0]])
    est = sample_motion_model_odometry(path[:1], path[:1], path[1:],
                                       noise=OdometryNoise(gyro_bias_radps=0.2), dt_s=0.1,
                                       rng=np.random.default_rng(0))
    assert est[0, 2] == pytest.approx(0.02)


def test_a_turn_on_the_spot_is_no_drive_and_backward_is_negative():
    rot1, trans, rot2 = odometry_motion(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
                                        np.array([[0.0, 0.0, 1.0], [-0.1, 0.0, 0.0]]))
    assert rot1.tolist() == [0.0, 0.0] and trans[0] == 0.0 and rot2[0] == 1.0
    assert trans[1] == pytest.approx(-0.1) and rot2[1] == pytest.approx(0.0)


def test_bad_input_names_the_parameter():
    with pytest.raises(FftnavError, match="alpha2 must be"):
        OdometryNoise(alpha2=-1.0)
    with pytest.raises(FftnavError, match="estimate must be an \\(N, 3\\) array"):
        sample_motion_model_odometry(np.zeros(3), np.zeros((1, 3)), np.zeros((1, 3)),
                                     noise=OdometryNoise(), dt_s=0.1,
                                     rng=np.random.default_rng(0))
    with pytest.raises(FftnavError, match="estimate must have one row per robot"):
        sample_motion_model_odometry(np.zeros((2, 3)), np.zeros((1, 3)), np.zeros((1, 3)),
                                     noise=OdometryNoise(), dt_s=0.1,
                                     rng=np.random.default_rng(0))


@pytest.mark.parametrize("alphas", [(0.05, 0.02, 0.04, 0.01), (0.2, 0.005, 0.01, 0.05)])
def test_a_turn_drive_turn_has_each_readings_variance(alphas):
    """A motion with both turns and a drive: each reading's error variance is its term of
    Table 5.6 (rot1 and rot2 kept apart), within 10 %."""
    a1, a2, a3, a4 = alphas
    rot1, trans, rot2 = 0.4, 0.1, -0.3
    e_rot1, e_trans, e_rot2 = _read_back(OdometryNoise(*alphas), np.random.default_rng(5),
                                         (rot1, trans, rot2))
    assert np.mean(e_rot1**2) == pytest.approx(a1 * rot1**2 + a2 * trans**2, rel=0.1)
    assert np.mean(e_trans**2) == pytest.approx(a3 * trans**2 + a4 * (rot1**2 + rot2**2),
                                                rel=0.1)
    assert np.mean(e_rot2**2) == pytest.approx(a1 * rot2**2 + a2 * trans**2, rel=0.1)
