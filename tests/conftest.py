from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

if TYPE_CHECKING:
    from bipedsim.control.settings import ControllerConfig

REPO = Path(__file__).resolve().parent.parent
# runs in the suite track with the feedback controller alone: the per-clip search takes tens of seconds a
# clip and has tests of its own (tests/sim/test_reconstruct.py), which ask for it explicitly; set here so
# the suite's subprocesses inherit it
os.environ.setdefault("BIPEDSIM_RECONSTRUCT", "off")
#: The real BVH samples beside the repository (``../shared/data/bvh``); ``BIPEDSIM_SHARED_DATA`` names
#: another data folder (its ``bvh/`` is read), or a missing one to run the suite as a fresh clone does
SHARED_DATA = Path(os.environ.get("BIPEDSIM_SHARED_DATA", REPO.parent / "shared" / "data"))
#: whether the real samples are there (``need_shared`` skips the tests of their own numbers otherwise)
HAVE_SHARED = (SHARED_DATA / "bvh").is_dir()
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bvh_fixtures import standin_dir  # noqa: E402 (tests/ on the path first)

#: The folder of BVH files laid out as ``../shared/data/bvh`` (human/, animal/, odd/): the real samples,
#: or without them the generated stand-ins in their layouts (``bvh_fixtures.py``, a subset of the names)
SHARED_BVH = SHARED_DATA / "bvh" if HAVE_SHARED else standin_dir()


def shared_files(sub: str = "*") -> list[Path]:
    """The BVH files of folder ``sub`` (human, animal, odd) of :data:`SHARED_BVH`."""
    return sorted(SHARED_BVH.glob(f"{sub}/*.bvh"))


def shared_or_standin(rel: str) -> Path:
    """The file ``rel`` (``"human/NAME.bvh"``) of :data:`SHARED_BVH`: the real one, or without ``../shared``
    its generated stand-in; a skip when it has none."""
    path = SHARED_BVH / rel
    if not path.is_file():
        pytest.skip(f"shared BVH data not found at {SHARED_DATA / 'bvh'} and {rel} has no generated stand-in")
    return path


def need_shared() -> None:
    """Skip unless the real samples are there: for the tests of a real file's own numbers."""
    if not HAVE_SHARED:
        pytest.skip(f"shared BVH data not found at {SHARED_DATA / 'bvh'} (it lives beside the repository)")


#: the example motion graph (the shared CMU walk and wave on Holden's skeleton)
GRAPH_EXAMPLE = REPO / "examples" / "graphs" / "walk_wave.yaml"


def example_graph_config(folder: Path) -> Path:
    """The example graph's YAML written into ``folder`` with its clips read from :data:`SHARED_BVH`: the
    real walk and wave, or without ``../shared`` their generated stand-ins."""
    text = GRAPH_EXAMPLE.read_text().replace("../../../shared/data/bvh", str(SHARED_BVH))
    path = folder / GRAPH_EXAMPLE.name
    path.write_text(text)
    return path


@pytest.fixture
def shared_dir() -> Path:
    """:data:`SHARED_BVH`: the real samples, or their stand-ins (for the tests of a layout's properties)."""
    return SHARED_BVH


def shared_params(sub: str = "*"):
    """``shared_files(sub)`` as parameters named by file (stand-ins without ``../shared``)."""
    files = shared_files(sub)
    if not files:
        return [pytest.param(None, marks=pytest.mark.skip(
            reason=f"shared BVH data not found at {SHARED_BVH}"))]
    return [pytest.param(f, id=f.name) for f in files]


#: a clip whose root moves slower than this (m/s, horizontal) is "in place" (a walk cycle without
#: root travel, a gesture, a pose); the shared walks travel at 0.5-1.3 m/s
IN_PLACE_SPEED = 0.2


class SharedFile:
    """What a test may expect of a shared BVH file, measured from the file, not from its name: its
    folder says human / animal / odd; ``travels`` whether its root moves (a walk that goes somewhere)
    or stays (in place, a gesture); ``names`` its joint names. A file added to ``../shared`` is
    classified the same way, so the tests say what each kind must do and keep passing."""

    def __init__(self, path: Path) -> None:
        from bipedsim.motion import load_bvh

        self.path = path
        self.folder = path.parent.name
        m = load_bvh(path)
        root = m.root_translation[:, :2]
        self.speed = float(np.linalg.norm(root[-1] - root[0]) / m.duration) if m.duration > 0 else 0.0
        self.travels = self.speed >= IN_PLACE_SPEED
        self.names = set(m.skeleton.names)

    def __repr__(self) -> str:
        return f"SharedFile({self.path.name}: {self.folder}, {'travels' if self.travels else 'in place'})"


