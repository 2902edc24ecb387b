"""Generated clips for the motion-graph and motion-tile-world tests in a clone without ``../shared``.

The example graph (``examples/graphs/walk_wave.yaml``) joins the shared CMU walk and wave: the wave's
performer steps while waving, so the two takes share poses and the graph moves between them. The
stand-ins of ``tests/bvh_fixtures.py`` (the generated walk, and a wave standing in the rest pose)
share none: their walk and wave fall apart into two graphs. Here, on Holden's 31-joint skeleton with
its rest pose, as the shared files are:

- the walk (2.8 s, as CMU 02_01): the generated walk, its pace rising a little over the clip and
  wobbling (no window of it repeats another exactly, and each step offers the graph a way on, as a
  person's walk does), its right arm swinging out from the body (the walk and its mirror differ, as a
  person's do);
- the wave (4.3 s): another take of the same walker, walking on with a smaller arm swing: the right
  arm rises sideways, waves twice a second and comes down again. Its arm-down walking leads to and
  from the walk; the example's ``stand`` clip (its first 0.8 s) is some of it.

Where a graph's transitions fall follows from the takes' phases and paces; the player's checks (a
script's length, random scripts reaching every motion) pass on these. Another phase can leave a
script longer than the tests allow or the player's route short of a motion it could reach.

The example world's dog (``examples/worlds/dog.yaml``, the shared MANN take: lying, getting up,
walking) gets the dog's stand-in (the shipped horse's walk on the MANN skeleton) after a stand in its
rest pose: a clip with an idle part and a walking part, as the world cuts them. The Bandai-Namco walk's
stand-in is laid out as the real take is: under a static ``joint_Root`` at the floor, with position
channels on every joint.

Each function gives the real files where ``../shared`` is there and the generated ones otherwise; the
generated files are written once per process (per xdist worker) into a folder laid out as
``../shared/data/bvh`` is, in the file frame of the shared files they stand for.
"""

from __future__ import annotations

import atexit
import functools
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
from bvh_fixtures import PRECISION, STANDINS, _holden31, _splayed_rest, relaid, rest_turned, six_channels, standin
from conftest import GRAPH_EXAMPLE, HAVE_SHARED, SHARED_BVH, example_graph_config
from scipy.spatial.transform import Rotation, Slerp

from bipedsim.motion import load_bvh
from bipedsim.motion.bvh import bvh_text
from bipedsim.motion.gaitgen import WalkParams, generate_walk, walk_skeleton
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.reroot import add_static_root

#: the shared files these stand for (``SHARED_BVH``-relative)
WALK_REL = "human/cmu_02_01_walk__holden31_crlf.bvh"
WAVE_REL = "human/cmu_141_16_wave_hello__holden31_crlf.bvh"
DOG_REL = "animal/mann_dog_D1_007_KAN01_001_locomotion.bvh"
#: the example worlds
WORLDS = Path(__file__).resolve().parents[2] / "examples" / "worlds"
#: frames per second the generated walk and wave are written at (the example graph plays at 30)
FPS = 30.0
#: the walker: the generated walk with the elbows nearly straight (the hands hang at the hips, as a
#: person's do)
WALKER = WalkParams(elbow_bend=0.15)
#: how far the walker's right arm swings out from the body (rad): the walk's asymmetry, which makes
#: the wave (right arm up) the closer of the wave and its mirror to the walk
ARM_OUT = 0.25
#: how long one wobble of the walker's pace takes (s)
WOBBLE_S = 1.3
#: the walk: its length (s), its pace's steady change over the clip and its wobble (shares), and where
#: in the generated walk it starts (s)
WALK_SECONDS, WALK_PACE, WALK_WOBBLE, WALK_START = 2.8, 0.1, 0.05, 0.45
#: the wave: the same, and the walker's arm swing in that take
WAVE_SECONDS, WAVE_PACE, WAVE_WOBBLE, WAVE_START = 4.3, -0.1, 0.04, 0.55
WAVE_WALKER = replace(WALKER, arm_swing=0.18)
#: when the wave's arm rises and comes down (s)
WAVE_RAISE, WAVE_LOWER = (1.4, 1.8), (3.0, 3.4)
#: the dog's stand before it walks and its blend from the stand into the walk (s)
DOG_STAND_S, DOG_START_S = 1.6, 0.4


