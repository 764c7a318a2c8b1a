"""The physical side: MJCF from the spec, playback, contact CoP, events, one trial.

Importing this package routes MuJoCo's warnings (e.g. "Nan, Inf or huge value in
QACC") to the ``slopewalk.mujoco`` logger at INFO level. MuJoCo's default handler
prints them to stdout and appends them to ``MUJOCO_LOG.TXT`` in the working
directory, which litters wherever the user stands; the trial reports what such a
warning means (a ``diverged`` event, from the simulated state) in its own words.
"""

import logging

import mujoco

_log = logging.getLogger("slopewalk.mujoco")


def _mujoco_warning(message: str) -> None:
    _log.info("MuJoCo warning: %s", message)


mujoco.set_mju_user_warning(_mujoco_warning)
