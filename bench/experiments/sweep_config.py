"""A sweep file: the TOML grid (or list) of trials, checked whole before any trial runs.

Format (degrees at this edge, like the CLI)::

    description = "what this sweep is for"   # optional, free text
    steps = 4          # steps per walk, >= 1 (4)
    seed = 0           # recorded with every row, >= 0 (0)

    [grid]             # the product of these lists; a key left out takes its default
    step_time = [1.0, 0.5]                 # [s], > 0 (1.0, the nominal step time)
    slope = [0, 10]                        # [deg], in (-60, 60) (0)
    friction = [0.6, 1.0]                  # Coulomb mu, > 0 (1.0)
    actuators = ["stiff"]                  # "stiff" or "servo" ("stiff")
    robot = ["short_legs.toml"]            # spec files, relative to this file (the paper's biped)
    mass_scale = [{}, {all = 10}, {legs = 2}]   # per link-group factors, > 0 ({} = none)

    [[trial]]          # single trials beside (or instead of) the grid: same keys, scalars
    step_time = 0.4
    friction = 0.4

``[[grid]]`` may also be an array of tables; the sweep is the union of their
products and the ``[[trial]]`` entries, de-duplicated by ``trial_id`` (first
occurrence kept, in file order).

Mass-scale groups: ``all``, ``pelvis``, ``legs`` (thigh, shank, ankle and foot of
both legs) and the link names ``thigh``, ``shank``, ``ankle``, ``foot``; a
link's factor is the product of the factors of the groups that hold it, so
``{all = 10, legs = 2}`` makes the legs 20 times heavier. Masses and inertias
scale together. The paper's "doubled swing leg" has no fixed body in an
alternating walk (each leg swings every other step), so it is written
``{legs = 2}``: both legs doubled.

``trial_id`` is a stable hash of everything that decides a trial's outcome: the
gait inputs, μ, actuators, steps, seed, the simulation step and the *contents*
of the (scaled) robot spec, not its path; editing a spec file gives new ids.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import asdict, dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from bench.sim.model import ACTUATOR_MODES
from bench.sim.trial import TrialSpec
from planner.errors import SlopewalkError
from planner.spec import LINK_NAMES, RobotSpec, load_spec
from planner.trajectory import GaitParams

SWEEPS_DIR = Path(__file__).parent / "sweeps"
DEFAULT_SWEEP = SWEEPS_DIR / "paper.toml"
TIMESTEP = 0.001  # [s], the simulation step of every sweep trial
TOP_KEYS = ("description", "steps", "seed", "grid", "trial")
TRIAL_KEYS = ("step_time", "slope", "friction", "actuators", "robot", "mass_scale")
DEFAULTS = {
    "step_time": 1.0,
    "slope": 0.0,
    "friction": 1.0,
    "actuators": "stiff",
    "robot": "default",
    "mass_scale": {},
}
LEGS = tuple(name for name in LINK_NAMES if name != "pelvis")
MASS_GROUPS = {"all": LINK_NAMES, "pelvis": ("pelvis",), "legs": LEGS} | {
    name: (name,) for name in LEGS
}


class SweepError(SlopewalkError):
    """A sweep file with an unknown key, a bad value or a missing robot file."""


@dataclass(frozen=True)
class SweepTrial:
    """One trial of a sweep, with its inputs as written in the sweep file.

    Attributes:
        step_time: Step completion time [s].
        slope_deg: Plane inclination [deg].
        friction: Coulomb μ of the feet on the plane.
        actuators: "stiff" or "servo".
        robot: The spec path as written in the file, or "default".
        mass_scale: (group, factor) pairs in file order; () = no scaling.
        steps: Steps per walk.
        seed: The sweep's seed, recorded with the row.
        spec: The robot, mass scaling applied.
    """

    step_time: float
    slope_deg: float
    friction: float
    actuators: str
    robot: str
    mass_scale: tuple[tuple[str, float], ...]
    steps: int
    seed: int
    spec: RobotSpec = field(repr=False, compare=False)

    @cached_property
    def trial_id(self) -> str:
        """12 hex digits of a SHA-256 over the inputs that decide the outcome (module doc)."""
        key = {
            "step_time": self.step_time,
            "slope_deg": self.slope_deg,
            "friction": self.friction,
            "actuators": self.actuators,
            "steps": self.steps,
            "seed": self.seed,
            "timestep": TIMESTEP,
            "spec": asdict(self.spec),
        }
        text = json.dumps(key, sort_keys=True, default=float)
        return hashlib.sha256(text.encode()).hexdigest()[:12]

    @property
    def mass_scale_text(self) -> str:
        """``"legs=2"``, ``"all=10;legs=2"``, or ``"none"``."""
        return ";".join(f"{g}={f:g}" for g, f in self.mass_scale) or "none"

    @property
    def label(self) -> str:
        """Short human description, e.g. ``T=0.5 s slope=0 mu=0.6``."""
        text = f"T={self.step_time:g} s slope={self.slope_deg:g} mu={self.friction:g}"
        if self.actuators != "stiff":
            text += f" {self.actuators}"
        if self.mass_scale:
            text += f" mass {self.mass_scale_text}"
        if self.robot != "default":
            text += f" robot {self.robot}"
        return text

    def gait(self) -> GaitParams:
        """The nominal gait of this trial (radians from here on)."""
        return GaitParams.nominal(
            self.spec, self.step_time, slope=float(np.deg2rad(self.slope_deg)), steps=self.steps
        )

    def trial_spec(self) -> TrialSpec:
        return TrialSpec(
            self.gait(), friction=self.friction, actuators=self.actuators, timestep=TIMESTEP
        )

    def inputs(self) -> dict:
        """The input columns of this trial's row."""
        return {
            "trial_id": self.trial_id,
            "step_time": self.step_time,
            "slope_deg": self.slope_deg,
            "friction": self.friction,
            "actuators": self.actuators,
            "robot": self.robot,
            "mass_scale": self.mass_scale_text,
            "steps": self.steps,
            "seed": self.seed,
        }


