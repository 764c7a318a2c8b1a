"""A command's kernel entries compiled side by side, in processes of their own, on a cold cache.

numba compiles one function at a time per process (its compiler lock), and most of a
compile is numba's own Python (type inference, inlining, lowering), not LLVM: a trial's
two entries, "plan" (``run.series``, ~17 s CPU) and "predictors" (``dynamics``,
``servo``, ``rocking``, ``whole_body``, ~21 s more in the same process), take ~39 s one
after the other.
``cache.prepare`` compiles the cold ones of a command's entries at once, one process each
(``compile_entry``, at most one per core), each writing what it compiles into numba's
cache, where the command then finds it: on 2 cores the wall time is about the longest
entry's, not the sum. The predictors' process first compiles what needs nothing of the
plan's kernel (the servo loop's ``integrate``, ``rocking``), then the dynamics, which
call the per-block stages of ``sample`` the plan's process compiles meanwhile and
caches (where it has not yet, both compile them: the same code, the later write wins).
Beside the plan's, a GA's scores' process (``slopewalk optimize``: "scores" and "plan")
compiles the stages the plan's does not (measured: the plan's process then 14 s of CPU,
finding them cached, where alone it takes ~18 s).

``compile_entry`` calls each entry's compiled functions on small inputs of the types the
predictors give them (tests/planner/test_kernel_warm.py holds a trial after it to
compile nothing new), so the predictors' process needs no plan, and no compiled
``series``, to get going.
"""

from __future__ import annotations

import numpy as np

from slopewalk.planner.kernel import cache

# The per-block stages of ``sample`` both entries call, as their callers type them. The
# plan's process compiles these first and caches them; the predictors' process compiles
# ``_outward`` meanwhile, then its own functions, which find the others cached by then.
_F1, _F2, _F3, _I1 = "float64[::1]", "float64[:, ::1]", "float64[:, :, ::1]", "int64[::1]"
_PLAN_STAGES = {
    "_kinematics": f"({_F1}, {_F1}, {_F1}, int64, {_F1})",
    "_inward": f"({_F1}, int64, int64, {_F1})",
    "write_rows": f"({_F1}, {_F1}, int64, {_F1}, {_F2}, {_I1})",
}
_PREDICTOR_STAGES = {"_outward": f"({_F3}, {_F2}, {_F1}, int64, {_F1})"}
# A GA's scores call the plan's stages through the same ``evaluate_loaded``: beside the
# plan's process (``slopewalk optimize``, ``bands``) the scores' compiles the others
_SCORES_STAGES = _PREDICTOR_STAGES | {
    "_gait_ik": f"({_F1}, {_F1}, {_F1}, int64, {_F1})",
    "_margin": f"({_F1}, int64, int64, {_F1})",
}


def _stages(signatures: dict[str, str]) -> None:
    """Compile (or load) the ``sample`` stages named, for their one signature each.

    numba keys its cache by the signature as given: a tuple of types, as a caller's
    compile passes it (a string would be cached under another key, never found)."""
    from numba.core import sigutils

    from slopewalk.planner.kernel import sample

    for name, signature in signatures.items():
        args, _ = sigutils.normalize_signature(signature)
        getattr(sample, name).compile(tuple(args))


def _predictors() -> None:
    """The predictors' compiled functions, each called once on a 3-sample walk at rest."""
    from slopewalk.planner.kernel import dynamics, rocking, servo, whole_body

    _stages(_PREDICTOR_STAGES)
    from slopewalk.planner.kernel.tables import ChainTable
    from slopewalk.planner.kinematics import Chain, gravity_in_slope
    from slopewalk.planner.spec import load_spec

    spec = load_spec()
    n, dof = 3, 8
    eye = np.repeat(np.eye(dof)[None], n, axis=0)
    zero = np.zeros((n, dof))
    stance = np.zeros(n, dtype=np.int64)
    both = np.zeros(n, dtype=np.bool_)
    dt = np.full(n, 1e-3)
    gains = (1.0, 0.0, 0.0, 0.0, 1.0, 1.0)  # kp, kv, damping, armature, τ_max, μ
    servo.integrate(
        eye, 0 * eye, 0 * eye, zero, zero, zero, dt, stance, both,
        np.zeros((n, 4, dof)), gains, np.zeros(dof),
    )  # fmt: skip
    body = 11  # the whole-body walk's x: the stance sole's z, roll, pitch and 8 joints
    square, corners = np.repeat(np.eye(body)[None], n, axis=0), np.zeros((n, 8))
    whole_body.integrate(
        square, 0 * square, np.zeros((n, 8, body)), corners, corners, corners,
        np.zeros((n, 3, body)), np.zeros((n, 3, body)), zero, 0 * eye, 0 * eye, zero, zero,
        dt, stance, both, both, gains[:5], (1.0, 0.0, 1.0), 0.5, np.zeros(body),
    )  # fmt: skip
    # the chain's own masses and inertias, read-only arrays as a trial passes them (a
    # writable stand-in compiled a type a trial never calls, and left each sweep worker
    # to compile the read-only one, ~4.7 s of CPU, at its first trial; stop 55)
    own, links = Chain.from_spec(spec), np.zeros((n, 9, 3))
    whole_body.mass_and_stiffness(
        own.mass, links, np.zeros((n, 9, 3, 3)), own.inertia, stance,
        np.zeros((n, 8, 3)), np.zeros((n, 8, 3)), np.zeros((n, 3)), links,
    )  # fmt: skip
    row, pair = np.zeros(n), np.zeros((2, n))
    lines = np.array([[-1.0] * n, [1.0] * n])
    rocking.rocking_loop(
        lines, pair + 1.0, pair, row, row, row, row, row, row, pair, ~both, row, dt, 1.0, 1.0,
        np.zeros(n, dtype=np.bool_),
    )  # fmt: skip
    t = ChainTable.of(spec)
    chain = (t.geometry, t.a, t.d5, t.mass, t.com, t.inertia)
    gravity = gravity_in_slope(0.0)
    sole, share = np.zeros((n, 3)), np.zeros(n)
    args = (chain, gravity, zero, zero, zero, stance, sole, share)
    servo.fixed_point(*args, zero, 1.0, 1e-7, 2)
    dynamics.linearised(*args, 1e-6)
    dynamics.rows(*args)


def compile_entry(name: str) -> None:
    """Compile (or load from the cache) entry ``name``'s functions in this process, and
    mark it (``cache.compiled``)."""
    from slopewalk.planner.gait import GaitParams
    from slopewalk.planner.spec import load_spec

    if name == "predictors":
        _predictors()
    else:
        from slopewalk.planner.plan import evaluate, plan_walk

        spec = load_spec()
        if name == "plan":
            _stages(_PLAN_STAGES)
            plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=1))
        else:
            _stages(_SCORES_STAGES)
            gait = GaitParams.nominal(spec, 1.0, steps=1, dt=0.01)
            evaluate(spec, gait, np.array([[0.2, 0.06, 0.2]]))
    cache.compiled(name)
