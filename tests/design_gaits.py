"""Design-set gaits that several tests play (results/README.md, stops 56-58): gaits the
predictor was designed on, never a reported set's, so a test may pin the model on them."""

from __future__ import annotations

import numpy as np

from slopewalk.planner.gait import GaitParams


def leaning_uphill(spec, *, steps: int = 4) -> GaitParams:
    """ga-dev's GA gait at 0.45 s steps up 7.5° (extended family, max margin): a 7.5 mm
    swing lift and a 20° lean, the walk traced at stops 56-58."""
    return GaitParams.nominal(
        spec,
        0.45,
        steps=steps,
        slope=np.deg2rad(7.5),
        hip_height=0.1792653,
        swing_lift=0.0074864,
        tilt=np.deg2rad(19.8915),
        pelvis_offset=0.0137907,
        step_length=0.0556639,
        sway_share=0.8466267,
    )
