"""A sweep file: the TOML grid (or list) of trials, checked whole before any trial runs.

Format (degrees at this edge, like the CLI)::

    description = "what this sweep is for"   # optional, free text
    steps = 4          # steps per walk, >= 1 (4)
    seed = 0           # recorded with every row, >= 0, or a list of them: each trial per seed (0)
    command_noise = 0  # [deg], σ of white noise on every command row, in [0, 0.5] (0)
    spec_ends = ["servo.armature:low", "servo.armature:high"]   # optional (below)

    [grid]             # the product of these lists; a key left out takes its default
    step_time = [1.0, 0.5]                 # [s], > 0 (1.0, the nominal step time)
    slope = [0, 10]                        # [deg], in (-60, 60) (0)
    friction = [0.6, 1.0]                  # Coulomb mu, > 0 (1.0)
    actuators = ["stiff"]                  # modes of slopewalk.bench.actuators.MODES ("stiff")
    robot = ["short_legs.toml"]            # spec files, relative to this file (the paper's biped)
    mass_scale = [{}, {all = 10}, {legs = 2}]   # per link-group factors, > 0 ({} = none)
    # ("none": open loop)
    controller = ["none", "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback"]

    [[trial]]          # single trials beside (or instead of) the grid: same keys, scalars
    step_time = 0.4
    friction = 0.4

    [draw]             # optional: random gaits instead of the nominal one (held-out fidelity)
    family = ["paper", "extended"]   # gait families of planner.gait_search.FAMILIES
    gaits = 2          # gaits drawn per cell (step time x slope x mu x robot) and family, >= 1
    seed = 7           # the draw's seed, >= 0

    envelope = ["../../../results/envelope/envelope.csv"]   # optional, relative to this file

``[draw]`` replaces every trial's nominal gait by ``gaits`` gaits per family, each drawn
uniformly from the family's search box (``gait_search.gait_bounds`` of the trial's
robot, step time and slope), seeded by the draw's seed, the family, the gait's number
and the cell (step time, slope, μ, robot), so the same gait is played in every actuator
mode of the cell. ``envelope`` lists envelope tables (``slopewalk envelope``): every gait
of their rows that the envelope played (both objectives), at its cell's step time,
slope and μ, is a trial in every ``actuators`` mode of the ``[grid]`` (whose other keys
must be left out). Either makes the table's ``gait`` columns
(``tables.sweep.GAIT_COLUMNS``); neither goes with a controller or command noise.

``model`` and ``map`` (paths relative to the file; ``sweep --model MODEL --map MAP``
replaces both) play every trial on that unmodified MJCF/URDF model
(``robot_import.model_file.ModelFile``): ``robot`` then defaults to ``"imported"`` (the
spec imported from the model now; a path names an edited spec), ``actuators`` to
``"servo_ff"``; the paper's robot, ``mass_scale``, controllers and ``envelope`` are
refused, the model's digest enters every ``trial_id`` and the table gains the
``model`` and ``model_digest`` columns (``tables.table.model_format``).

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
of the (scaled) robot spec, not its path; editing a spec file gives new ids. A
``controller`` enters the hash only when one is set, so open-loop ids are the same
with or without the key; a sweep that names a controller anywhere gets a
``controller`` column in its table (``tables.sweep.CONTROLLER_COLUMNS``).

Command noise (``playback.noisy``) probes how much of a verdict the simulation's last
bits decide: with ``command_noise`` > 0 every open-loop trial's commands get white
noise of that σ, seeded by its ``trial_id``, so each seed of a list is a replica of
the sweep. The noise enters the hash only when set, and such a sweep's table has a
``command_noise_deg`` column (``tables.sweep.NOISE_COLUMNS``); it is refused beside a
controller (the closed loop's commands are its own).

Spec ends probe how much of a verdict the values the spec only estimates decide:
``spec_ends`` lists ``"KEY:low"``/``"KEY:high"`` (a key of every robot's ``[uncertain]``
table, ``planner/uncertainty.py``) and ``"nominal"``; each trial is played once per entry,
on its robot's spec with that one value at that end of its range (before any mass
scaling; a drawn gait is drawn on the nominal spec, so each replica walks the nominal
trial's gait). The changed spec gives new ids, and such a sweep's table has a ``spec_end``
column after every other (``tables.sweep.spec_end_format``), which ``slopewalk fidelity``
pairs with the nominal trial's rows in any table (``report/replicas.py``). Refused with a
model (its spec has no ``[uncertain]`` table).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np

from slopewalk.bench.actuators import DEFAULT_MODE, actuator_mode
from slopewalk.bench.experiments.sweep.trials import (  # noqa: F401 (TIMESTEP, SweepTrial: re-exported)
    AXES,
    NOMINAL,
    TIMESTEP,
    Body,
    Box,
    GaitChoice,
    SweepTrial,
    TrialSet,
    spec_text,
)
from slopewalk.bench.robot_import.model_file import ModelFile
from slopewalk.bench.sim.trial_spec import MAX_COMMAND_NOISE_DEG
from slopewalk.planner.config_file import load_toml
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.spec import LINK_NAMES, RobotSpec, load_spec
from slopewalk.planner.uncertainty import load_uncertainty, spec_at

SWEEPS_DIR = Path(__file__).parents[1] / "sweeps"  # bench/experiments/sweeps/
DEFAULT_SWEEP = SWEEPS_DIR / "paper.toml"
TOP_KEYS = ("description", "steps", "seed", "command_noise", "spec_ends", "draw", "envelope",
            "model", "map", "grid", "trial")  # fmt: skip
DRAW_KEYS = ("family", "gaits", "seed")
TRIAL_KEYS = ("step_time", "slope", "friction", "actuators", "robot", "mass_scale", "controller")
DEFAULTS = {
    "step_time": 1.0,
    "slope": 0.0,
    "friction": 1.0,
    "actuators": DEFAULT_MODE,
    "robot": "default",
    "mass_scale": {},
    "controller": "none",
}
OPEN_LOOP = "none"  # the controller key's value for the plan played open loop
IMPORTED = "imported"  # the robot key's default on a model: the spec imported from it now
MODEL_MODE = "servo_ff"  # the actuators key's default on a model (its own servos)
LEGS = tuple(name for name in LINK_NAMES if name != "pelvis")
MASS_GROUPS = {"all": LINK_NAMES, "pelvis": ("pelvis",), "legs": LEGS} | {
    name: (name,) for name in LEGS
}


class SweepError(SlopewalkError):
    """A sweep file with an unknown key, a bad value or a missing robot file."""


@dataclass(frozen=True)
class SweepConfig:
    """A parsed sweep file: its trials (a lazy ``TrialSet``, unique by ``trial_id``, file order)."""

    source: str
    steps: int
    seeds: tuple[int, ...]
    boxes: tuple[Box, ...] = field(repr=False)
    description: str = ""
    command_noise_deg: float = 0.0  # [deg]
    model: ModelFile | None = None  # every trial played on this model (``sweep --model``)
    spec_ends: tuple[str, ...] = ()  # the file's ``spec_ends`` (module doc); (): none

    @cached_property
    def trials(self) -> TrialSet:
        return TrialSet(self.boxes, self.steps, self.command_noise_deg, self.model)

    @property
    def noisy(self) -> bool:
        """The commands get noise (its table has a ``command_noise_deg`` column)."""
        return self.command_noise_deg > 0

    @property
    def other_gaits(self) -> bool:
        """Some trial walks a drawn or given gait (its table has ``GAIT_COLUMNS``)."""
        k = AXES.index("gait")
        return any(value is not None for box in self.boxes for _, value in box.values[k])

    @property
    def robots(self) -> tuple[str, ...]:
        """The robots its trials play (their ``robot`` column), in file order."""
        k = AXES.index("body")
        return tuple(dict.fromkeys(body.robot for box in self.boxes for _, body in box.values[k]))

    @property
    def closed_loop(self) -> bool:
        """Some trial names a controller (its table has a ``controller`` column)."""
        k = AXES.index("controller")
        return any(value is not None for box in self.boxes for _, value in box.values[k])


def load_sweep(path: str | Path | None = None, *, model: ModelFile | None = None) -> SweepConfig:
    """Read and check a sweep file (default: ``bench/experiments/sweeps/paper.toml``);
    ``model`` (``--model``) replaces the file's ``model`` and ``map`` keys.

    Raises:
        SweepError: unreadable file, unknown key, value out of range or missing
            robot file, in one line naming the key.
    """
    path = Path(path) if path is not None else DEFAULT_SWEEP
    data = load_toml(path, where=f"sweep file {str(path)!r}", kind="a sweep TOML", error=SweepError)
    return sweep_from_dict(data, base_dir=path.parent, source=str(path), model=model)


# long: a sweep file's top level, one check after the other
def sweep_from_dict(
    data: dict, *, base_dir: Path, source: str = "<dict>", model: ModelFile | None = None
) -> SweepConfig:
    """Build a SweepConfig from parsed TOML; robot, model and map paths are relative to
    ``base_dir``; ``model`` replaces the file's ``model`` and ``map`` (module doc).

    Every value of every grid axis is checked (its range, and the gait it makes
    with the first values of the other axes); the product is not expanded.
    """
    _known(data, TOP_KEYS, "", source)
    steps = data.get("steps", 4)
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise SweepError(f"{source}: steps = {steps!r}: must be an integer >= 1")
    seeds = _seeds(data.get("seed", 0), source)
    noise = data.get("command_noise", 0)
    if isinstance(noise, bool) or not isinstance(noise, int | float) or not math.isfinite(noise):
        raise SweepError(f"{source}: command_noise = {noise!r}: must be a finite number of deg")
    noise = float(noise)
    if not 0 <= noise <= MAX_COMMAND_NOISE_DEG:
        raise SweepError(
            f"{source}: command_noise = {noise:g} deg: "
            f"must lie in [0, {MAX_COMMAND_NOISE_DEG:g}] deg"
        )
    description = data.get("description", "")
    if not isinstance(description, str):
        raise SweepError(f"{source}: description = {description!r}: must be a string")
    grids = _tables(data, "grid", source)
    singles = _tables(data, "trial", source)
    gaits = _draws(data.get("draw"), source)
    ends = _spec_ends(data.get("spec_ends"), source)
    model = model or file_model(data, base_dir, source, SweepError)
    if ends and model is not None:
        raise SweepError(
            f"{source}: spec_ends with a model: the spec imported from it has no [uncertain] "
            "table; name an edited spec with one as robot instead"
        )
    if "envelope" in data and model is not None:
        raise SweepError(
            f"{source}: envelope with a model: the envelope tables' gaits are the default "
            "robot's; run 'slopewalk envelope --model' for the model's own"
        )
    if "envelope" in data:
        config = _envelope_sweep(data, grids, singles, base_dir, source, steps, seeds, ends, noise)
        return replace(config, description=description, spec_ends=ends)
    if gaits != (None,) and (noise or singles):
        raise SweepError(
            f"{source}: [draw] goes with a [grid] alone (no command_noise, no [[trial]])"
        )
    if not grids and not singles:
        raise SweepError(f"{source}: no trials: give a [grid] table or [[trial]] entries")
    robots: dict = {}  # specs by robot key, bodies by (robot, scale, ends) (``_bodies``)
    defaults = DEFAULTS
    if model is not None:
        robots[IMPORTED] = model.scene().spec
        defaults = DEFAULTS | {"robot": IMPORTED, "actuators": MODEL_MODE}
    boxes = []
    for where, table in grids:
        _known(table, TRIAL_KEYS, f"{where}.", source)
        if not table:
            raise SweepError(
                f"{source}: {where} is empty: give at least one list, e.g. step_time = [1.0]"
            )
        axes = {}
        for key in TRIAL_KEYS:
            values = table.get(key, [defaults[key]])
            if not isinstance(values, list) or not values:
                raise SweepError(f"{source}: {where}.{key} = {values!r}: must be a non-empty list")
            axes[key] = values
        where = f"{source}: {where}"
        boxes.append(_box(axes, steps, seeds, noise, robots, base_dir, where, gaits, model, ends))
    for where, table in singles:
        _known(table, TRIAL_KEYS, f"{where}.", source)
        axes = {key: [table.get(key, defaults[key])] for key in TRIAL_KEYS}
        where = f"{source}: {where}"
        boxes.append(_box(axes, steps, seeds, noise, robots, base_dir, where, (None,), model, ends))
    return SweepConfig(source, steps, seeds, tuple(boxes), description, noise, model, ends)


def file_model(data: dict, base_dir: Path, source: str, error: type[SlopewalkError]):
    """The ``ModelFile`` of a sweep or envelope file's ``model`` and ``map`` keys (paths
    relative to ``base_dir``), or None without a ``model`` key."""
    from slopewalk.bench.robot_import.mapfile import RobotImportError

    paths = {}
    for key in ("model", "map"):
        value = data.get(key)
        if value is not None and (not isinstance(value, str) or not value):
            raise error(f"{source}: {key} = {value!r}: must be a file path (relative to the file)")
        paths[key] = None if value is None else base_dir / value
    if paths["model"] is None:
        if paths["map"] is not None:
            raise error(
                f"{source}: map = {data['map']!r}: only with a model key, which is not given"
            )
        return None
    try:
        return ModelFile.of(paths["model"], paths["map"])
    except RobotImportError as err:
        raise error(f"{source}: {err}") from None


def _on_model(axes: dict[str, list], model: ModelFile, where: str) -> None:
    """Refuse what a trial on a model cannot be: the paper's robot, scaled masses, a
    controller (a model plays the plan open loop)."""
    for key, value, why in (
        ("robot", "default", "the paper's biped is not the model; leave robot out (the spec "
         f"imported from {model.name} now) or name a spec of 'slopewalk robot import'"),
        ("controller", None, "a model plays the plan open loop"),
    ):  # fmt: skip
        values = [v for v in axes[key] if v == value or (value is None and v != OPEN_LOOP)]
        if values:
            raise SweepError(f"{where}.{key} = {values[0]!r} with a model: {why}")
    if any(scale for scale in axes["mass_scale"]):
        raise SweepError(
            f"{where}.mass_scale = {axes['mass_scale']!r} with a model: the model's masses "
            "are its own (a scaled spec would only change the plan)"
        )


def _seeds(value, source: str) -> tuple[int, ...]:
    """The top-level ``seed``: an integer >= 0 or a non-empty list of distinct ones."""
    values = value if isinstance(value, list) else [value]
    what = "must be an integer >= 0 or a non-empty list of distinct ones"
    if not values or len(set(map(repr, values))) < len(values):
        raise SweepError(f"{source}: seed = {value!r}: {what}")
    for seed in values:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise SweepError(f"{source}: seed = {value!r}: {what}")
    return tuple(values)


def _envelope_sweep(data, grids, singles, base_dir, source, steps, seeds, ends, noise=0.0):
    """The sweep of every gait the envelope tables of ``data["envelope"]`` played, in each
    ``actuators`` mode of the one ``[grid]`` (module doc), with ``noise`` [deg] of command
    noise (each seed a replica)."""
    paths = data["envelope"]
    if not isinstance(paths, list) or not paths or not all(isinstance(p, str) for p in paths):
        raise SweepError(f"{source}: envelope = {paths!r}: must be a non-empty list of paths")
    if singles or len(grids) != 1 or "draw" in data or set(grids[0][1]) - {"actuators"}:
        raise SweepError(
            f"{source}: envelope goes with one [grid] of actuators alone (no other grid key, "
            "[[trial]] or draw)"
        )
    modes = grids[0][1].get("actuators", [DEFAULTS["actuators"]])
    robots: dict = {}  # specs by robot key, bodies by (robot, scale, ends) (``_bodies``)
    boxes = []
    for path in paths:
        for k, (cell, gait) in enumerate(_envelope_gaits(base_dir / path, source)):
            axes = cell | {"actuators": modes}
            axes |= {"mass_scale": [{}], "controller": [OPEN_LOOP]}
            where = f"{source}: {path} gait {k}"
            boxes.append(
                _box(axes, steps, seeds, noise, robots, base_dir, where, (gait,), ends=ends)
            )
    return SweepConfig(source, steps, seeds, tuple(boxes), command_noise_deg=noise)


def _envelope_gaits(path: Path, source: str):
    """(cell axes, ``GaitChoice``) of every gait an envelope table's rows played."""
    from slopewalk.bench.actuators import MODES
    from slopewalk.bench.tables.envelope import EXTENDED_COLUMNS, GAITS, sim_columns
    from slopewalk.bench.tables.table import read_table
    from slopewalk.planner.gait_search import tilt_bounds

    if not path.is_file():
        raise SweepError(f"{source}: envelope table {str(path)!r}: no such file")
    try:
        rows = read_table(path)
    except (OSError, SlopewalkError) as err:
        raise SweepError(f"{source}: envelope table {str(path)!r}: {err}") from None
    limit = tilt_bounds(load_spec())[1]
    for row in rows:
        if row["robot"] != "default":
            raise SweepError(
                f"{source}: {path}: cell {row['cell_id']} is of robot {row['robot']!r}: "
                "only envelopes of the default robot are played"
            )
        for gait in GAITS:
            if not any(row[sim_columns(gait, m)[0]] for m in MODES):
                continue  # not played (nothing found)
            values = (
                ("hip_height", row[f"{gait}_hip_height_m"]),
                ("swing_lift", row[f"{gait}_swing_lift_m"]),
                ("tilt", _tilt(row[f"{gait}_tilt_deg"], limit)),
                *((e.removesuffix("_m"), row[f"{gait}_{e}"]) for e in EXTENDED_COLUMNS),
            )
            cell = {"step_time": [row["step_time"]], "slope": [row["slope_deg"]],
                    "friction": [row["friction"]], "robot": ["default"]}  # fmt: skip
            yield cell, GaitChoice(f"{path.name} {row['family']} {gait}", values=values)


