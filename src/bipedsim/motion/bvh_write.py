"""Write a :class:`~bipedsim.motion.motion.Motion` as BVH text or a BVH file, in the motion's own units and
axes, with each joint's channel order preserved.
"""

from __future__ import annotations

import os

import numpy as np
import numpy.typing as npt

from bipedsim.files import atomic_write_text
from bipedsim.motion.bvh_channels import motion_to_channels
from bipedsim.motion.motion import Motion

FloatArray = npt.NDArray[np.float64]


def _fmt(values: FloatArray, precision: int | None) -> list[str]:
    if precision is None:
        return [repr(float(v)) for v in values]  # shortest text that reads back exactly
    # + 0.0 turns -0.0 into 0.0, and a value that rounds to zero is written "0.000000", never
    # "-0.000000": float noise around zero (1e-15 on one machine, -1e-15 on another) must not change the text
    zero = 0.5 * 10.0 ** -precision
    return [f"{(v if abs(v) >= zero else 0.0) + 0.0:.{precision}f}" for v in values]


def _depth_first(motion: Motion) -> Motion:
    """The motion with its joints in depth-first order, the order a BVH hierarchy lists them (and its
    channel columns follow): a skeleton built otherwise (joints appended under earlier parents, as a
    bred meta-skeleton is) would otherwise be written with its columns under the wrong joints."""
    sk = motion.skeleton
    kids: dict[int, list[int]] = {j: [] for j in range(sk.num_joints)}
    for j in range(1, sk.num_joints):
        kids[int(sk.parents[j])].append(j)
    order: list[int] = []
    stack = [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(kids[j]))
    if order == list(range(sk.num_joints)):
        return motion
    new = {j: k for k, j in enumerate(order)}
    skel = sk.replace(names=tuple(sk.names[j] for j in order),
                      parents=np.array([-1 if sk.parents[j] < 0 else new[int(sk.parents[j])] for j in order]),
                      offsets=sk.offsets[order], channels=tuple(sk.channels[j] for j in order),
                      position_modes=tuple(sk.position_modes[j] for j in order) if sk.position_modes else (),
                      end_site_parents=np.array([new[int(p)] for p in sk.end_site_parents], dtype=np.int64))
    return motion.copy(skeleton=skel, rotations=motion.rotations[:, order],
                       translations=None if motion.translations is None else motion.translations[:, order])


def _unambiguous_root(motion: Motion) -> Motion:
    """The motion with a translating root's OFFSET written as zero and its channels absolute.

    Readers disagree on whether position channels replace the OFFSET or add to it (``load_bvh``
    guesses per file). With a zero root OFFSET both readings give the same root path, so a file this
    project writes never depends on the guess (a world output whose root OFFSET was the source clip's
    4.7 m read back 4.7 m off). The root's OFFSET has no bone behind it, so nothing else changes."""
    sk = motion.skeleton
    if not sk.has_positions(0) or not np.any(sk.offsets[0]):
        return motion
    root = motion.root_translation.copy()
    offsets = sk.offsets.copy()
    offsets[0] = 0.0
    modes = ("replace", *sk.position_modes[1:]) if sk.position_modes else ()
    return motion.copy(skeleton=sk.replace(offsets=offsets, position_modes=modes), root_translation=root)


def bvh_text(motion: Motion, *, precision: int | None = None) -> str:
    """The BVH text of a motion (LF line endings, tab indentation).

    ``precision``: decimals per value; ``None`` writes the shortest exact representation so the file
    reads back to the same numbers.
    """
    motion = _unambiguous_root(_depth_first(motion))
    sk = motion.skeleton
    out: list[str] = ["HIERARCHY"]
    children: dict[int, list[int]] = {j: [] for j in range(sk.num_joints)}
    for j in range(1, sk.num_joints):
        children[int(sk.parents[j])].append(j)
    ends: dict[int, list[int]] = {}
    for e, p in enumerate(sk.end_site_parents):
        ends.setdefault(int(p), []).append(e)

    def off(v: FloatArray) -> str:
        return " ".join(_fmt(v, precision))

    def emit(j: int, depth: int) -> None:
        ind = "\t" * depth
        out.append(f"{ind}{'ROOT' if j == 0 else 'JOINT'} {sk.names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET {off(sk.offsets[j])}")
        if sk.channels[j] or j == 0:
            out.append(f"{ind}\tCHANNELS {len(sk.channels[j])}" +
                       "".join(" " + c for c in sk.channels[j]))
        for c in children[j]:
            emit(c, depth + 1)
        for e in ends.get(j, []):
            out.append(f"{ind}\tEnd Site")
            out.append(f"{ind}\t{{")
            out.append(f"{ind}\t\tOFFSET {off(sk.end_site_offsets[e])}")
            out.append(f"{ind}\t}}")
        out.append(f"{ind}}}")

    emit(0, 0)
    out.append("MOTION")
    out.append(f"Frames: {motion.num_frames}")
    out.append(f"Frame Time: {motion.frame_time!r}")
    data = motion_to_channels(motion)
    for row in data:
        out.append(" ".join(_fmt(row, precision)))
    return "\n".join(out) + "\n"


def write_bvh(motion: Motion, path: str | os.PathLike[str], *, precision: int | None = None) -> None:
    """Write a motion as BVH, atomically (temporary file + rename), in the motion's own units and
    axes, with each joint's channel order preserved."""
    atomic_write_text(path, bvh_text(motion, precision=precision))
