"""Controllers that misbehave, for the refusal tests (pytest puts tests/ on sys.path)."""

import numpy as np

NOT_CALLABLE = 3.0


def seven_numbers(observation):
    return np.zeros(7)


def nan_command(observation):
    return np.full(8, np.nan)


def raises(observation):
    raise ZeroDivisionError("the user's bug")


def words(observation):
    return "stand still"