def _smooth(s: np.ndarray) -> np.ndarray:
    """Minimum-jerk 0 -> 1 over s in [0, 1]."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def _sample(m: Motion, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The root translation and the joint rotations of ``m`` at ``times`` (s): linear and slerp."""
    t = np.arange(m.num_frames) * m.frame_time
    root = np.stack([np.interp(times, t, m.root_translation[:, c]) for c in range(3)], axis=1)
    rot = np.stack([Slerp(t, Rotation.from_quat(m.rotations[:, j]))(times).as_quat()
                    for j in range(m.num_joints)], axis=1)
    return root, rot


def _blend(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Per frame the slerp from quaternions ``a`` (T, 4) to ``b`` by ``w`` (T,)."""
    ra, rb = Rotation.from_quat(a), Rotation.from_quat(b)
    return (ra * Rotation.from_rotvec(w[:, None] * (ra.inv() * rb).as_rotvec())).as_quat()


def _walker(params: WalkParams, seconds: float, pace: float, wobble: float, start_s: float,
            raised: np.ndarray | None = None) -> Motion:
    """The walker on the generated skeleton (metres, Z up, along +X) at :data:`FPS` for ``seconds``:
    the walk of ``params`` from ``start_s`` in, its pace changing steadily by ``pace`` over the clip and
    wobbling by ``wobble`` (shares), the right arm out by :data:`ARM_OUT`; the right arm raised sideways
    and waved by ``raised`` (per frame, 0 to 1)."""
    sk = walk_skeleton()
    t = np.arange(int(round(seconds * FPS)) + 1) / FPS
    # the walk's own time, at the changing pace
    rate = 1.0 + pace * (t / t[-1] - 0.5) + wobble * np.sin(2 * np.pi * t / WOBBLE_S)
    own = np.concatenate([[0.0], np.cumsum((rate[1:] + rate[:-1]) / 2) / FPS])
    cycle = 120.0 / params.resolved()[2]
    walk = generate_walk(replace(params, cycles=int((own[-1] + start_s) / cycle) + 2))
    root, rot = _sample(walk, start_s + own)
    arm, fore = sk.index("RightArm"), sk.index("RightForeArm")
    rot[:, arm] = (Rotation.from_euler("X", -ARM_OUT) * Rotation.from_quat(rot[:, arm])).as_quat()
    if raised is not None:  # the arm out to the side and up, the forearm waving twice a second
        up = Rotation.from_euler("X", (-2.4 * raised)[:, None]).as_quat()
        wave = Rotation.from_euler("X", (-0.4 * raised * np.sin(2 * np.pi * 2.0 * t))[:, None]).as_quat()
        rot[:, arm] = _blend(rot[:, arm], up, raised)
        rot[:, fore] = _blend(rot[:, fore], wave, raised)
    return Motion(skeleton=sk, frame_time=1.0 / FPS, root_translation=root, rotations=canonical_quat(rot),
                  unit=1.0, up="z")


def _holden(m: Motion) -> Motion:
    """``m`` on Holden's CMU skeleton with its rest pose (legs splayed, feet pointing down)."""
    js, ends = _holden31()
    h = relaid(m, js, ends)
    return rest_turned(h, {**_splayed_rest(h, "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", 1.0),
                           **_splayed_rest(h, "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase", -1.0)})


def generated_walk() -> Motion:
    """The walk (project frame)."""
    return _holden(_walker(WALKER, WALK_SECONDS, WALK_PACE, WALK_WOBBLE, WALK_START))


def generated_wave() -> Motion:
    """The wave: the walker walking on, waving with the right arm (project frame)."""
    t = np.arange(int(round(WAVE_SECONDS * FPS)) + 1) / FPS
    raised = _smooth((t - WAVE_RAISE[0]) / (WAVE_RAISE[1] - WAVE_RAISE[0])) - _smooth(
        (t - WAVE_LOWER[0]) / (WAVE_LOWER[1] - WAVE_LOWER[0]))
    return _holden(_walker(WAVE_WALKER, WAVE_SECONDS, WAVE_PACE, WAVE_WOBBLE, WAVE_START, raised))


@functools.cache
def _generated_dir() -> Path:
    """A folder laid out as ``../shared/data/bvh`` for the generated files, removed at exit."""
    root = Path(tempfile.mkdtemp(prefix="bipedsim-synthesis-clips-"))
    atexit.register(shutil.rmtree, root, ignore_errors=True)
    (root / "human").mkdir()
    (root / "animal").mkdir()
    return root


def _write(m: Motion, rel: str) -> Path:
    """``m`` written in the file frame of the shared file ``rel`` stands for (its unit and up axis)."""
    _, unit_m, up, _, _ = STANDINS[rel]
    path = _generated_dir() / rel
    path.write_text(bvh_text(m.with_up(up).scaled(1.0 / unit_m), precision=PRECISION))
    return path


@functools.cache
def _walk_wave_dir() -> Path:
    """The folder of the generated walk and wave, written once."""
    _write(generated_walk(), WALK_REL)
    _write(generated_wave(), WAVE_REL)
    return _generated_dir()


def walk_wave() -> tuple[Path, Path]:
    """The walk and the wave of the example graph: the shared CMU files, or the generated ones."""
    folder = SHARED_BVH if HAVE_SHARED else _walk_wave_dir()
    return folder / WALK_REL, folder / WAVE_REL


def graph_config(folder: Path) -> Path:
    """The example graph's YAML written into ``folder``, its clips read from the shared walk and wave or
    without ``../shared`` from the generated ones."""
    if HAVE_SHARED:
        return example_graph_config(folder)
    path = folder / GRAPH_EXAMPLE.name
    path.write_text(GRAPH_EXAMPLE.read_text().replace("../../../shared/data/bvh", str(_walk_wave_dir())))
    return path


def generated_dog() -> Motion:
    """The dog's stand-in (project frame) after :data:`DOG_STAND_S` standing in its rest pose (the
    shipped horse's standing pose), the tail wagging and the head turning a little, and a blend of
    :data:`DOG_START_S` into the walk."""
    walk = load_bvh(standin(DOG_REL)).to_project_frame()
    sk = walk.skeleton
    n_stand, n_blend = int(round(DOG_STAND_S * walk.fps)), int(round(DOG_START_S * walk.fps))
    t = np.arange(n_stand) * walk.frame_time
    stand = np.zeros((n_stand, sk.num_joints, 4))
    stand[..., 3] = 1.0
    stand[:, 0] = walk.rotations[0, 0]
    stand[:, sk.index("Tail")] = Rotation.from_euler("z", (0.3 * np.sin(2 * np.pi * 1.5 * t))[:, None]).as_quat()
    stand[:, sk.index("Neck")] = Rotation.from_euler("z", (0.1 * np.sin(2 * np.pi * 0.4 * t))[:, None]).as_quat()
    w = _smooth(np.arange(1, n_blend + 1) / n_blend)
    rest = np.broadcast_to(stand[-1], (n_blend, sk.num_joints, 4)).reshape(-1, 4)
    start = _blend(rest, walk.rotations[:n_blend].reshape(-1, 4), np.repeat(w, sk.num_joints))
    rot = np.concatenate([stand, start.reshape(n_blend, -1, 4), walk.rotations[n_blend:]])
    root = np.concatenate([np.repeat(walk.root_translation[:1], n_stand, axis=0), walk.root_translation])
    return walk.copy(root_translation=root, rotations=canonical_quat(rot))


@functools.cache
def _dog_path() -> Path:
    """The generated dog's file, written once."""
    return _write(generated_dog(), DOG_REL)


def dog_clip() -> Path:
    """The dog's clip: the shared MANN take, or the generated stand and walk."""
    return SHARED_BVH / DOG_REL if HAVE_SHARED else _dog_path()


def dog_creature(folder: Path) -> Path:
    """The example world's dog (``examples/worlds/dog.yaml``) written into ``folder``, its walk and idle
    clip :func:`dog_clip`."""
    text = (WORLDS / "dog.yaml").read_text().replace(f"../../../shared/data/bvh/{DOG_REL}", str(dog_clip()))
    path = folder / "dog.yaml"
    path.write_text(text)
    return path


#: the shared Bandai-Namco walk (``SHARED_BVH``-relative)
BANDAI_REL = "human/bandai2_walk_exhausted_001.bvh"
#: the hips' OFFSET (m, Z up), about 4 m from the origin as the real take's is: its rest pose only, the
#: position channels replace it
BANDAI_HIPS_OFFSET = (-4.27, 0.05, 0.91)


@functools.cache
def _bandai_path() -> Path:
    """The Bandai walk's stand-in laid out as the real take is: under a static ``joint_Root`` at the floor
    (the translation on the hips), position channels on every joint, the hips' OFFSET away from the
    origin; written once."""
    s = six_channels(add_static_root(load_bvh(standin(BANDAI_REL))))
    sk = s.skeleton
    offsets = sk.offsets.copy()
    offsets[sk.index("Hips")] = BANDAI_HIPS_OFFSET
    return _write(s.copy(skeleton=sk.replace(offsets=offsets)), BANDAI_REL)


def bandai_walk() -> Path:
    """The Bandai walk: the shared take, or its stand-in under a static root (:func:`_bandai_path`)."""
    return SHARED_BVH / BANDAI_REL if HAVE_SHARED else _bandai_path()
