"""A trial's own ``MjData`` as a dm_control ``Physics``, for those who work with dm_control.

slopewalk does not depend on dm-control: ``env.TrialEnv`` is a plain
``dm_env.Environment`` on the bench's own model (see its module doc), and dm-control
pins itself to the MuJoCo it was written for. dm-control 1.0.50 installs beside
MuJoCo 4.0 but fails at first use (its model wrapper reads ``MjModel.flex_vertedge``,
which 4.0 no longer has); with MuJoCo 3.17 it works. So where dm_control is
importable and works with the MuJoCo installed, ``TrialEnv.physics`` is a
``dm_control.mujoco.Physics`` on the environment's very ``MjData`` (``wrapper.MjData``
of a ``mujoco.MjData`` wraps it, never copies): its named indexing
(``physics.named.data.qpos["l_knee"]``) reads the state the environment steps, and
its rendering shows it. Elsewhere ``shared_physics`` raises ``PhysicsUnavailable``, one
line that says why.

Making a ``Physics`` runs ``mj_forward`` once with the actuators off (dm_control's
``after_reset``): it rewrites the quantities derived from the state (accelerations,
forces, sensors) but not the state, nor the solver's warm start, so the next
``mj_step`` of the episode is the one it would have been
(``tests/sim/test_dm_physics.py`` holds the episode equal bit for bit).
"""

from __future__ import annotations

import mujoco

from slopewalk.planner.errors import SlopewalkError

WORKS_WITH = "dm-control 1.0.50 works with mujoco 3.17"


class PhysicsUnavailable(SlopewalkError):
    """dm_control is not installed, or does not work with the MuJoCo installed."""


def shared_physics(data: mujoco.MjData):
    """A ``dm_control.mujoco.Physics`` on ``data`` itself (module doc).

    Raises:
        PhysicsUnavailable: dm_control cannot be imported, or fails on this MuJoCo.
    """
    try:
        from dm_control.mujoco import Physics, wrapper
    except Exception as err:  # not installed (ImportError), or broken on import
        raise PhysicsUnavailable(
            f"TrialEnv.physics needs dm_control, which slopewalk does not install "
            f"({_one_line(err)}); {WORKS_WITH} (README, 'dm_control')"
        ) from None
    try:
        physics = Physics(wrapper.MjData(data))
    except Exception as err:
        raise PhysicsUnavailable(
            f"dm-control {_version()} does not work with mujoco {mujoco.__version__} "
            f"({_one_line(err)}); {WORKS_WITH} (README, 'dm_control')"
        ) from None
    if physics.data.ptr is not data:  # a dm_control that copies would show a stale state
        raise PhysicsUnavailable(
            f"dm-control {_version()} copies the MjData it is given; {WORKS_WITH}"
        )
    return physics


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("dm-control")
    except PackageNotFoundError:
        return "(version unknown)"


def _one_line(err: BaseException) -> str:
    text = " ".join(str(err).split())
    return f"{type(err).__name__}: {text}" if text else type(err).__name__