@dataclass(frozen=True)
class SweepConfig:
    """A parsed sweep file: its trials, unique by ``trial_id``, in file order."""

    source: str
    steps: int
    seed: int
    trials: tuple[SweepTrial, ...]
    description: str = ""


def load_sweep(path: str | Path | None = None) -> SweepConfig:
    """Read and check a sweep file (default: ``bench/experiments/sweeps/paper.toml``).

    Raises:
        SweepError: unreadable file, unknown key, value out of range or missing
            robot file, in one line naming the key.
    """
    path = Path(path) if path is not None else DEFAULT_SWEEP
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except (FileNotFoundError, IsADirectoryError):
        raise SweepError(f"sweep file {str(path)!r}: no such file") from None
    except tomllib.TOMLDecodeError as err:
        raise SweepError(f"sweep file {str(path)!r}: not valid TOML ({err})") from None
    return sweep_from_dict(data, base_dir=path.parent, source=str(path))


def sweep_from_dict(data: dict, *, base_dir: Path, source: str = "<dict>") -> SweepConfig:
    """Build a SweepConfig from parsed TOML; robot paths are relative to ``base_dir``."""
    _known(data, TOP_KEYS, "", source)
    steps = data.get("steps", 4)
    seed = data.get("seed", 0)
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise SweepError(f"{source}: steps = {steps!r}: must be an integer >= 1")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise SweepError(f"{source}: seed = {seed!r}: must be an integer >= 0")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise SweepError(f"{source}: description = {description!r}: must be a string")
    grids = _tables(data, "grid", source)
    singles = _tables(data, "trial", source)
    if not grids and not singles:
        raise SweepError(f"{source}: no trials: give a [grid] table or [[trial]] entries")
    robots: dict[str, RobotSpec] = {}
    combos: list[tuple[str, dict]] = []
    for where, table in grids:
        _known(table, TRIAL_KEYS, f"{where}.", source)
        axes = {}
        for key in TRIAL_KEYS:
            values = table.get(key, [DEFAULTS[key]])
            if not isinstance(values, list) or not values:
                raise SweepError(f"{source}: {where}.{key} = {values!r}: must be a non-empty list")
            axes[key] = values
        combos += [(where, dict(zip(TRIAL_KEYS, c, strict=True))) for c in _product(axes)]
    for where, table in singles:
        _known(table, TRIAL_KEYS, f"{where}.", source)
        combos.append((where, {key: table.get(key, DEFAULTS[key]) for key in TRIAL_KEYS}))
    trials: dict[str, SweepTrial] = {}
    for where, values in combos:
        trial = _trial(values, steps, seed, robots, base_dir, f"{source}: {where}")
        trials.setdefault(trial.trial_id, trial)
    return SweepConfig(source, steps, seed, tuple(trials.values()), description)