TILT_DIGITS = 1e-5  # [deg] the envelope table's precision of a tilt (tables/envelope.py)


def _tilt(degrees: float, limit: float) -> float:
    """A table's tilt [deg] in radians; one the table's rounding put past the ankle roll's
    ``limit`` [rad] (a GA gait at its bound, 34.37747° for 0.6 rad) back on it."""
    tilt = float(np.deg2rad(degrees))
    if limit < abs(tilt) <= limit + np.deg2rad(TILT_DIGITS):
        return float(np.copysign(limit, tilt))
    return tilt


def _draws(value, source: str) -> tuple[GaitChoice | None, ...]:
    """The gaits of a ``[draw]`` table (module doc); (None,): the nominal gait."""
    from slopewalk.planner.gait_search import FAMILIES

    if value is None:
        return (None,)
    if not isinstance(value, dict):
        raise SweepError(f"{source}: draw must be a table [draw]")
    _known(value, DRAW_KEYS, "draw.", source)
    families = value.get("family", ["paper"])
    if not isinstance(families, list) or not families or any(f not in FAMILIES for f in families):
        raise SweepError(
            f"{source}: draw.family = {families!r}: must be a non-empty list of "
            f"{', '.join(FAMILIES)}"
        )
    count, seed = value.get("gaits", 1), value.get("seed", 0)
    for key, number, low in (("gaits", count, 1), ("seed", seed, 0)):
        if isinstance(number, bool) or not isinstance(number, int) or number < low:
            raise SweepError(f"{source}: draw.{key} = {number!r}: must be an integer >= {low}")
    return tuple(
        GaitChoice(f"{family} draw {i}", family, i, seed)
        for family in dict.fromkeys(families)
        for i in range(count)
    )