def looped(cfg: ControllerConfig) -> ControllerConfig:
    """``cfg`` tracking the clip's best cycle looped from its first strike (``source: cycle``): the
    setting in which the counterfactual tests of balance terms were measured (a whole clip's start and
    end shift every later step's phase)."""
    from dataclasses import replace

    return replace(cfg, source="cycle")


def without_modulation(cfg: ControllerConfig) -> ControllerConfig:
    """``cfg`` with the reference modulation a capture gets by default (swing-foot IK, stance-ankle
    feedback) off: the setting in which the counterfactual tests of velocity tuning, the Froude-scheduled
    c_d, the stance foot's yaw limit and the course frame were measured. With the modulation on these
    features still help but their counterfactuals no longer fail as they did (docs/controller.md,
    *Public walks we do not ship*)."""
    from dataclasses import replace

    mod = cfg.modulation
    return replace(cfg, modulation=replace(mod, swing_foot=replace(mod.swing_foot, enabled=False),
                                           stance_ankle=replace(mod.stance_ankle, enabled=False)))


@contextmanager
def toes_as_measured() -> Iterator[None]:
    """Bodies built inside it get short toes: a toe whose skeleton gives no tip (Bandai-Namco's, the
    Holden CMU layouts') stops at its 3 cm minimum instead of reaching a person's foot length. The
    counterfactual tests whose contrast shows on such bodies build their scenario in it: with the
    real-length toes both sides of some contrasts walk."""
    from bipedsim.model import humanoid

    builder = humanoid._HumanoidBuilder
    saved = builder.toe_length_without_tip
    builder.toe_length_without_tip = lambda self, side, foot_frame: humanoid.MIN_TOE_M  # type: ignore[method-assign]
    try:
        yield
    finally:
        builder.toe_length_without_tip = saved  # type: ignore[method-assign]


def swing_as_measured(cfg: ControllerConfig) -> ControllerConfig:
    """``cfg`` with a slower swing -- the hips' torque limits on the actuator alone (``pd.net_limit:
    off``, so a hip driven at its limit tops out at limit / kd) and the sagittal c_v 0.2 (scaled to the
    body as the rest: the ratio to the default's 0.15) -- the setting in which the counterfactual tests
    of the step tempo, the velocity tuning, the Froude-scheduled c_d, the sync and the course law show
    their contrast. With the swing hip's net limit the swing reaches its reference, and some of those
    contrasts do not fail on their weaker side."""
    from dataclasses import replace

    from bipedsim.control.settings import ControllerConfig

    default = ControllerConfig().balance.sagittal.cv
    sag = cfg.balance.sagittal
    return replace(cfg, pd=replace(cfg.pd, net_limit="off"),
                   balance=replace(cfg.balance, sagittal=replace(sag, cv=sag.cv * 0.2 / default)))


def velocity_as_measured(cfg: ControllerConfig) -> ControllerConfig:
    """``cfg`` with a faster speed low-pass for the velocity tuning -- 0.75 s (scaled to the body as the
    rest: the ratio to the default's 1.0 s) -- the setting in which the counterfactual tests of the
    velocity tuning and the torso law show their contrast."""
    from dataclasses import replace

    from bipedsim.control.settings import ControllerConfig

    default = ControllerConfig().balance.velocity.filter_s
    vel = cfg.balance.velocity
    return replace(cfg, balance=replace(cfg.balance, velocity=replace(vel, filter_s=vel.filter_s * 0.75 / default)))


def torso_as_measured(cfg: ControllerConfig) -> ControllerConfig:
    """``cfg`` with a softer torso law -- damping 100 (scaled to the body as the rest: the ratio to the
    default's 175) and the stance foot's yaw limit 0.35 rad -- the setting in which the counterfactual
    tests of the step tempo, the velocity tuning, the Froude-scheduled c_d, the stance foot's yaw limit and
    the torso twist show their contrast, and the course law's heading without the crab's compensation
    (``crab_filter_s: 0``), as they were measured. With the default torso law (175, 0.6) the body is
    steadier and both sides of these contrasts survive or keep their speed."""
    from dataclasses import replace

    from bipedsim.control.settings import ControllerConfig

    default = ControllerConfig().balance.torso_kd
    return replace(cfg, balance=replace(cfg.balance, torso_kd=cfg.balance.torso_kd * 100.0 / default,
                                        stance_yaw_limit=0.35, course=replace(cfg.balance.course, crab_filter_s=0.0)))
