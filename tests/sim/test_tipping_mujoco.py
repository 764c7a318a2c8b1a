"""The tipping predictor's rigid-body model against MuJoCo: a block on an edge.

A block of mass m, CoM h above a 0.1 m sole, is pushed at its CoM so that the ZMP
sits e beyond the toe edge for a while, then released (ZMP back at the sole's
centre). MuJoCo's rotation is compared with I θ̈ = W (e + h θ) integrated by
``excursion_integral`` (I: the block's inertia about the edge).
"""

import mujoco
import numpy as np
import pytest

from planner.tipping import excursion_integral

M, H, HALF = 0.8, 0.15, 0.05  # [kg], [m], [m]
SPIN = 0.002  # [kg m²] about the CoM, both horizontal axes
XML = f"""
<mujoco><option timestep="0.001" integrator="implicitfast" cone="elliptic" impratio="10"/>
<worldbody><geom type="plane" size="0 0 0.05" friction="1 0.005 0.0001" condim="3"
  priority="1"/>
<body name="block"><freejoint/>
<geom type="box" size="{HALF} 0.03 0.0025" pos="0 0 0.0025" contype="0" conaffinity="1"
  mass="0.0001"/>
<inertial pos="0 0 {H}" mass="{M}" diaginertia="{SPIN} {SPIN} 0.001"/>
</body></worldbody></mujoco>"""


@pytest.mark.parametrize("beyond, push", [(0.010, 0.2), (0.020, 0.15)])
def test_rotation_about_the_edge_matches_mujoco(beyond, push):
    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 300)  # settle on the plane
    weight = M * 9.81
    force = weight * (HALF + beyond) / H  # static ZMP of the push: (HALF + beyond) ahead
    t = np.arange(600) * model.opt.timestep
    tilt = np.empty(t.size)
    for k, tk in enumerate(t):
        data.xfrc_applied[1, 0] = force if tk < push else 0.0
        mujoco.mj_step(model, data)
        tilt[k] = np.arccos(np.clip(data.xmat[1][8], -1.0, 1.0))
    inertia = SPIN + M * (H**2 + HALF**2)
    drive = np.where(t < push, weight * beyond, -weight * HALF)  # released: ZMP at the centre
    predicted = excursion_integral(t, drive, inertia, weight * H)
    assert predicted.max() == pytest.approx(tilt.max(), rel=0.12)
    assert np.rad2deg(tilt.max()) > 5.0  # a real tip, not a wobble
