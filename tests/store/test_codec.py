"""Encoder logs are stored compactly and come back bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from odolab.core.errors import StoreError
from odolab.core.trials import EncoderLog
from odolab.store.codec import EncodedLog, decode_log, encode_log

int64s = hnp.arrays(np.int64, st.integers(0, 60), elements=st.integers(-(2**63), 2**63 - 1))


@given(data=st.data(), left=int64s)
def test_round_trip_is_exact_for_any_int64_and_float64(
    data: st.DataObject, left: np.ndarray
) -> None:
    n = left.size
    right = data.draw(hnp.arrays(np.int64, n, elements=st.integers(-(2**63), 2**63 - 1)))
    t = data.draw(hnp.arrays(np.float64, n, elements=st.floats(allow_nan=True)))
    modulus = data.draw(st.one_of(st.none(), st.integers(2, 2**40)))
    back = decode_log(encode_log(EncoderLog(t, left, right, modulus)))
    assert back.t.tobytes() == t.tobytes()
    assert back.left_ticks.dtype == np.int64
    assert np.array_equal(back.left_ticks, left)
    assert np.array_equal(back.right_ticks, right)
    assert back.modulus == modulus


def test_a_real_looking_log_compresses_well() -> None:
    rng = np.random.default_rng(7)
    n = 6000  # 5 minutes at 20 Hz
    t = np.arange(n) * 0.05
    left = (np.cumsum(rng.integers(20, 30, n)) + 32000) % 32768
    right = (np.cumsum(rng.integers(20, 30, n)) + 100) % 32768
    enc = encode_log(EncoderLog(t, left, right, 32768))
    stored = len(enc.t) + len(enc.left_ticks) + len(enc.right_ticks)
    assert stored < 0.25 * 3 * 8 * n  # int64/float64 raw would be 144 kB
    back = decode_log(enc)
    assert np.array_equal(back.left_ticks, left) and np.array_equal(back.right_ticks, right)


def test_corrupt_blob_is_a_store_error() -> None:
    enc = encode_log(EncoderLog(np.zeros(3), np.arange(3), np.arange(3)))
    with pytest.raises(StoreError, match="corrupt"):
        decode_log(enc._replace(t=b"not zlib"))
    with pytest.raises(StoreError, match="expected 32"):
        decode_log(enc._replace(n=4))
    with pytest.raises(StoreError, match="codec"):
        decode_log(EncodedLog(*enc)._replace(codec="gzip"))
