"""odolab.core.distributions gives scipy.stats' values to the bit, without importing scipy.stats
(about a second of every command that needs a quantile)."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core import distributions as d

probs = st.floats(1e-6, 1 - 1e-6)
dofs = st.floats(0.5, 500.0)


@given(p=probs, k=dofs)
def test_chi2_ppf_is_scipy_s(p: float, k: float) -> None:
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    assert d.chi2_ppf(p, k) == float(stats.chi2.ppf(p, k))


@given(x=st.floats(-1.0, 2000.0), k=dofs)
def test_chi2_sf_is_scipy_s(x: float, k: float) -> None:
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    assert d.chi2_sf(x, k) == float(stats.chi2.sf(x, k))


@given(q=probs, k=st.floats(1.0, 500.0))
def test_t_ppf_is_scipy_s(q: float, k: float) -> None:
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    assert d.t_ppf(q, k) == float(stats.t.ppf(q, k))


@given(x=st.floats(-1.0, 100.0), dfn=st.integers(1, 20), dfd=st.integers(1, 200))
def test_f_sf_is_scipy_s(x: float, dfn: int, dfd: int) -> None:
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    assert d.f_sf(x, dfn, dfd) == float(stats.f.sf(x, dfn, dfd))


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(
    ("name", "args"),
    [
        ("chi2_ppf", (0.975, 0)), ("chi2_ppf", (0.975, NAN)), ("chi2_ppf", (0.0, 3)),
        ("chi2_ppf", (1.0, 3)), ("chi2_ppf", (NAN, 3)), ("chi2_sf", (NAN, 3)),
        ("chi2_sf", (INF, 3)), ("chi2_sf", (0.0, 0)), ("chi2_sf", (5.0, 0)),
        ("chi2_sf", (5.0, INF)), ("t_ppf", (0.975, 0)), ("t_ppf", (0.975, INF)),
        ("t_ppf", (0.975, NAN)), ("f_sf", (2.0, 1, 0)), ("f_sf", (0.0, 1, 0)),
        ("f_sf", (-1.0, 2, 5)),
    ],
)  # fmt: skip
def test_the_edges_are_scipy_s(name: str, args: tuple[float, ...]) -> None:
    """Degrees of freedom of 0, NaN or infinity and probabilities at 0 and 1 as scipy.stats."""
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    dist, fn = name.split("_")
    want = float(getattr(getattr(stats, dist), fn)(*args))
    got = getattr(d, name)(*args)
    assert got == want or (math.isnan(got) and math.isnan(want)), (got, want)


def test_norm_pdf_and_fit_are_scipy_s() -> None:
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    rng = np.random.default_rng(5)
    data = rng.normal(0.3, 2.0, 101)
    assert d.norm_fit(data) == tuple(float(v) for v in stats.norm.fit(data))
    xs = np.linspace(-6, 6, 301)
    np.testing.assert_array_equal(d.norm_pdf(xs, 0.3, 2.0), stats.norm.pdf(xs, 0.3, 2.0))


@pytest.mark.parametrize("what", ["consistency", "compare", "slipfit", "noise", "random"])
def test_the_quantiles_do_not_import_scipy_stats(what: str) -> None:
    """The modules that only need quantiles or a normality test leave scipy.stats unimported
    (`odolab analyze` of the demo's notebook: 2.03-2.25 s before, 1.25-1.41 s after)."""
    code = {
        "consistency": "import numpy as np; from odolab.metrics.consistency import RunNees, "
        "nees_summary; nees_summary([RunNees('r', 1.0, 0.0, np.full(5, 3.0), np.zeros((5, 3)), "
        "np.ones(5))])",
        "compare": "import numpy as np; from odolab.calibration.compare import _t_interval; "
        "_t_interval(np.array([1.0, 2.0, 3.0]))",
        "slipfit": "from odolab.calibration.slipfit import nees_bounds; nees_bounds(9, 3)",
        "noise": "from odolab.analysis.noise import _scrub_fit, record_rotation; "
        "_scrub_fit([record_rotation(0.01 * i, 6.0, 0.5) for i in range(1, 6)], 1e-4, 1e-4)",
        "random": "import numpy as np; from odolab.analysis.random import random_error; "
        "random_error(np.arange(10.0) ** 2 - 30.0, 9)",
    }[what]
    out = subprocess.run(
        [sys.executable, "-c", f"{code}; import sys; print('scipy.stats' in sys.modules)"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert out.stdout.strip() == "False", out.stderr


@pytest.mark.parametrize("n", [3, 4, 5, 6, 7, 11, 12, 13, 20, 50, 200, 1000])
def test_shapiro_wilk_is_scipy_s(n: int) -> None:
    """Royston's AS R94 in double precision against scipy's (single precision inside)."""
    from scipy import stats  # (0.7-0.95 s to import: when a test needs it)

    rng = np.random.default_rng(n)
    worst_w = worst_p = 0.0
    for sample in (rng.normal(size=n), rng.exponential(size=n), rng.uniform(size=n) ** 3):
        w, p = d.shapiro_wilk(sample)
        ref = stats.shapiro(sample)
        worst_w = max(worst_w, abs(w - float(ref.statistic)))
        worst_p = max(worst_p, abs(p - float(ref.pvalue)))
    # measured at most 3.9e-9 (W) and 1.8e-7 (p) over sizes 3-5,000 and four shapes: scipy's
    # float32 arithmetic; bound 1e-5
    assert worst_w < 1e-5 and worst_p < 1e-5, (worst_w, worst_p)
