"""An envelope file: the TOML grid of cells and the GA settings, checked whole before any cell runs.

Format (degrees and millimetres at this edge, like the CLI)::

    description = "what this envelope is for"   # optional, free text
    steps = 4            # steps per walk, in [1, 1000] (4)

    [grid]               # the product of these lists is the set of cells
    step_time = [2.0, 1.0, 0.5]      # [s], in (0, 60]; required
    slope = [-20, 0, 15]             # [deg], in (-60, 60), negative walks downhill; required
    friction = [1.0]                 # Coulomb mu, in (0, 10] ([1.0])
    robot = ["default"]              # spec files, relative to this file (the paper's biped)
    actuators = ["stiff", "servo"]   # modes each found gait is played in (every mode the bench has)
    # also walked closed loop ([])
    controller = ["slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback"]

    [search]             # the GA of every cell (the paper's operators, seeded)
    population = 40      # in [2, 1000] (40)
    generations = 30     # in [1, 100000] (30)
    seed = 0             # in [0, 2^32 - 1] (0)
    family = ["paper"]   # gait families searched, one row each ("paper", "extended")
    required_margin = 5  # [mm] least ZMP margin of the least-work gait, in [0, 50] (5),
                         # below half the sole's width, 0 or not below that width in m

One ``[grid]`` table (an array ``[[grid]]``, a sweep file's union of boxes, is refused:
the grid is the plane the figure and the boundaries draw); an actuator mode named twice
is refused; so is a ``required_margin`` no gait can meet or that reads as metres
(``_check_margin_unit``).

``controller`` names closed-loop controllers (``MODULE:CALLABLE``, as in a sweep
file; ``"none"``, open loop, is always played): each played gait is also walked,
in every mode, by each of them, into columns of their own (``envelope/cell.py``).
A controller that does not import, or two whose callables share a name (they
name the columns), is refused before any cell runs.

``model`` and ``map`` (paths relative to the file; ``envelope --model MODEL --map MAP``
replaces both) play every found gait on that unmodified MJCF/URDF model: ``robot``
then defaults to ``["imported"]`` (the spec imported from it now), ``actuators`` to
the modes a model plays in (``robot_import.scene.model_modes``); the paper's robot
and controllers are refused; the model's digest enters every ``cell_id``.

Every key is checked: an unknown key, a value of the wrong type or out of its
range is refused in one line naming the key, the value and the range (the
sweep file's rules, ``sweep/config.py``, whose helpers this module uses).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slopewalk.bench.actuators import ACTUATOR_MODES, actuator_mode
from slopewalk.bench.experiments.envelope.cell import FAMILIES, EnvelopeCell, SearchSettings
from slopewalk.bench.experiments.sweep.config import (
    IMPORTED,
    SweepError,
    _bodies,
    _controller,
    _known,
    _number,
    file_model,
)
from slopewalk.bench.files import in_package
from slopewalk.bench.flags import GENERATIONS, POPULATION, SEED
from slopewalk.bench.robot_import.model_file import ModelFile
from slopewalk.bench.tables.envelope import envelope_format
from slopewalk.planner import ranges
from slopewalk.planner.config_file import load_toml
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams

ENVELOPES_DIR = Path(__file__).parents[1] / "envelopes"  # bench/experiments/envelopes/
DEFAULT_ENVELOPE = ENVELOPES_DIR / "paper.toml"
TOP_KEYS = ("description", "steps", "model", "map", "grid", "search")
GRID_KEYS = ("step_time", "slope", "friction", "robot", "actuators", "controller")
SEARCH_KEYS = ("population", "generations", "seed", "family", "required_margin")
SEARCH_DEFAULTS = {
    "population": 40,
    "generations": 30,
    "seed": 0,
    "family": ["paper"],
    "required_margin": 5.0,
}
REQUIRED_MARGIN_MM = ranges.Range(0.0, 50.0, "mm", low_open=False)


class EnvelopeError(SweepError):
    """An envelope file with an unknown key, a bad value or a missing robot file."""


@dataclass(frozen=True)
class EnvelopeConfig:
    """A parsed envelope file.

    Attributes:
        source: The file, for messages.
        cells: Every cell × family, in file order (step time outer, then slope,
            friction, robot, family).
        step_times, slopes_deg: The grid's axes as written [s], [deg].
        search: The GA settings of every cell.
        modes: Actuator modes each found gait is played in.
        controllers: ``MODULE:CALLABLE`` of the controllers each played gait is also
            walked with (besides open loop).
    """

    source: str
    cells: tuple[EnvelopeCell, ...]
    step_times: tuple[float, ...]
    slopes_deg: tuple[float, ...]
    search: SearchSettings
    modes: tuple[str, ...]
    description: str = ""
    controllers: tuple[str, ...] = ()
    model: ModelFile | None = None  # every gait played on this model (``envelope --model``)


def load_envelope(
    path: str | Path | None = None, *, model: ModelFile | None = None
) -> EnvelopeConfig:
    """Read and check an envelope file (default: ``bench/experiments/envelopes/paper.toml``);
    ``model`` (``--model``) replaces the file's ``model`` and ``map`` keys.

    Raises:
        EnvelopeError: unreadable file, unknown key, value out of range or missing
            robot file, in one line naming the key.
    """
    given = path
    path = Path(path) if path is not None else DEFAULT_ENVELOPE
    where = f"envelope file {str(path)!r}"
    data = load_toml(path, where=where, kind="an envelope TOML", error=EnvelopeError)
    # the source as the reports quote it: as given, or the default's path in the package
    source = str(given) if given is not None else in_package(DEFAULT_ENVELOPE)
    return envelope_from_dict(data, base_dir=path.parent, source=source, model=model)


def envelope_from_dict(
    data: dict, *, base_dir: Path, source: str = "<dict>", model: ModelFile | None = None
) -> EnvelopeConfig:
    """Build an EnvelopeConfig from parsed TOML; robot, model and map paths are relative to
    ``base_dir``; ``model`` replaces the file's ``model`` and ``map`` (module doc)."""
    try:
        return _parse(data, base_dir, source, model)
    except EnvelopeError:
        raise
    except SweepError as err:  # a helper of the sweep file's: the same message, our class
        raise EnvelopeError(str(err)) from None


