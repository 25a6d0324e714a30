from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from odolab.core.encoders import EncoderUnwrapper, dticks_from_ticks, unwrap_ticks
from odolab.core.errors import EncoderJumpError, LogFormatError


@given(
    arrays(np.int64, st.integers(1, 80), elements=st.integers(-16000, 16000)),
    st.sampled_from([32768, 65536, 2**32]),
    st.integers(0, 2**32),
)
def test_unwrap_recovers_counts_batch_and_streaming(d, modulus, offset) -> None:  # type: ignore[no-untyped-def]
    d = d % (modulus // 2)  # keep each step inside what a wrap can represent
    true = np.cumsum(d) + offset
    raw = true % modulus
    un = unwrap_ticks(raw, modulus)
    np.testing.assert_array_equal(un - un[0], true - true[0])
    u = EncoderUnwrapper(modulus)
    inc = [u.update(int(v)) for v in raw]
    np.testing.assert_array_equal(np.array(inc[1:]), dticks_from_ticks(raw, modulus))


def test_backward_wrap_and_limit() -> None:
    assert list(dticks_from_ticks([1, 32767, 32760], 32768)) == [-2, -7]
    with pytest.raises(EncoderJumpError, match="between samples 0 and 1"):
        dticks_from_ticks([0, 5000], 32768, max_dticks=1000)
    u = EncoderUnwrapper(32768, 1000)
    u.update(0)
    with pytest.raises(EncoderJumpError):
        u.update(5000)


def test_non_integer_rejected() -> None:
    with pytest.raises(LogFormatError, match="expected an integer count"):
        unwrap_ticks([1.0, 2.5], None)
