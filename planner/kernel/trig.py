"""sin and cos of one argument in branch-free arithmetic, so a loop of them vectorises.

A call of libm's ``sin``/``cos`` in a loop keeps the loop scalar (numba's SVML
path, which would vectorise them, needs an llvmlite built with SVML: the wheels of
llvmlite 0.50 are not). ``sincos`` is fdlibm's algorithm (``__kernel_sin``,
``__kernel_cos`` on [−π/4, π/4] after a Cody-Waite reduction by multiples of π/2),
with selects in place of its branches; within an ulp or two of libm for
|x| ≤ ``LIMIT``, NaN for ±inf and NaN as libm's. Larger arguments are libm's
(``sincos_fixup``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

LIMIT = 1.0e5  # [rad] beyond this, the two-part reduction loses digits: use libm

_TWO_OVER_PI = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00  # first 33 bits of π/2
_PIO2_1T = 6.07710050650619224932e-11  # π/2 − _PIO2_1
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11

_KW = {"cache": True, "error_model": "numpy", "nogil": True}


@njit(inline="always", **_KW)
def sincos(x):
    """(sin x, cos x) for |x| ≤ ``LIMIT`` [rad] or non-finite; others: ``sincos_fixup``."""
    k = np.floor(x * _TWO_OVER_PI + 0.5)  # x = k π/2 + r, |r| ≤ π/4
    r = (x - k * _PIO2_1) - k * _PIO2_1T
    z = r * r
    s = r + (z * r) * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    p = z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    hz = 0.5 * z
    v = 1.0 - hz
    c = v + (((1.0 - v) - hz) + p)
    q = k - 4.0 * np.floor(0.25 * k)  # quadrant 0..3, in floats (no int conversion)
    odd = (q == 1.0) | (q == 3.0)
    sn, cs = (c if odd else s), (s if odd else c)
    return (-sn if q >= 2.0 else sn), (-cs if (q == 1.0) | (q == 2.0) else cs)


@njit(**_KW)
def sincos_fixup(w, x, sn, cs, n):
    """libm's sin and cos into w[sn + j], w[cs + j] where x = w[x + j] is beyond ``LIMIT``,
    j < n (row offsets into one flat array)."""
    for j in range(n):
        a = w[x + j]
        if abs(a) > LIMIT:
            w[sn + j], w[cs + j] = np.sin(a), np.cos(a)