# long: an envelope file's keys, one check after the other
def _parse(data: dict, base_dir: Path, source: str, model: ModelFile | None) -> EnvelopeConfig:
    _known(data, TOP_KEYS, "", source)
    model = model or file_model(data, base_dir, source, EnvelopeError)
    description = data.get("description", "")
    if not isinstance(description, str):
        raise EnvelopeError(f"{source}: description = {description!r}: must be a string")
    steps = _checked(data.get("steps", 4), "steps", ranges.STEPS, source)
    grid = _table(data, "grid", source, required=True)
    _known(grid, GRID_KEYS, "grid.", source)
    search = _table(data, "search", source, required=False)
    _known(search, SEARCH_KEYS, "search.", source)

    where = f"{source}: grid"
    step_times = _unique(
        _checked(v, "grid.step_time", ranges.STEP_TIME, source)
        for v in _list(grid, "step_time", None, source)
    )
    slopes = _unique(
        _checked(v, "grid.slope", ranges.SLOPE_DEG, source)
        for v in _list(grid, "slope", None, source)
    )
    frictions = _unique(
        _checked(v, "grid.friction", ranges.FRICTION, source)
        for v in _list(grid, "friction", [1.0], source)
    )
    robots: dict = {} if model is None else {IMPORTED: model.scene().spec}
    given_robots = _list(grid, "robot", ["default" if model is None else IMPORTED], source)
    if model is not None and "default" in given_robots:
        raise EnvelopeError(
            f"{where}.robot = 'default' with a model: the paper's biped is not the model; "
            f"leave robot out (the spec imported from {model.name} now) or name a spec of "
            "'slopewalk robot import'"
        )
    bodies = [b for r in given_robots for b in _bodies(r, (), robots, base_dir, where)]
    bodies = list({b.spec_json: b for b in reversed(bodies)}.values())[::-1]  # first kept
    playable = ACTUATOR_MODES if model is None else _model_modes(bodies)
    given_modes = _list(grid, "actuators", list(playable), source)
    for mode in given_modes:
        actuator_mode(mode, EnvelopeError, f"{where}.actuators =")
    for mode in given_modes:
        if mode not in playable:
            raise EnvelopeError(
                f"{where}.actuators = {mode!r} with a model: it plays on its own actuators "
                f"(gains the spec's [servo]); use {' or '.join(playable)}"
            )
    modes = _unique(given_modes)
    if len(modes) < len(given_modes):
        twice = sorted({m for m in given_modes if given_modes.count(m) > 1})
        raise EnvelopeError(
            f"{where}.actuators = {given_modes!r}: names {', '.join(twice)} more than once "
            "(each mode is played once per gait, into columns of its own)"
        )
    controllers = tuple(
        c
        for c in _unique(_controller(v, where) for v in _list(grid, "controller", [], source))
        if c is not None  # "none": open loop, played anyway
    )
    if controllers and model is not None:
        raise EnvelopeError(
            f"{where}.controller = {controllers[0]!r} with a model: a model plays the plan "
            "open loop"
        )
    try:
        envelope_format(controllers)
    except ValueError as err:
        raise EnvelopeError(f"{where}.controller: {err}") from None

    settings = _search(search, source)
    _check_margin_unit(settings.required_margin, bodies, source)
    for body, t in itertools.product(bodies, step_times):  # the gait's own checks, per value
        for s in slopes:
            try:
                GaitParams.nominal(body.spec, t, slope=float(np.deg2rad(s)), steps=steps)
            except SlopewalkError as err:
                raise EnvelopeError(f"{where}: step_time {t:g} s, slope {s:g} deg: {err}") from None
    cells = tuple(
        EnvelopeCell(
            step_time=t,
            slope_deg=s,
            friction=mu,
            robot=body.robot,
            family=family,
            steps=steps,
            search=settings,
            modes=modes,
            spec=body.spec,
            spec_json=body.spec_json,
            controllers=controllers,
            model=model,
        )
        for t, s, mu, body, family in itertools.product(
            step_times, slopes, frictions, bodies, settings.families
        )
    )
    return EnvelopeConfig(
        source, cells, step_times, slopes, settings, modes, description, controllers, model
    )


