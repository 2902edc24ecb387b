"""A generated dog for the creature-gait tests in a clone without ``../shared``.

The dog's stand-in of ``tests/bvh_fixtures.py`` is the shipped horse on the MANN dog's joint names: a
horse's size, its head held high, straight legs, its joints' frames the horse's (each joint's rest
frame its standing pose, so the walk turns each joint a little). The planned-gait tests check what the
shared dog gives the gait, and that stand-in does not:

- bone-aligned joint frames (each joint's x axis along its bone, as MANN's skeleton has them) and a
  take that starts lying and gets up (as MANN's does): its joints turn far from their rest frames, so
  the ball joints' limits (the largest turn the clip shows, plus a margin) leave the legs room to
  reach their planned feet;
- the root's x axis pointing backward (toward the tail), so a heading read from the root frame and
  one read from the walking direction differ;
- a dog's size and build: about half the horse's size and stepping quicker (dynamically similar), its
  neck carried forward and its head low (a body longer than tall, read as a creature in centimetres
  as the real file is), its legs bent and close together, its tail weighing against its neck and head
  so the centre of mass lies between the shoulders and the hips and each neutral foot stands under
  its leg.

The motion is the shipped horse's four-beat walk (``bipedsim.motion.samples.horse_walk``).
:func:`dog_clip` gives the real file where ``../shared`` is there and the generated one otherwise;
:func:`gliding_dog` and :func:`stretched_dog` are variants with the traits of the shared dog's bred
child (feet that never stand still; legs that reach far one way and little the other). The generated
files are written once per process (per xdist worker).
"""

from __future__ import annotations

import atexit
import functools
import shutil
import tempfile
from pathlib import Path

import numpy as np
from bvh_fixtures import E, J, _rest_positions, _text, _to_file_frame, relaid
from conftest import HAVE_SHARED, SHARED_BVH
from scipy.spatial.transform import Rotation, Slerp

from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.samples import horse_walk

#: the shared MANN dog (lying, getting up, walking)
DOG_REL = "animal/mann_dog_D1_007_KAN01_001_locomotion.bvh"
#: the generated dog's size over the shipped horse's: its root about 0.46 m up (MANN's dog: 0.54 m)
DOG_SCALE = 0.55


#: each leg moved in toward the body's mid-line (m, on the horse): the horse's legs stand 0.15 m out, a
#: dog's hips are about a tenth of their height apart from the mid-line (MANN's: 4.8 cm at 0.46 m)
LEG_INWARD = 0.06
#: the neck's and head's joints on the horse's chest, the head's End Site (m, on the horse)
NECK_AT, HEAD_AT, HEAD_END = (0.30, 0.0, 0.10), (0.55, 0.0, 0.16), (0.30, 0.0, -0.04)
#: the tail's joints on the horse's hips (held still: the horse's tail swings) and its End Site (m, on
#: the horse): about the neck's and head's weight, as far behind the hips as they are ahead of the chest
TAIL_AT, TAIL1_AT, TAIL_END = (-0.15, 0.0, 0.02), (-0.35, 0.0, -0.08), (-0.25, 0.0, -0.25)


def _dog_layout() -> tuple[list[J], list[E]]:
    """The MANN dog's joints (Spine1, shoulders, Tail/Tail1, ZXY) on the horse's, the neck and head on
    its chest, reaching forward and a little up (a dog's, not a horse's), the legs closer together
    (:data:`LEG_INWARD`)."""
    js = [J("Hips", None, "Hips", order="ZXY"), J("Spine", "Hips", "Spine", order="ZXY"),
          J("Spine1", "Spine", "Chest", order="ZXY"), J("Neck", "Spine1", "Chest", NECK_AT, order="ZXY"),
          J("Head", "Neck", "Chest", HEAD_AT, order="ZXY")]
    ends = [E("Head", HEAD_END)]
    for side, w in (("Left", 1.0), ("Right", -1.0)):
        inward = (0.0, -w * LEG_INWARD, 0.0)
        js += [J(f"{side}Shoulder", "Spine1", "Chest", (0.08, w * 0.05, -0.05), order="ZXY"),
               J(f"{side}Arm", f"{side}Shoulder", f"{side}Arm", inward, order="ZXY"),
               J(f"{side}ForeArm", f"{side}Arm", f"{side}ForeArm", inward, order="ZXY"),
               J(f"{side}Hand", f"{side}ForeArm", f"{side}Hand", inward, order="ZXY")]
        ends.append(E(f"{side}Hand", (0.06, 0.0, -0.08)))
    for side, w in (("Left", 1.0), ("Right", -1.0)):
        inward = (0.0, -w * LEG_INWARD, 0.0)
        js += [J(f"{side}UpLeg", "Hips", f"{side}UpLeg", inward, order="ZXY"),
               J(f"{side}Leg", f"{side}UpLeg", f"{side}Leg", inward, order="ZXY"),
               J(f"{side}Foot", f"{side}Leg", f"{side}Foot", inward, order="ZXY")]
        ends.append(E(f"{side}Foot", (0.06, 0.0, -0.08)))
    js += [J("Tail", "Hips", "Hips", TAIL_AT, order="ZXY"), J("Tail1", "Tail", "Hips", TAIL1_AT, order="ZXY")]
    ends.append(E("Tail1", TAIL_END))
    return js, ends


