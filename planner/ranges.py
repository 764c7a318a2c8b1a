"""Allowed ranges of the numbers a user types, and the one-line refusal of a value outside one.

A ``Range`` is an interval with its unit; ``check`` refuses anything that is not
a finite real number inside it (NaN, ±inf, strings and booleans included) with
one line that names the value and the interval, e.g.
``step time inf s: must lie in (0, 60] s``.

The bounds of the walk's inputs live here so that the CLI can refuse a flag while
parsing it and the dataclasses (``GaitParams``, ``TrialSpec``) refuse the same
value through the API, from one definition.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import TypeGuard, TypeVar

from slopewalk.planner.errors import SlopewalkError

_V = TypeVar("_V")


@dataclass(frozen=True)
class Range:
    """An interval of allowed values.

    Attributes:
        low, high: The bounds, in ``unit``.
        unit: Unit printed after values and the interval ("s", "m", "deg", "" for none).
        low_open, high_open: Whether the bound itself is excluded.
        integer: Whether only integers are allowed.
    """

    low: float
    high: float
    unit: str = ""
    low_open: bool = True
    high_open: bool = False
    integer: bool = False

    def __str__(self) -> str:
        left = "(" if self.low_open else "["
        right = ")" if self.high_open else "]"
        low, high = (
            (f"{int(self.low)}", f"{int(self.high)}")
            if self.integer
            else (f"{self.low:g}", f"{self.high:g}")
        )
        return f"{left}{low}, {high}{right}{self._unit}"

    @property
    def _unit(self) -> str:
        return f" {self.unit}" if self.unit else ""

    def contains(self, value: object) -> bool:
        """Whether ``value`` is a finite real number (an integer if required) inside."""
        if not _is_number(value):
            return False
        if self.integer and not isinstance(value, numbers.Integral):
            return False
        x = float(value)
        if not math.isfinite(x):
            return False
        above = x > self.low if self.low_open else x >= self.low
        below = x < self.high if self.high_open else x <= self.high
        return above and below

    def check(self, name: str, value: _V, error: type[SlopewalkError] = SlopewalkError) -> _V:
        """Return ``value`` if inside, else raise ``error`` "<name> <value> <unit>: must ..."."""
        if not self.contains(value):
            unit = self._unit if _is_number(value) else ""
            raise error(f"{name} {show(value)}{unit}: {self.requirement}")
        return value

    @property
    def requirement(self) -> str:
        """E.g. "must lie in (0, 60] s", "must be an integer in [1, 1000]", "must be finite"."""
        if math.isinf(self.low) and math.isinf(self.high):
            return "must be a finite number"
        return f"must be an integer in {self}" if self.integer else f"must lie in {self}"


def _is_number(value: object) -> TypeGuard[numbers.Real]:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def show(value: object) -> str:
    """A value as the user typed it (``inf``, ``nan``, ``100000.0``, ``'abc'``)."""
    if not _is_number(value):
        return repr(value)
    return repr(float(value)) if isinstance(value, float) else str(value)


# The walk's inputs.  Upper bounds are where the question stops being a walk of
# this bench, not numerical limits: a step slower than a minute is quasi-static
# long before; more than 1000 steps or a plan of more than MAX_SAMPLES samples
# would hold gigabytes (a plan keeps about 630 bytes per sample, measured on the
# 4-step nominal walk, so 1e6 samples are 0.6 GB; the simulated recording adds
# as much again).
STEP_TIME = Range(0.0, 60.0, "s")  # and at least 10 samples (GaitParams)
DT = Range(0.0, 0.1, "s")
STEPS = Range(1, 1000, integer=True, low_open=False)
SLOPE_DEG = Range(-60.0, 60.0, "deg", high_open=True)
TILT_DEG = Range(-45.0, 45.0, "deg", high_open=True)
SWAY_SHARE = Range(0.0, 1.0, low_open=False)  # w of the lean's shape (trajectory.lean_shape)
MAX_SAMPLES = 1_000_000
# Coulomb friction of the feet on the plane.  Rubber on dry concrete is about 1,
# the grippiest soft elastomers about 2-3; 10 leaves room for a "never slips"
# trial while refusing values that only stand for infinity.
FRICTION = Range(0.0, 10.0)
