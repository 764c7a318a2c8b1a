"""A whole trial driven by a closed-loop controller through ``env.TrialEnv``.

``play_controller`` is the closed-loop counterpart of ``playback.play``: it runs
the environment over the whole trial (settle, walk, hold; a fall does not end it,
as it does not end a rollout) calling the controller once per control period,
and returns the same ``playback.Recording``. A controller that raises, or returns
an action that is not ``nu`` finite numbers, stops the trial with one
``ControllerError`` line naming the controller, the time and the fault.
"""

from __future__ import annotations

from collections.abc import Callable

from slopewalk.bench.controllers import ControllerError, load_controller
from slopewalk.bench.sim.env import ActionError, TrialEnv
from slopewalk.bench.sim.playback import Recording
from slopewalk.planner.plan import Plan
from slopewalk.planner.spec import RobotSpec


def play_controller(
    spec: RobotSpec, trial, plan: Plan, *, controller: Callable | None = None
) -> Recording:
    """Simulate ``trial`` with its controller (or ``controller``, already loaded).

    Args:
        spec: The robot.
        trial: A ``TrialSpec`` whose ``controller`` names ``MODULE:CALLABLE``.
        plan: The trial's plan.
        controller: The callable itself, if already loaded (``trial.controller`` names it).
    """
    name = trial.controller
    policy = controller if controller is not None else load_controller(name)
    env = TrialEnv(spec, trial, plan=plan, end_at_fall=False)
    step = env.reset()
    while not step.last():
        observation = step.observation
        try:
            action = policy(observation)
        except Exception as err:  # the user's code: one line, its type and message
            raise ControllerError(
                f"controller {name!r} raised {type(err).__name__} at t = "
                f"{float(observation['time']):.3f} s: {err}"
            ) from None
        try:
            step = env.step(action)
        except ActionError as err:
            raise ControllerError(
                f"controller {name!r} at t = {float(observation['time']):.3f} s: returned an {err}"
            ) from None
    return env.recording()