def _box(
    axes: dict[str, list],
    steps,
    seeds,
    noise,
    robots,
    base_dir,
    where,
    gaits=(None,),
    model=None,
    ends=(),
) -> Box:
    """Check each value of each axis once; the grid as a ``Box`` (of trials on ``model``)."""
    if model is not None:
        _on_model(axes, model, where)
    step_times = [_positive(v, "step_time", "s", where) for v in axes["step_time"]]
    slopes = []
    for value in axes["slope"]:
        slope = _number(value, "slope", where)
        if not -60 < slope < 60:
            raise SweepError(f"{where}.slope = {slope:g} deg: must lie in (-60, 60) deg")
        slopes.append(slope)
    frictions = [_positive(v, "friction", "", where) for v in axes["friction"]]
    for actuators in axes["actuators"]:
        actuator_mode(actuators, SweepError, f"{where}.actuators =")
    bodies = [
        body
        for robot in axes["robot"]
        for scale in axes["mass_scale"]
        for body in _bodies(robot, _mass_scale(scale, where), robots, base_dir, where, ends)
    ]
    controllers = [_controller(v, where) for v in axes["controller"]]
    if model is not None:
        _model_modes(axes["actuators"], bodies, where)
    if gaits != (None,) and any(c is not None for c in controllers):
        raise SweepError(f"{where}: [draw] with a controller: drawn gaits are played open loop")
    if noise and any(c is not None for c in controllers):
        raise SweepError(
            f"{where}: command_noise = {noise:g} deg with a controller: the noise is for "
            "plans played open loop (a controller makes its own commands)"
        )
    values = (
        _unique((repr(v), v) for v in step_times),
        _unique((repr(v), v) for v in slopes),
        _unique((repr(v), v) for v in frictions),
        _unique((a, a) for a in axes["actuators"]),
        _unique((b.spec_json, b) for b in bodies),
        _unique((c or OPEN_LOOP, c) for c in controllers),
        _unique(("nominal" if g is None else g.key, g) for g in gaits),
        tuple((repr(seed), seed) for seed in seeds),
    )
    box = Box(where, values)
    # The gait's own range checks (e.g. dt <= step_time/10) of each value of
    # each axis, the other axes at their first value: each check involves one axis.
    # A seed decides no check (any integer >= 0 is a seed): its axis is not walked.
    first = [axis[0][1] for axis in values]
    for k, axis in enumerate(values[: AXES.index("seed")]):
        for _, value in axis[1:] if k else axis:
            combo = [*first[:k], value, *first[k + 1 :]]
            trial = TrialSet((box,), steps, noise, model).make(combo)
            try:
                trial.trial_spec()
            except SlopewalkError as err:
                raise SweepError(f"{where}: {err}") from None
    return box


