"""Closed-loop controllers for the bench, and the one place a ``MODULE:CALLABLE`` is loaded.

A controller is any callable ``observation -> action``: the observation is the dict
of ``slopewalk.bench.sim.env.TrialEnv`` (named arrays, slope frame), the action the ``nu``
actuator commands. ``slopewalk trial --controller MODULE:CALLABLE`` and a sweep
file's ``controller`` key name one; ``load_controller`` imports it. Shipped:

* ``slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback``: stance-ankle CoP feedback.
* ``slopewalk.bench.controllers.capture_point:capture_point_pelvis``: LIPM capture-point
  correction of the pelvis.
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable

from slopewalk.planner.errors import SlopewalkError

_SPEC = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*$")
SHIPPED = (
    "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback",
    "slopewalk.bench.controllers.capture_point:capture_point_pelvis",
)


class ControllerError(SlopewalkError):
    """A controller that cannot be loaded, or that returned a bad action."""


def check_controller_name(name: str) -> str:
    """``name`` if it reads ``MODULE:CALLABLE`` (dotted module, dotted attribute), else raise."""
    if not isinstance(name, str) or not _SPEC.match(name):
        raise ControllerError(
            f"controller {name!r}: must read MODULE:CALLABLE, "
            "e.g. slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback"
        )
    return name


def load_controller(name: str) -> Callable:
    """Import ``MODULE`` and return its attribute ``CALLABLE`` (observation -> action).

    Raises:
        ControllerError: not ``MODULE:CALLABLE``, the module or the attribute missing,
            the module failing on import, or the attribute not callable; in one line.
    """
    module_name, attribute = check_controller_name(name).split(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as err:
        missing = err.name or module_name
        raise ControllerError(f"controller {name!r}: no module named {missing!r}") from None
    except Exception as err:  # the user's module fails on import: say how, in one line
        raise ControllerError(
            f"controller {name!r}: importing {module_name!r} failed ({type(err).__name__}: {err})"
        ) from None
    target = module
    for part in attribute.split("."):
        if not hasattr(target, part):
            raise ControllerError(f"controller {name!r}: module {module_name!r} has no {part!r}")
        target = getattr(target, part)
    if not callable(target):
        raise ControllerError(
            f"controller {name!r}: {attribute!r} is a {type(target).__name__}, not callable"
        )
    return target