def _product(axes: dict[str, list]):
    return itertools.product(*(axes[key] for key in TRIAL_KEYS))


def _known(table: dict, allowed: tuple[str, ...], prefix: str, source: str) -> None:
    for key in table:
        if key not in allowed:
            raise SweepError(f"{source}: unknown key {prefix}{key} (allowed: {', '.join(allowed)})")


def _tables(data: dict, key: str, source: str) -> list[tuple[str, dict]]:
    """``[key]`` or ``[[key]]`` as (name for messages, table) pairs."""
    value = data.get(key)
    if value is None:
        return []
    if isinstance(value, dict):
        return [(key, value)]
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        return [(f"{key}[{i}]", v) for i, v in enumerate(value)]
    raise SweepError(f"{source}: {key} must be a table [{key}] or an array of tables [[{key}]]")


def _trial(values, steps, seed, robots, base_dir, where) -> SweepTrial:
    step_time = _number(values["step_time"], "step_time", where)
    if not step_time > 0:
        raise SweepError(f"{where}.step_time = {step_time:g} s: must be > 0")
    slope = _number(values["slope"], "slope", where)
    if not -60 < slope < 60:
        raise SweepError(f"{where}.slope = {slope:g} deg: must lie in (-60, 60) deg")
    friction = _number(values["friction"], "friction", where)
    if not friction > 0:
        raise SweepError(f"{where}.friction = {friction:g}: must be > 0")
    actuators = values["actuators"]
    if actuators not in ACTUATOR_MODES:
        raise SweepError(
            f"{where}.actuators = {actuators!r}: must be one of {', '.join(ACTUATOR_MODES)}"
        )
    robot = values["robot"]
    if not isinstance(robot, str) or not robot:
        raise SweepError(f"{where}.robot = {robot!r}: must be a spec file path")
    if robot not in robots:
        path = None if robot == "default" else base_dir / robot
        try:
            robots[robot] = load_spec(path)
        except SlopewalkError as err:
            raise SweepError(f"{where}.robot: {err}") from None
    scale = _mass_scale(values["mass_scale"], where)
    spec = robots[robot]
    if scale:
        factors = dict.fromkeys(LINK_NAMES, 1.0)
        for group, factor in scale:
            for name in MASS_GROUPS[group]:
                factors[name] *= factor
        spec = spec.with_mass_scale(factors)
    trial = SweepTrial(step_time, slope, friction, actuators, robot, scale, steps, seed, spec)
    try:
        trial.trial_spec()  # the gait's own range checks (e.g. dt <= step_time/10)
    except SlopewalkError as err:
        raise SweepError(f"{where}: {err}") from None
    return trial


def _number(value, key: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SweepError(f"{where}.{key} = {value!r}: must be a finite number")
    return float(value)


def _mass_scale(value, where: str) -> tuple[tuple[str, float], ...]:
    if not isinstance(value, dict):
        raise SweepError(
            f"{where}.mass_scale = {value!r}: must be an inline table like {{legs = 2}}"
        )
    out = []
    for group, factor in value.items():
        if group not in MASS_GROUPS:
            raise SweepError(
                f"{where}.mass_scale: unknown group {group!r} (allowed: {', '.join(MASS_GROUPS)})"
            )
        factor = _number(factor, f"mass_scale.{group}", where)
        if not factor > 0:
            raise SweepError(f"{where}.mass_scale.{group} = {factor:g}: must be > 0")
        out.append((group, factor))
    return tuple(out)