def _model_modes(modes: list[str], bodies: list[Body], where: str) -> None:
    """Refuse an actuator mode a model cannot play (``robot_import.scene.model_modes``)."""
    from slopewalk.bench.robot_import.scene import model_modes

    for body in bodies:
        allowed = model_modes(body.spec)
        for mode in modes:
            if mode not in allowed:
                raise SweepError(
                    f"{where}.actuators = {mode!r} with a model: it plays on its own actuators "
                    f"(gains the spec's [servo]); use {' or '.join(allowed)}"
                )


def _unique(pairs) -> tuple[tuple[str, object], ...]:
    """(key, value) pairs with the first of each key kept, in order."""
    out: dict[str, object] = {}
    for key, value in pairs:
        out.setdefault(key, value)
    return tuple(out.items())


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


def _bodies(robot, scale, robots: dict, base_dir, where, ends=()) -> list[Body]:
    """The robot ``robot`` with its mass ``scale``, once per spec end of ``ends`` (the
    nominal spec alone for none; module doc). ``robots``: the sweep's cache of specs by
    robot key, and of these lists by (robot, scale, ends)."""
    if not isinstance(robot, str) or not robot:
        raise SweepError(f"{where}.robot = {robot!r}: must be a spec file path")
    path = None if robot == "default" else base_dir / robot
    if robot not in robots:
        try:
            robots[robot] = load_spec(path)
        except SlopewalkError as err:
            raise SweepError(f"{where}.robot: {err}") from None
    made = (robot, scale, ends)  # an envelope sweep has a box per gait, each of these bodies
    if made in robots:
        return robots[made]
    base = robots[robot]
    nominal = _scaled(base, scale)
    nominal_json = spec_text(nominal)
    if not ends:
        robots[made] = [Body(robot, scale, nominal, nominal_json)]
        return robots[made]
    try:
        ranges = {u.key: u for u in load_uncertainty(path)}
    except SlopewalkError as err:
        raise SweepError(f"{where}.robot: {err}") from None
    out = []
    for end in ends:
        if end == NOMINAL:
            out.append(Body(robot, scale, nominal, nominal_json))
            continue
        key, _, side = end.rpartition(":")
        if key not in ranges:
            raise SweepError(
                f"{where}: spec_ends {end!r}: {key} is not in robot {robot!r}'s [uncertain] "
                f"table (it has: {', '.join(ranges) or 'none'})"
            )
        value = ranges[key].low if side == "low" else ranges[key].high
        spec = _scaled(spec_at(base, key, value), scale)
        out.append(Body(robot, scale, spec, spec_text(spec), end, nominal, nominal_json))
    robots[made] = out
    return out


