import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fftnav.observe.codec import MessageError, decode_message, decode_sigma, encode_sigma


def random_sigma(rng, n, range_m=3.0):
    sigma = np.column_stack(
        [np.sort(rng.uniform(-math.pi, math.pi, n)), rng.uniform(0, range_m, n)]
    )
    return sigma, rng.random(n) < 0.5


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 40), range_m=st.floats(0.5, 100.0))
def test_round_trips_within_the_stated_quantisation(seed, n, range_m):
    rng = np.random.default_rng(seed)
    sigma, mins = random_sigma(rng, n, range_m)
    data = encode_sigma(sigma, is_min=mins, layout="compact", range_m=range_m)
    assert len(data) == 4 + 3 * n
    got, got_min = decode_message(data, range_m=range_m)
    dphi = (got[:, 0] - sigma[:, 0] + math.pi) % (2 * math.pi) - math.pi
    assert np.all(np.abs(dphi) <= math.pi / 4096 + 1e-12)
    assert np.all(np.abs(got[:, 1] - sigma[:, 1]) <= range_m / 4094 + 1e-12)
    np.testing.assert_array_equal(got_min, mins)
    data = encode_sigma(sigma, is_min=mins, layout="float32", range_m=range_m)
    assert len(data) == 4 + 8 * n
    got, got_min = decode_message(data, range_m=range_m)
    np.testing.assert_allclose(got, sigma, rtol=1e-7, atol=1e-6)
    np.testing.assert_array_equal(got_min, mins)


def test_paper_sized_message_is_28_bytes_compact_and_68_float32():
    sigma, mins = random_sigma(np.random.default_rng(0), 8)
    assert len(encode_sigma(sigma, is_min=mins, range_m=3.0)) == 28
    assert len(encode_sigma(sigma, layout="float32", range_m=3.0)) == 68
    assert not decode_message(encode_sigma(sigma, range_m=3.0), range_m=3.0)[1].any()
    np.testing.assert_allclose(
        decode_sigma(encode_sigma(sigma, layout="float32", range_m=3.0), range_m=3.0),
        sigma,
        rtol=1e-6,
    )
    min_at_zero = encode_sigma(np.array([[0.5, 0.0]]), is_min=[True], layout="float32", range_m=3.0)
    assert decode_message(min_at_zero, range_m=3.0)[1].tolist() == [True]


@pytest.mark.parametrize("layout", ["compact", "float32"])
def test_every_single_byte_corruption_and_truncation_is_rejected(layout):
    sigma, mins = random_sigma(np.random.default_rng(1), 8)
    data = encode_sigma(sigma, is_min=mins, layout=layout, range_m=3.0)
    for i in range(len(data)):
        for flip in (0x01, 0x80, 0xFF):
            bad = bytearray(data)
            bad[i] ^= flip
            with pytest.raises(MessageError):
                decode_message(bytes(bad), range_m=3.0)
    for cut in range(len(data)):
        with pytest.raises(MessageError):
            decode_message(data[:cut], range_m=3.0)


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (b"\xc1\x00", "message truncated: 2 bytes, a message has at least 4"),
        (b"GET / HTTP/1.1", "not an fftnav Sigma message or unsupported version: first byte 0x47"),
        (b"\xc2\x00\x00\x00", "unsupported version: first byte 0xc2"),
        (b"\xc1\x02\x00\x00\x00\x00", r"message length 6 does not match 10 bytes for n=2"),
        (b"\xc1\x00\x00\x00", "message corrupted: CRC-16 mismatch"),
        ("text", "message must be bytes, got str"),
    ],
)
def test_bad_messages(data, match):
    with pytest.raises(MessageError, match=match):
        decode_message(data, range_m=3.0)


@pytest.mark.parametrize(
    ("sigma", "kwargs", "match"),
    [
        (np.zeros((2, 3)), {}, r"sigma must have shape \(n, 2\) .* got shape=\(2, 3\)"),
        (np.zeros((256, 2)), {}, r"n <= 255 per message, got shape=\(256, 2\)"),
        (np.array([[0.0, 4.0]]), {}, r"distances in \[0, range_m=3.0\]"),
        (np.array([[np.nan, 1.0]]), {}, "sigma must hold finite angles"),
        (np.zeros((1, 2)), {"layout": "zip"}, "layout must be one of .* got layout='zip'"),
        (
            np.zeros((1, 2)),
            {"range_m": -1.0},
            "range_m must be a finite number > 0, got range_m=-1.0",
        ),
        (np.zeros((2, 2)), {"is_min": [True]}, r"is_min must have shape \(2,\), got shape=\(1,\)"),
    ],
)
def test_bad_encoder_input(sigma, kwargs, match):
    kwargs = {"range_m": 3.0, **kwargs}
    with pytest.raises(ValueError, match=match):
        encode_sigma(sigma, **kwargs)


@pytest.mark.parametrize("layout", ["compact", "float32"])
def test_pack_messages_equals_encode_batch_and_checks_the_count(layout):
    from fftnav.observe.codec import encode_batch, pack_messages

    rng = np.random.default_rng(7)
    counts = [0, 3, 8, 0, 1, 12]
    sigma, mins = random_sigma(rng, sum(counts))
    offsets = np.cumsum([0] + counts)
    packed = pack_messages(sigma, mins, counts, layout=layout, range_m=3.0)
    assert packed == encode_batch(sigma, mins, offsets, layout=layout, range_m=3.0)
    for k, msg in enumerate(packed):
        got, got_min = decode_message(msg, range_m=3.0)
        np.testing.assert_array_equal(got_min, mins[offsets[k] : offsets[k + 1]])
        assert len(got) == counts[k]
    with pytest.raises(ValueError, match="a message holds n <= 255 extrema, got n=256"):
        pack_messages(np.zeros((256, 2)), np.zeros(256, bool), [256], layout=layout, range_m=3.0)
