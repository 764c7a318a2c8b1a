"""The one error family of slopewalk: every refusal names the value and the allowed range."""


class SlopewalkError(ValueError):
    """Base class of every error slopewalk raises on purpose (bad input, unreachable targets)."""


class SpecError(SlopewalkError):
    """A robot spec file that is missing a key or holds a non-physical value."""


class GaitError(SlopewalkError):
    """Gait parameters outside their allowed range (step time, slope, lift, tilt ...)."""


class UnreachableError(SlopewalkError):
    """An inverse-kinematics target farther from the hip than the leg can reach."""
