"""Named points of a source skeleton (joints and End Sites) in the rest pose or over a motion."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.motion.motion import Motion
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]


def _yaw_matrix(yaw: float) -> FloatArray:
    return Rotation.from_rotvec([0.0, 0.0, yaw]).as_matrix()


class SourcePoints:
    """Positions of joints (by name) and End Sites (``"<joint>/end<k>"``), for one pose (N, 3) or
    over frames (T, N, 3), with the joints' global rotations (T, J, 3, 3) when known."""

    def __init__(self, skeleton: Skeleton, positions: FloatArray, rotations: FloatArray | None = None) -> None:
        self.skeleton = skeleton
        self.positions = positions
        self.rotations = rotations
        names = list(skeleton.names)
        count: dict[int, int] = {}
        for p in skeleton.end_site_parents:
            k = count.get(int(p), 0)
            names.append(f"{skeleton.names[int(p)]}/end{k}")
            count[int(p)] = k + 1
        self.names = names
        self.index = {n: i for i, n in enumerate(names)}

    def __getitem__(self, name: str) -> FloatArray:
        return self.positions[..., self.index[name], :]

    def rotation(self, joint: str) -> FloatArray:
        assert self.rotations is not None
        return self.rotations[..., self.skeleton.index(joint), :, :]

    def turned(self, yaw: float) -> SourcePoints:
        """The same points with the world turned by ``yaw`` rad about +z.

        Joint rotations are rotations away from the rest pose (BVH: identity at rest); turned, they
        are the same rotations seen in the turned frame, ``r R r^T``, so they stay identity in the
        turned rest pose, whose body frames are parallel to the world."""
        r = _yaw_matrix(yaw)
        rot = None if self.rotations is None else np.einsum("ij,...jk,lk->...il", r, self.rotations, r)
        return SourcePoints(self.skeleton, self.positions @ r.T, rot)

    def below(self, joint: str) -> list[str]:
        """``joint``, its descendant joints and the End Sites of all of them, in point order."""
        sub = set(self.skeleton.subtree(self.skeleton.index(joint)))
        return [n for n in self.index if self.skeleton.index(n.split("/end")[0]) in sub]

    def tip(self, joint: str) -> str:
        """The point that ends a joint's bone: its first End Site, else -- none, or one of no length
        (a Perception Neuron foot's) -- the farthest point below it (descendant joints and their End
        Sites: a toe joint on the ankle ending in its End Site), else the joint itself."""
        sk = self.skeleton
        j = sk.index(joint)
        rest = self.positions if self.positions.ndim == 2 else self.positions[0]

        def farthest(names: list[str]) -> str | None:
            d = [float(np.linalg.norm(rest[self.index[n]] - rest[j])) for n in names]
            return names[int(np.argmax(d))] if d and max(d) > 0.0 else None

        below = self.below(joint)
        end = f"{joint}/end0"
        first = (end if end in self.index and np.linalg.norm(rest[self.index[end]] - rest[j]) > 0.0
                 else farthest([n for n in below if n != joint and "/end" not in n]))
        if first is not None:
            return first
        return farthest([n for n in below if "/end" in n]) or joint


def rest_points(motion: Motion) -> SourcePoints:
    """Joint and End Site positions of the skeleton's rest pose (all rotations identity, root at the
    origin), in the motion's frame. Joints with position channels sit at their median animated
    translation rather than their OFFSET: that is where the motion actually holds them."""
    sk = motion.skeleton
    if motion.translations is not None:
        offsets = np.median(motion.translations, axis=0)
        offsets[0] = sk.offsets[0]
        sk = sk.replace(offsets=offsets)
    rest = Motion(skeleton=sk, frame_time=1.0, root_translation=np.zeros((1, 3)),
                  rotations=np.tile([0.0, 0.0, 0.0, 1.0], (1, sk.num_joints, 1)), unit=motion.unit,
                  up=motion.up)
    pos, rot = rest.fk()
    ends = rest.end_site_positions((pos, rot))
    return SourcePoints(motion.skeleton, np.concatenate([pos, ends], axis=1)[0], rot[0])


def motion_points(motion: Motion) -> SourcePoints:
    """Joint and End Site positions and joint rotations on every frame."""
    pos, rot = motion.fk()
    sk = motion.skeleton
    p = sk.end_site_parents
    ends = pos[:, p] + np.einsum("teij,ej->tei", rot[:, p], sk.end_site_offsets)
    return SourcePoints(sk, np.concatenate([pos, ends], axis=1), rot)
