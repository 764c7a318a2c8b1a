"""The kernel's branch-free sin/cos against libm's."""

import numpy as np
from numba import njit

from planner.kernel.trig import LIMIT, sincos, sincos_fixup


@njit
def _both(x):
    """sin and cos of every x the way the kernel takes them: sincos, then the fix-up."""
    w = np.empty(3 * x.size)
    n = x.size
    w[:n] = x
    for j in range(n):
        w[n + j], w[2 * n + j] = sincos(w[j])
    sincos_fixup(w, 0, n, 2 * n, n)
    return w[n : 2 * n], w[2 * n :]


def test_sincos_is_libm_to_the_last_bits_over_every_quadrant():
    rng = np.random.default_rng(0)
    quarter = np.arange(-400, 401) * np.pi / 4  # every octant's edges, both sides
    x = np.concatenate(
        [
            rng.uniform(-1.0, 1.0, 20_000),
            rng.uniform(-LIMIT, LIMIT, 20_000),
            (quarter[:, None] + [-1e-9, 0.0, 1e-9]).ravel(),
            [0.0, -0.0, 1e-300, -1e-300, LIMIT, -LIMIT],
        ]
    )
    s, c = _both(x)
    # an ulp or two of the result, absolute near a zero (|sin| ≤ 1)
    np.testing.assert_allclose(s, np.sin(x), rtol=0, atol=4e-16)
    np.testing.assert_allclose(c, np.cos(x), rtol=0, atol=4e-16)
    assert np.array_equal(np.signbit(s[np.sin(x) != 0]), np.signbit(np.sin(x)[np.sin(x) != 0]))


def test_sincos_leaves_large_arguments_to_libm_and_is_nan_where_libm_is():
    x = np.array([LIMIT * 1.5, -1e12, 3e300, np.inf, -np.inf, np.nan])
    s, c = _both(x)
    with np.errstate(invalid="ignore"):
        np.testing.assert_allclose(s, np.sin(x), rtol=0, atol=4e-16)  # NaN as libm's
        np.testing.assert_allclose(c, np.cos(x), rtol=0, atol=4e-16)
