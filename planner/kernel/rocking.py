"""The rocking of the support through time, compiled: ``tipping.rocking``'s per-sample loop.

``tipping._rocking_loop`` is the readable reference (held equal, bit for bit on the walks
drawn, by tests/planner/test_kernel_rocking.py): the same statements in the same order,
so the same IEEE arithmetic (numba compiles without fast-math, so without reassociation
or fused multiply-adds). Python's ``min``/``max`` are spelled out as their comparisons
(``max(a, b)`` is ``b if b > a else a``), which keeps what they do with a NaN. The
per-series inputs (the support lines, their inertias and gravity stiffnesses, the
floor's give) are computed by ``tipping.rocking`` in numpy, once per walk; only the
loop, ~6 ms per walk in Python, runs here (~0.05 ms).

Units as the reference: rad, rad/s, m, N, kg m², N m/rad, s.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_KW = {"cache": True, "error_model": "numpy", "nogil": True}


@njit(**_KW)
def _restitution(mass, com, old_line, new_line, new_inertia):
    """``tipping.landing_restitution``: θ̇⁺ / θ̇⁻ of the landing on ``new_line``, ≥ 0."""
    r = 1.0 - mass * (old_line - new_line) * (com - new_line) / new_inertia
    return 0.0 if 0.0 > r else r  # Python's max(r, 0.0)


@njit(**_KW)
def rocking_loop(
    lines, inertia, stiffness, z, normal, com, compliance, centroid, flat_give, reach, single,
    height, dt, mass, fallen, props,
):  # fmt: skip
    """θ + θ_g at each sample [rad], (n,): ``tipping._rocking_loop`` (arguments as there).

    lines, inertia, stiffness: (2, n), row 0 the lower line's, row 1 the upper's;
    reach: the swing sole's (lower, upper) edge, (2, n); single: single support, (n,) bool;
    props: (n,) bool, set True where the swing sole props the rotation.
    """
    n = z.shape[0]
    theta = np.zeros(n)
    x, v = 0.0, 0.0
    for k in range(n):
        lower, upper = lines[0, k], lines[1, k]
        if x == 0.0 and v == 0.0:  # flat: starts only with the ZMP past a line
            if lower <= z[k] and z[k] <= upper:
                theta[k] = flat_give[k]
                continue
            side = 1 if z[k] > upper else 0
        else:
            side = 1 if x > 0.0 or (x == 0.0 and v > 0.0) else 0
        e = lines[side, k]
        give = compliance[k] * (e - centroid[k])
        drive = normal[k] * (z[k] - e) + stiffness[side, k] * (x + give)
        v += drive / inertia[side, k] * dt[k]
        moved = x + v * dt[k]
        sign = 1.0 if side else -1.0
        if moved * sign <= 0.0:
            other = 1 - side
            e_new = lines[other, k]
            v = _restitution(mass, com[k], e, e_new, inertia[other, k]) * v
            pull = normal[k] * (z[k] - e_new) / inertia[other, k] * dt[k]
            x = 0.0
            if v == 0.0 or (v + pull) * v <= 0.0:
                v = 0.0
        else:
            x = moved
        if single[k] and x != 0.0:
            beyond = (reach[1, k] - upper) if x > 0 else (lower - reach[0, k])
            if beyond > 0.0 and abs(x) * beyond > height[k]:
                x = math.copysign(height[k] / beyond, x)
                props[k] = True
                if x > 0:
                    v = 0.0 if 0.0 < v else v  # min(v, 0.0)
                else:
                    v = 0.0 if 0.0 > v else v  # max(v, 0.0)
                if x == 0.0:
                    v = 0.0
        x = -fallen if -fallen > x else x  # max(x, -FALLEN)
        x = fallen if fallen < x else x  # min(x, FALLEN)
        theta[k] = x + (give if x != 0.0 or v != 0.0 else flat_give[k])
    return theta
