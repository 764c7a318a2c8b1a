"""slopewalk: does an analytic prediction of a biped's balance hold up in MuJoCo?

The public API, in the order of the data flow (README, "Python API"):

* ``load_spec(path=None) -> RobotSpec``: a robot spec (TOML); None is the paper's Bioloid.
* ``GaitParams(step_time, slope=0.0, ...)``: what to walk. **Radians and SI units**:
  ``slope`` and ``tilt`` are radians (the CLI's ``--slope 10`` is ``math.radians(10)``),
  lengths metres, times seconds. ``GaitParams.nominal(spec, ...)`` scales the
  length defaults to another robot.
* ``plan_walk(spec, params) -> Plan``: the analytic walk (joint angles, torques, ZMP,
  margin, friction ratio, work); ``evaluate(spec, params, population)`` scores many gaits.
* ``TrialSpec(gait, friction=1.0, actuators="stiff", ...)`` and
  ``run_trial(spec, trial) -> TrialResult``: the plan played in MuJoCo and compared.
* ``load_sweep`` / ``run_sweep`` and ``load_envelope`` / ``run_envelope``: the
  ``slopewalk sweep`` and ``slopewalk envelope`` commands as functions.
* ``ACTUATOR_MODES``: the actuator modes a trial may name.
* ``SlopewalkError``: the base of every error the package raises on bad input.

The analytic side lives in ``slopewalk.planner`` (numpy, scipy and numba only, never
MuJoCo), the physical side in ``slopewalk.bench``. Names load on first use, so
``import slopewalk`` costs nothing and ``slopewalk.plan_walk`` does not import MuJoCo.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# public name -> the module that defines it (the one place each lives)
_API = {
    "SlopewalkError": "slopewalk.planner.errors",
    "RobotSpec": "slopewalk.planner.spec",
    "load_spec": "slopewalk.planner.spec",
    "GaitParams": "slopewalk.planner.gait",
    "Plan": "slopewalk.planner.plan",
    "plan_walk": "slopewalk.planner.plan",
    "evaluate": "slopewalk.planner.plan",
    "ACTUATOR_MODES": "slopewalk.bench.actuators",
    "TrialSpec": "slopewalk.bench.sim.trial_spec",
    "TrialResult": "slopewalk.bench.sim.trial",
    "run_trial": "slopewalk.bench.sim.trial",
    "load_sweep": "slopewalk.bench.experiments.sweep.config",
    "run_sweep": "slopewalk.bench.experiments.sweep.run",
    "load_envelope": "slopewalk.bench.experiments.envelope.config",
    "run_envelope": "slopewalk.bench.experiments.envelope.run",
}

__all__ = [
    "ACTUATOR_MODES",
    "GaitParams",
    "Plan",
    "RobotSpec",
    "SlopewalkError",
    "TrialResult",
    "TrialSpec",
    "evaluate",
    "load_envelope",
    "load_spec",
    "load_sweep",
    "plan_walk",
    "run_envelope",
    "run_sweep",
    "run_trial",
]

if TYPE_CHECKING:
    from slopewalk.bench.actuators import ACTUATOR_MODES
    from slopewalk.bench.experiments.envelope.config import load_envelope
    from slopewalk.bench.experiments.envelope.run import run_envelope
    from slopewalk.bench.experiments.sweep.config import load_sweep
    from slopewalk.bench.experiments.sweep.run import run_sweep
    from slopewalk.bench.sim.trial import TrialResult, run_trial
    from slopewalk.bench.sim.trial_spec import TrialSpec
    from slopewalk.planner.errors import SlopewalkError
    from slopewalk.planner.gait import GaitParams
    from slopewalk.planner.plan import Plan, evaluate, plan_walk
    from slopewalk.planner.spec import RobotSpec, load_spec


def __getattr__(name: str) -> Any:
    if name not in _API:
        raise AttributeError(f"module 'slopewalk' has no attribute {name!r}")
    value = getattr(importlib.import_module(_API[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