def _scaled(spec: RobotSpec, scale) -> RobotSpec:
    if not scale:
        return spec
    factors = dict.fromkeys(LINK_NAMES, 1.0)
    for group, factor in scale:
        for name in MASS_GROUPS[group]:
            factors[name] *= factor
    return spec.with_mass_scale(factors)


def _spec_ends(value, source: str) -> tuple[str, ...]:
    """The top-level ``spec_ends``: a non-empty list of distinct ``"nominal"``,
    ``"KEY:low"`` or ``"KEY:high"`` (the keys checked per robot, ``_bodies``); () if absent."""
    if value is None:
        return ()
    what = 'must be a non-empty list of distinct "nominal", "KEY:low" or "KEY:high"'
    if not isinstance(value, list) or not value or len(set(map(repr, value))) < len(value):
        raise SweepError(f"{source}: spec_ends = {value!r}: {what}")
    for end in value:
        key, _, side = end.rpartition(":") if isinstance(end, str) else ("", "", "")
        if end != NOMINAL and not (key and side in ("low", "high")):
            raise SweepError(f"{source}: spec_ends entry {end!r}: {what}")
    return tuple(value)


def _controller(value, where: str) -> str | None:
    """None for "none" (open loop), else a ``MODULE:CALLABLE`` that imports and is callable."""
    from slopewalk.bench.controllers import load_controller

    if value == OPEN_LOOP:
        return None
    if not isinstance(value, str):
        raise SweepError(f'{where}.controller = {value!r}: must be "none" or MODULE:CALLABLE')
    try:
        load_controller(value)  # in this process: a bad name is refused before any trial runs
    except SlopewalkError as err:
        raise SweepError(f"{where}.controller: {err}") from None
    return value


def _positive(value, key: str, unit: str, where: str) -> float:
    number = _number(value, key, where)
    if not number > 0:
        raise SweepError(f"{where}.{key} = {number:g}{' ' + unit if unit else ''}: must be > 0")
    return number


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
