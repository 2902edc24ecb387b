"""The soles' soft ground contact (profile ``sim.sole_solref`` / ``sim.sole_solimp``): a sole rolled a few
degrees under a tilted leg rests on two points, not one corner, and sinks about a centimetre at most."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bipedsim.errors import ConfigError
from bipedsim.model import load_profile
from bipedsim.model.plan import BodyPlan, BodyPlanSet, GeomPlan, ModelBuilder
from bipedsim.model.profile import PROFILE_DIR


def _sole_on_floor(sim: dict, roll_deg: float, pitch_deg: float = 2.0) -> tuple[int, float]:
    """A 60 kg body whose one geom is a sole box (0.17 x 0.09 m, the shared bodies' foot), built by the
    project's plan builder, resting 2 s on the floor held at ``roll_deg`` / ``pitch_deg`` (as a leg tilted
    sideways holds it): (contact points carrying more than 5 N, the lowest corner's height in m)."""
    plan = BodyPlanSet(name="sole", profile="humanoid", heading_yaw=0.0, source_names=[], sim=sim, bodies=[
        BodyPlan(name="foot", parent=None, pos=[0.0, 0.0, 0.06], source="", geoms=[
            GeomPlan(kind="box", size=[0.085, 0.045, 0.035], pos=[0.0, 0.0, 0.0], mass=60.0, name="sole",
                     sole=True)])])
    m = ModelBuilder(plan).compile()
    d = mujoco.MjData(m)
    q = Rotation.from_euler("xy", [roll_deg, pitch_deg], degrees=True).as_quat(scalar_first=True)
    d.qpos[3:7] = q
    for _ in range(1000):
        mujoco.mj_step(m, d)
        d.qpos[3:7], d.qvel[3:6] = q, 0.0  # the orientation held, the weight free to settle
    mujoco.mj_forward(m, d)
    f = np.zeros(6)
    carrying = 0
    for k in range(d.ncon):
        mujoco.mj_contactForce(m, d, k, f)
        carrying += int(f[0] > 5.0)
    g = m.geom("sole").id
    corners = np.array([[sx, sy, -1.0] for sx in (-1, 1) for sy in (-1, 1)]) * m.geom_size[g]
    low = float((d.geom_xpos[g] + corners @ d.geom_xmat[g].reshape(3, 3).T)[:, 2].min())
    return carrying, low


@pytest.mark.parametrize("roll", [3.0, 8.0, 12.0])
def test_a_rolled_sole_rests_on_two_points_not_one_corner(roll: float) -> None:
    sim = asdict(load_profile("humanoid").sim)
    assert sim["sole_solref"] is not None and sim["sole_solimp"] is not None  # on by default
    soft, soft_low = _sole_on_floor(sim, roll)
    hard, hard_low = _sole_on_floor(dict(sim, sole_solref=None, sole_solimp=None), roll)
    assert hard == 1 and soft >= 2, (hard, soft)
    assert -0.015 < soft_low < hard_low < 0.0  # sinks more than the hard sole, by about a centimetre at most


def test_the_soles_take_their_own_contact_parameters(tmp_path: Path) -> None:
    """Priority 1 on the foot and toe boxes: the contact uses the sole's parameters whatever the
    ground's; every other geom keeps the profile's ``solref`` / ``solimp``."""
    from bipedsim.data import BUILTIN_WALK
    from bipedsim.model import build_model
    from bipedsim.motion import load_bvh

    prof = load_profile("humanoid")
    m = build_model(load_bvh(BUILTIN_WALK)).model
    for i in range(m.ngeom):
        name = m.geom(i).name
        sole = name.endswith(("_foot_geom", "_toe_geom"))
        assert m.geom_priority[i] == (1 if sole else 0), name
        np.testing.assert_allclose(m.geom_solref[i], prof.sim.sole_solref if sole else prof.sim.solref)
        np.testing.assert_allclose(m.geom_solimp[i], prof.sim.sole_solimp if sole else prof.sim.solimp)
    bad = tmp_path / "p.yaml"
    text = (PROFILE_DIR / "humanoid.yaml").read_text()
    bad.write_text(text.replace("sole_solimp: [0.45, 0.95,", "sole_solimp: [0.99, 0.95,"))
    with pytest.raises(ConfigError, match=r"sole_solimp.*dmin <= dmax"):
        load_profile(bad)
    bad.write_text(text.replace("sole_solref: [0.0225,", "sole_solref: [0.001,"))
    with pytest.raises(ConfigError, match=r"sole_solref.*at least 2 timesteps"):
        load_profile(bad)


def test_the_soles_take_the_profile_s_condim() -> None:
    """With priority the sole's condim is the contact's, so the soles carry the profile's ``sim.condim``
    (3 by default; 4 adds torsional friction, ``friction[1]`` m): before, every body geom had condim 3 and
    a profile asking for 4 got 3 at the soles."""
    from dataclasses import replace

    from bipedsim.data import BUILTIN_WALK
    from bipedsim.model import build_model
    from bipedsim.motion import load_bvh

    prof = load_profile("humanoid")
    for condim in (3, 4):
        p = replace(prof, sim=replace(prof.sim, condim=condim))
        m = build_model(load_bvh(BUILTIN_WALK), p).model
        soles = [i for i in range(m.ngeom) if m.geom(i).name.endswith(("_foot_geom", "_toe_geom"))]
        assert len(soles) == 4 and all(m.geom_condim[i] == condim for i in soles)
        assert m.geom_condim[m.geom("floor").id] == condim


def test_creature_soles_stay_hard() -> None:
    """The creature profile names no sole contact: a two-legged creature's sole boxes (the built-in walk
    built as a creature) meet the ground as every other geom (priority 0, the profile's solref)."""
    from bipedsim.data import BUILTIN_WALK
    from bipedsim.model import build_model
    from bipedsim.motion import load_bvh

    prof = load_profile("creature")
    assert prof.sim.sole_solref is None and prof.sim.sole_solimp is None
    m = build_model(load_bvh(BUILTIN_WALK), "creature").model
    soles = [i for i in range(m.ngeom) if m.geom(i).name.endswith("_sole_geom")]
    assert soles and all(m.geom_priority[i] == 0 for i in soles)
    np.testing.assert_allclose(m.geom_solref[soles], np.tile(prof.sim.solref, (len(soles), 1)))