#: the lying pose in the horse's joint frames: each leg joint's turn about its y axis (rad; negative
#: turns a bone forward): hind legs folded under the body, fore legs folded back beneath the chest
LYING_TURNS = {"UpLeg": -1.3, "Leg": 2.4, "Foot": -1.2, "Shoulder": 0.6, "Arm": 1.0, "ForeArm": -2.2, "Hand": 2.0}
#: seconds lying, then rising to the walk's first pose
LIE_S, RISE_S = 0.8, 0.7


#: gait cycles of the horse's walk the dog walks (0.82 s each at its size)
WALK_CYCLES = 4
#: the legs' bend in the walk (rad): the horse's legs stand straight, a dog's zig-zag (thigh and upper arm
#: forward, shin and forearm back, the paw level again), so its feet move on from a bent knee or elbow
BEND = 0.55


def _bent(walk: Motion, trail: float = 0.0) -> Motion:
    """``walk`` with each leg bent by :data:`BEND` at its three joints (forward, back twice as far,
    forward: the foot keeps its attitude), the root lowered so the feet meet the floor as before.
    ``trail`` (rad) turns the hind legs back at the hip as well (the paws kept level): hind feet that
    stand behind the hips, with room to reach forward and little to reach back."""
    sk = walk.skeleton
    rot = Rotation.from_quat(walk.rotations.reshape(-1, 4)).as_matrix().reshape(walk.rotations.shape[:2] + (3, 3))
    for side in ("Left", "Right"):
        for top, mid, paw in (("UpLeg", "Leg", "Foot"), ("Arm", "ForeArm", "Hand")):
            back = trail if top == "UpLeg" else 0.0
            for name, k in ((top, -BEND + back), (mid, 2.0 * BEND), (paw, -BEND - back)):
                j = sk.index(f"{side}{name}")
                rot[:, j] = Rotation.from_euler("y", k).as_matrix() @ rot[:, j]
    quat = canonical_quat(Rotation.from_matrix(rot.reshape(-1, 3, 3)).as_quat().reshape(walk.rotations.shape))
    bent = walk.copy(rotations=quat)

    def lowest(m: Motion) -> float:
        fk = m.fk()
        return float(min(fk[0][..., 2].min(), m.end_site_positions(fk)[..., 2].min()))

    return bent.copy(root_translation=bent.root_translation - [0.0, 0.0, lowest(bent) - lowest(walk)])


def _lying_then_walking(walk: Motion) -> Motion:
    """``walk`` after :data:`LIE_S` lying on folded legs and :data:`RISE_S` getting up (the turns and the
    root slerped and lerped to the walk's first frame): a take that starts lying, as MANN's does, so its
    joints turn far and the ball joints' limits measured from it leave the legs room."""
    sk = walk.skeleton
    lying = np.tile([0.0, 0.0, 0.0, 1.0], (sk.num_joints, 1))
    for k, name in enumerate(sk.names):
        for part, angle in LYING_TURNS.items():
            if name in (f"Left{part}", f"Right{part}"):
                lying[k] = Rotation.from_euler("y", angle).as_quat()
    pose = walk[:1].copy(rotations=lying[None], root_translation=walk.root_translation[:1] * [1.0, 1.0, 0.0])
    pos, _ = pose.fk()
    low = min(pos[0, :, 2].min(), pose.end_site_positions()[0, :, 2].min())
    root_lying = walk.root_translation[0] - [0.0, 0.0, low + walk.root_translation[0, 2]]
    n_lie, n_rise = round(LIE_S / walk.frame_time), round(RISE_S / walk.frame_time)
    s = np.clip(np.arange(n_rise) / n_rise, 0.0, 1.0)
    s = s * s * (3.0 - 2.0 * s)  # eased in and out
    rise = np.empty((n_rise, sk.num_joints, 4))
    for k in range(sk.num_joints):
        rise[:, k] = Slerp([0.0, 1.0], Rotation.from_quat([lying[k], walk.rotations[0, k]]))(s).as_quat()
    root = np.concatenate([np.tile(root_lying, (n_lie, 1)),
                           root_lying + s[:, None] * (walk.root_translation[0] - root_lying), walk.root_translation])
    rot = np.concatenate([np.tile(lying, (n_lie, 1, 1)), rise, walk.rotations])
    return walk.copy(root_translation=root, rotations=canonical_quat(rot))


