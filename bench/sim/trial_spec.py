"""What to simulate: a gait on a plane of friction μ with an actuator mode (``TrialSpec``).

Its own module so that the trial (``trial.py``), the closed loop (``closed_loop.py``)
and the ``dm_env`` environment (``env.py``) all read it without importing each other.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slopewalk.bench.controllers import check_controller_name
from slopewalk.bench.sim.model import SceneError, check_scene_options
from slopewalk.planner.gait import GaitParams

MAX_COMMAND_NOISE_DEG = 0.5  # [deg]: beyond, not a probe of the last bits
MAX_COMMAND_NOISE = float(np.deg2rad(MAX_COMMAND_NOISE_DEG))  # [rad]


def check_command_noise(sigma) -> None:
    """Raise one SceneError line unless ``sigma`` [rad] is a number in [0, MAX_COMMAND_NOISE]."""
    if isinstance(sigma, bool) or not isinstance(sigma, int | float | np.floating):
        raise SceneError(f"command_noise {sigma!r}: must be a number of radians")
    if not 0 <= sigma <= MAX_COMMAND_NOISE:
        raise SceneError(
            f"command_noise {sigma!r} rad: must lie in [0, {MAX_COMMAND_NOISE:.4g}] rad (0.5 deg)"
        )


@dataclass(frozen=True)
class TrialSpec:
    """What to simulate: a gait (``GaitParams``) on a plane of friction μ with an actuator mode.

    Attributes:
        gait: Step time, slope [rad], Hz, lift, tilt, steps.
        friction: Coulomb μ of the feet on the plane, > 0.
        actuators: "stiff", "servo", "stiff_ff" or "servo_ff".
        timestep: Simulation step [s].
        controller: ``MODULE:CALLABLE`` of a closed-loop controller (observation -> action,
            ``slopewalk.bench.sim.env``), or None: the plan played open loop by ``mujoco.rollout``.
        command_noise: σ of white noise on every open-loop command row [rad], in
            [0, ``MAX_COMMAND_NOISE``] (``playback.noisy``); 0: none.
        noise_seed: Seed of that noise, ≥ 0.
    """

    gait: GaitParams
    friction: float = 1.0
    actuators: str = "stiff"
    timestep: float = 0.001
    controller: str | None = None
    command_noise: float = 0.0
    noise_seed: int = 0

    def __post_init__(self) -> None:
        if self.controller is not None:
            check_controller_name(self.controller)
        check_command_noise(self.command_noise)
        if self.command_noise and self.controller is not None:
            raise SceneError(
                f"command_noise {self.command_noise!r} rad with controller "
                f"{self.controller!r}: noise is for the plan played open loop"
            )
        seed = self.noise_seed
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            raise SceneError(f"noise_seed {seed!r}: must be an integer >= 0")
        if not 0 < self.timestep <= 0.005:
            raise SceneError(f"timestep {self.timestep!r} s: must lie in (0, 0.005]")
        check_scene_options(
            slope=self.gait.slope,
            friction=self.friction,
            actuators=self.actuators,
            timestep=self.timestep,
        )