def _model_modes(bodies) -> tuple[str, ...]:
    """The actuator modes every robot of the grid plays the model in (``model_modes``)."""
    from slopewalk.bench.robot_import.scene import model_modes

    return tuple(m for m in ACTUATOR_MODES if all(m in model_modes(b.spec) for b in bodies))


def _search(table: dict, source: str) -> SearchSettings:
    values = SEARCH_DEFAULTS | table
    families = values["family"]
    families = [families] if isinstance(families, str) else families
    if not isinstance(families, list) or not families:
        raise EnvelopeError(
            f"{source}: search.family = {values['family']!r}: must be a family name or a "
            f"non-empty list of them ({', '.join(FAMILIES)})"
        )
    for family in families:
        if family not in FAMILIES:
            raise EnvelopeError(
                f"{source}: search.family = {family!r}: must be one of {', '.join(FAMILIES)}"
            )
    margin = _checked(
        values["required_margin"], "search.required_margin", REQUIRED_MARGIN_MM, source
    )
    return SearchSettings(
        population=_checked(values["population"], "search.population", POPULATION, source),
        generations=_checked(values["generations"], "search.generations", GENERATIONS, source),
        seed=_checked(values["seed"], "search.seed", SEED, source),
        families=tuple(_unique(families)),
        required_margin=float(margin) * 1e-3,
    )


def _check_margin_unit(margin: float, bodies, source: str) -> None:
    """Refuse a required margin [m] that no gait can meet or that reads as metres.

    The ZMP margin is the ZMP's distance inside the support polygon; in single support
    that is one sole, so no margin exceeds half its width (the sole's narrower side). A
    required margin of at least that is met by no gait. And a positive value below half
    the sole's width *in metres* (0.03 for the paper's biped) is a plausible margin
    written in metres: read as millimetres it asks for less than 30 µm, so it is refused
    as a likely unit slip rather than searched.
    """
    half = min(b.spec.foot_width for b in bodies) / 2  # [m]
    mm = margin * 1e3
    if mm >= half * 1e3:
        raise EnvelopeError(
            f"{source}: search.required_margin = {mm:g} mm: must be below half the sole's "
            f"width, {half * 1e3:g} mm (the ZMP is never farther inside a sole)"
        )
    if 0 < mm < half:
        raise EnvelopeError(
            f"{source}: search.required_margin = {mm:g} mm: looks like metres (the key is in "
            f"mm; {mm:g} m would be {mm * 1e3:g} mm): give 0 or a margin in mm from "
            f"{half:g} to {half * 1e3:g} (half the sole's width)"
        )


def _checked(value, key: str, allowed: ranges.Range, source: str):
    """``value`` if ``allowed`` holds it, else one line naming the key, value and range."""
    if not allowed.contains(value):
        unit = f" {allowed.unit}" if allowed.unit and _is_number(value) else ""
        raise EnvelopeError(f"{source}: {key} = {ranges.show(value)}{unit}: {allowed.requirement}")
    return int(value) if allowed.integer else float(value)


def _is_number(value) -> bool:
    try:
        _number(value, "", "")
    except SweepError:
        return False
    return True


def _table(data: dict, key: str, source: str, *, required: bool) -> dict:
    value = data.get(key)
    if value is None:
        if required:
            raise EnvelopeError(f"{source}: no [{key}] table: give at least step_time and slope")
        return {}
    if isinstance(value, list) and key == "grid":
        raise EnvelopeError(
            f"{source}: [[grid]] is an array of {len(value)} tables: an envelope takes one "
            "[grid] table, whose step_time x slope product is the plane its figure and "
            "boundaries draw (a sweep file's [[grid]] is a union of boxes); write one "
            "envelope file per grid"
        )
    if not isinstance(value, dict):
        raise EnvelopeError(f"{source}: {key} must be a table [{key}]")
    return value


def _list(table: dict, key: str, default, source: str) -> list:
    if key not in table:
        if default is None:
            raise EnvelopeError(f"{source}: grid.{key} is missing: give a list, e.g. {key} = [1.0]")
        return default
    values = table[key]
    if not isinstance(values, list) or not values:
        raise EnvelopeError(f"{source}: grid.{key} = {values!r}: must be a non-empty list")
    return values


def _unique(values) -> tuple:
    return tuple(dict.fromkeys(values))