def _frame_along(x: np.ndarray) -> np.ndarray:
    """A rotation matrix whose x axis is ``x`` (normalised) and whose y axis is the nearest to the
    world's y (the body's left): bones in the body's mid-plane turn about y alone from one to the next,
    so a joint's turn in its rest frame is the bend it shows, not a half turn of frames."""
    x = x / np.linalg.norm(x)
    ref = np.array([0.0, 1.0, 0.0]) if abs(x[1]) < 0.9 else np.array([0.0, 0.0, 1.0])
    y = ref - (ref @ x) * x
    y /= np.linalg.norm(y)
    return np.stack([x, y, np.cross(x, y)], axis=1)


def bone_aligned(m: Motion, root_x: tuple[float, float, float]) -> Motion:
    """``m`` (a rest pose of identity rotations) with each joint's frame turned so its x axis runs along
    its bone (to its first child set apart from it, or its End Site) and the root's along ``root_x``
    (in the rest pose); forward kinematics is unchanged."""
    sk = m.skeleton
    rest = _rest_positions(sk)
    base = np.tile(np.eye(3), (sk.num_joints, 1, 1))
    for j in range(sk.num_joints):
        bones = [rest[k] - rest[j] for k in range(sk.num_joints) if sk.parents[k] == j]
        bones += [sk.end_site_offsets[e] for e, p in enumerate(sk.end_site_parents) if p == j]
        bones = [b for b in bones if np.linalg.norm(b) > 1e-9]
        if j == 0:
            bones = [np.asarray(root_x, dtype=float)]
        if bones:
            base[j] = _frame_along(bones[0])
    return m.reframed(base)


def dog_like(glide: float = 1.0, trail: float = 0.0) -> Motion:
    """The generated dog (metres, Z up, 60 fps): the horse's walk at :data:`DOG_SCALE` of its size and
    moving as a body of that size does (dynamically similar: a quicker step), after lying and getting
    up, on :func:`_dog_layout` with bone-aligned frames and its root's x axis toward the tail. ``glide``
    multiplies the root's travel: above 1 the body runs ahead of its legs, so no foot ever stands still
    (a stance foot slides forward at ``glide - 1`` times the walking speed)."""
    walk = _bent(horse_walk(cycles=WALK_CYCLES), trail)
    walk = walk.copy(root_translation=walk.root_translation * [glide, glide, 1.0])
    m = _lying_then_walking(relaid(walk, *_dog_layout())).similar(DOG_SCALE)
    return bone_aligned(m, root_x=(-1.0, 0.0, 0.0)).resample(60.0)


@functools.cache
def _generated_dir() -> Path:
    root = Path(tempfile.mkdtemp(prefix="bipedsim-dog-"))
    atexit.register(shutil.rmtree, root, ignore_errors=True)
    return root


@functools.cache
def _generated_dog(glide: float = 1.0, trail: float = 0.0) -> Path:
    path = _generated_dir() / f"dog_like_glide{glide:g}_trail{trail:g}.bvh"
    # written as the MANN file is: centimetres, Y up, CRLF, a tab after "Frames:"
    path.write_bytes(_text(_to_file_frame(dog_like(glide, trail), 0.01, "y", None), eol="\r\n", frames_tab=True))
    return path


def dog_clip() -> Path:
    """The shared MANN dog where ``../shared`` is there, else the generated dog (:func:`dog_like`)."""
    return SHARED_BVH / DOG_REL if HAVE_SHARED else _generated_dog()


#: the gliding dog's root travel over its legs' walk: its stance feet slide forward at the walking
#: speed, about 1 m/s, twice a creature's contact speed (``reference.retarget``: 0.5 m/s)
GLIDE = 2.0


def gliding_dog() -> Path:
    """The generated dog gliding ahead of its legs (:func:`dog_like` with :data:`GLIDE`): a clip whose
    feet never stand still, so it labels no foot contact while it walks."""
    return _generated_dog(GLIDE)


#: the stretched dog's hind legs turned back at the hip (rad)
TRAIL = 0.7


def stretched_dog() -> Path:
    """The generated dog standing stretched (:func:`dog_like` with :data:`TRAIL`): its hind feet behind
    its hips and, the stance centred under its body, its fore feet ahead of its shoulders, so each leg
    reaches much further one way than the other (the hind legs forward, the fore legs back)."""
    return _generated_dog(1.0, TRAIL)
