"""The spec's ``[contact]``: read and checked, played by MuJoCo's contacts, and the
predictor's floor following it (MuJoCo's own contact rows are the reference)."""

from dataclasses import replace

import mujoco
import pytest

from slopewalk.bench.sim.floor import SoftFloor, scene_corner_stiffness
from slopewalk.bench.sim.model import SceneError, scene_xml
from slopewalk.planner.errors import SpecError
from slopewalk.planner.spec import default_spec_path, load_spec
from slopewalk.planner.whole_body import floor_spring

SETTINGS = [(0.02, 1.0), (0.04, 0.5), (0.01, 2.0)]  # (τ [s], ζ): the default and two ends


def _standing(spec):
    """The scene of ``spec`` after 0.5 s standing (``stiff``), and its data."""
    model = mujoco.MjModel.from_xml_string(scene_xml(spec, actuators="stiff"))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_step(model, data, 500)
    return model, data


@pytest.mark.parametrize("tau, zeta", SETTINGS)
def test_mujocos_foot_contacts_carry_the_specs_contact(spec, tau, zeta):
    model, data = _standing(replace(spec, contact_timeconst=tau, contact_dampratio=zeta))
    assert data.ncon == 8  # the two soles' 4 corners each
    for i in range(data.ncon):
        assert tuple(data.contact.solref[i]) == (tau, zeta)
    floor = SoftFloor.of_scene(model)
    assert (floor.timeconst, floor.dampratio) == (tau, zeta)


@pytest.mark.parametrize("tau, zeta", SETTINGS)
def test_the_predictors_floor_damps_as_mujocos_contact(spec, tau, zeta):
    """MuJoCo's contact row pushes with K r + B v (both times the same impedance factor),
    B / K = 2 d_max τ ζ²; the whole-body floor's corner damper over its spring is that over
    d_max, for every τ and ζ."""
    model, data = _standing(replace(spec, contact_timeconst=tau, contact_dampratio=zeta))
    k_c, c = floor_spring(scene_corner_stiffness(model), tau, zeta)
    d_max = SoftFloor.of_scene(model).solimp[1]
    for i in range(data.ncon):
        K, B, _, _ = data.efc_KBIP[data.contact.efc_address[i]]
        assert c / k_c == pytest.approx(B / K / d_max, rel=1e-9)


def test_the_default_contact_leaves_the_scene_and_the_ids_as_they_were(spec):
    assert (spec.contact_timeconst, spec.contact_dampratio) == (0.02, 1.0)
    assert "solref" not in scene_xml(spec)  # MuJoCo's defaults, as before the table
    assert "contact_timeconst" not in spec.as_dict()
    moved = replace(spec, contact_dampratio=0.5)
    assert moved.as_dict()["contact_dampratio"] == 0.5
    assert 'solref="0.02 0.5"' in scene_xml(moved)


def test_a_time_constant_below_two_steps_is_refused(spec):
    short = replace(spec, contact_timeconst=0.004)
    scene_xml(short, timestep=0.002)  # 2 steps: MuJoCo takes it as it is
    with pytest.raises(SceneError, match=r"^contact\.timeconst 0\.004 s of robot .*: must be >= 2 "
                       r"time steps \(0\.006 s\) at timestep 0\.003 s$"):  # fmt: skip
        scene_xml(short, timestep=0.003)


def _with_contact(tmp_path, table: str):
    text = default_spec_path().read_text()
    start = text.index("[contact]")
    end = text.index("[uncertain]")
    path = tmp_path / "r.toml"
    path.write_text(text[:start] + table + "\n" + text[end:])
    return path


def test_the_table_is_read_and_optional(tmp_path):
    spec = load_spec(_with_contact(tmp_path, "[contact]\ntimeconst = 0.03\ndampratio = 2\n"))
    assert (spec.contact_timeconst, spec.contact_dampratio) == (0.03, 2.0)
    plain = load_spec(_with_contact(tmp_path, ""))
    assert plain == load_spec()  # the shipped file states MuJoCo's defaults


@pytest.mark.parametrize(
    "table, fragment",
    [
        ("timeconst = 0", "contact.timeconst 0.0 s: must lie in (0, 1] s"),
        ("timeconst = -0.02", "contact.timeconst -0.02 s: must lie in (0, 1] s"),
        ("timeconst = nan", "contact.timeconst nan s: must lie in (0, 1] s"),
        ("timeconst = inf", "contact.timeconst inf s: must lie in (0, 1] s"),
        ("timeconst = 2.0", "must lie in (0, 1] s"),
        ('timeconst = "fast"', "contact.timeconst 'fast'"),
        ("dampratio = 0", "contact.dampratio 0.0: must lie in (0, 100]"),
        ("dampratio = true", "contact.dampratio True"),
        ("timeconstant = 0.02", "unknown key contact.timeconstant (did you mean contact.timec"),
    ],
)  # fmt: skip
def test_a_bad_contact_is_refused_in_one_line(tmp_path, table, fragment):
    path = _with_contact(tmp_path, f"[contact]\n{table}\n")
    with pytest.raises(SpecError) as err:
        load_spec(path)
    assert fragment in str(err.value)
    assert "\n" not in str(err.value)


def test_a_contact_that_is_no_table_is_refused(tmp_path):
    text = default_spec_path().read_text()
    path = tmp_path / "r.toml"
    path.write_text("contact = 0.02\n" + text[: text.index("[contact]")])
    with pytest.raises(SpecError, match=r"contact = 0\.02: must be a table \[contact\]$"):
        load_spec(path)
