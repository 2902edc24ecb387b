"""A person's proportions for a humanoid body's height: its mass from the legs' length, and a length
given to the bones a body needs and its skeleton leaves without one (a foot with no toe, a head with no
neck)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.model.humanoid_bones import MIN_BONE_M
from bipedsim.model.humanoid_sides import humanoid_roles
from bipedsim.model.profile import HumanoidProfile, load_profile
from bipedsim.model.source import rest_points
from bipedsim.motion.motion import Motion

FloatArray = npt.NDArray[np.float64]


def mass_from_legs(leg_length: float, profile: HumanoidProfile) -> float:
    """A person's mass (kg) for legs ``leg_length`` m long (hip to ankle): the height the legs are
    ``profile.leg_share`` of, at the body-mass index ``profile.mass_bmi`` (kg/m^2)."""
    if not leg_length > 0:
        raise ModelError(f"a body's mass from its legs needs legs > 0 m, got {leg_length}")
    return profile.mass_bmi * (leg_length / profile.leg_share) ** 2


#: a head that ends where it begins (no neck joint, and a head End Site of no length: SNU's 15-joint rig)
#: is given a crown this fraction of the body's height above its joint, up the spine (chin to crown 0.13
#: of the stature, Drillis & Contini)
HEAD_TOP_SHARE = 0.13
#: a foot with no toe joint and no length (the ankle's End Site of no length: Perception Neuron exports)
#: reaches a person's foot length forward (``geometry.foot_length_share``), its tip this fraction of the
#: height below the ankle (the ankle's height, 0.039 of the stature in Winter's table)
ANKLE_HEIGHT_SHARE = 0.039


def with_tips(motion: Motion, notes: list[str] | None = None, profile: HumanoidProfile | None = None) -> Motion:
    """``motion`` (project frame, a standing rest pose) with a length given to the bones a humanoid's
    body needs and its skeleton leaves without one: a foot with no toe joint whose End Site lies on the
    ankle, a head with no neck whose End Site lies on the head joint. Each gets an End Site at a
    person's proportions for the body's height (legs / ``leg_share``) in the rest pose's forward or up
    direction, so it turns with the captured joint; what was done is appended to ``notes``. Unchanged
    where the tips have length or no humanoid roles are found (the builder says what is missing)."""
    sk = motion.skeleton
    try:
        hm = humanoid_roles(motion)[0]
    except ModelError:
        return motion
    prof = profile if profile is not None else _default_profile()
    rest = rest_points(motion)

    def reach(joint: str, origin: str) -> float:  # farthest point of ``joint``'s subtree from ``origin``
        return max(float(np.linalg.norm(rest[n] - rest[origin])) for n in rest.below(joint))

    legs = [hm.legs[sd] for sd in ("left", "right")]
    leg = float(np.mean([np.linalg.norm(rest[lg["knee"]] - rest[lg["thigh"]])  # type: ignore[index]
                         + np.linalg.norm(rest[lg["ankle"]] - rest[lg["knee"]]) for lg in legs]))  # type: ignore[index]
    height = leg / prof.leg_share
    up = np.array([0.0, 0.0, 1.0])
    fwd = np.cross(rest[legs[0]["thigh"]] - rest[legs[1]["thigh"]], up)  # type: ignore[index]
    tips: dict[str, FloatArray] = {}
    made: list[str] = []
    for sd, lg in zip(("left", "right"), legs):
        an, toe = lg["ankle"], lg["toe"]
        assert an
        if toe and float(np.linalg.norm(rest[toe] - rest[an])) >= MIN_BONE_M:
            continue
        if reach(an, an) >= MIN_BONE_M or np.linalg.norm(fwd[:2]) < 1e-9:
            continue
        ahead = prof.geometry.foot_length_share * height - prof.geometry.heel_length
        tips[an] = fwd / np.linalg.norm(fwd) * ahead - up * ANKLE_HEIGHT_SHARE * height
        made.append(f"{sd} foot")
    if reach(hm.head, hm.neck) < MIN_BONE_M:
        spine = rest[hm.head] - rest[hm.torso_base]
        d = spine / np.linalg.norm(spine) if np.linalg.norm(spine) > 1e-9 else up
        tips[hm.head] = d * HEAD_TOP_SHARE * height
        made.append("head")
    if not tips:
        return motion
    par, off = list(sk.end_site_parents), [np.asarray(o, dtype=float) for o in sk.end_site_offsets]
    for joint, vec in tips.items():
        j = sk.index(joint)
        if j in par:
            off[par.index(j)] = vec
        else:
            par.append(j)
            off.append(vec)
    if notes is not None:
        what = " and ".join(made)
        notes.append(f"the skeleton's {what} {'end where they begin' if len(made) > 1 else 'ends where it begins'} "
                     "(no toe or neck joint, an End Site of no length): given a person's proportions for a "
                     f"{height:.2f} m body (a foot {prof.geometry.foot_length_share:g} of the height heel to toe, a "
                     f"head {HEAD_TOP_SHARE:g} of it above its joint)")
    return motion.copy(skeleton=sk.replace(end_site_parents=np.array(par, dtype=np.int64),
                                           end_site_offsets=np.array(off).reshape(-1, 3)))


def _default_profile() -> HumanoidProfile:
    prof = load_profile("humanoid")
    assert isinstance(prof, HumanoidProfile)
    return prof
