"""Export what the simulated body did as motion on the source skeleton (BVH) and as joint-angle CSV.

Every source joint that starts a body takes that body's simulated world rotation; joints inside a
body (between its joint and the joints of its child bodies: CMU's hip helpers, extra spine links,
clavicles) stay rigid; joints the physics skeleton dropped (fingers, the head's inner links, toe
tips) keep their reference rotation. The root follows the pelvis. The result is in the source's
facing (the model's heading turn undone), metres, Z up; :func:`write_motion_bvh` converts it to the
source file's unit and up axis.
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import mujoco
import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.files import atomic_write_text
from bipedsim.model.plan import BodyPlanSet
from bipedsim.model.source import rest_points
from bipedsim.motion.bvh import write_bvh
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.sim.recorder import Trajectory

FloatArray = npt.NDArray[np.float64]


def _yaw(yaw: float) -> FloatArray:
    return Rotation.from_rotvec([0.0, 0.0, yaw]).as_matrix()


def simulated_motion(tr: Trajectory, model: mujoco.MjModel, plan: BodyPlanSet, source: Motion,
                     source_frame: npt.NDArray[np.int64] | None = None) -> Motion:
    """The recorded body motion on ``source``'s skeleton (``source`` in the project frame).

    ``source_frame``: per sample, the source-motion frame whose rotations the dropped joints keep
    (default: frame 0).
    """
    sk = source.skeleton
    n, j = tr.num_samples, sk.num_joints
    body_of_source = {b.source: b.name for b in plan.bodies}
    # ownership: a joint is "inside" a body when a body joint lies below it; otherwise dropped
    below = np.zeros(j, dtype=bool)
    for k in range(j - 1, -1, -1):
        if sk.names[k] in body_of_source:
            below[k] = True
        if below[k] and sk.parents[k] >= 0:
            below[sk.parents[k]] = True
    owner: list[str | None] = [None] * j
    for k in range(j):
        name = sk.names[k]
        if name in body_of_source:
            owner[k] = body_of_source[name]
        elif sk.parents[k] >= 0 and below[k]:
            owner[k] = owner[sk.parents[k]]
    data = mujoco.MjData(model)
    bid = {b.name: model.body(b.name).id for b in plan.bodies}
    ry = _yaw(plan.heading_yaw)
    frames = np.zeros(n, dtype=np.int64) if source_frame is None else np.clip(source_frame, 0, source.num_frames - 1)
    ref_local = Rotation.from_quat(source.rotations[frames].reshape(-1, 4)).as_matrix().reshape(n, j, 3, 3)
    glob = np.zeros((n, j, 3, 3))
    root = np.zeros((n, 3))
    rest = rest_points(source)
    pelvis = plan.bodies[0]
    for i in range(n):
        data.qpos[:] = tr.qpos[i]
        mujoco.mj_kinematics(model, data)
        for k in range(j):
            if owner[k] is not None and (sk.names[k] in body_of_source or sk.parents[k] < 0
                                         or owner[k] != owner[sk.parents[k]]):
                glob[i, k] = data.xmat[bid[owner[k]]].reshape(3, 3)
            elif owner[k] is not None:
                glob[i, k] = glob[i, sk.parents[k]]
            else:
                p = sk.parents[k]
                glob[i, k] = ref_local[i, k] if p < 0 else glob[i, p] @ ref_local[i, k]
        g_p = data.xmat[bid[pelvis.name]].reshape(3, 3)
        # the root sits where the pelvis body's rest layout puts it
        off = ry @ (rest[sk.names[0]] - rest[pelvis.source])
        root[i] = data.xpos[bid[pelvis.name]] + g_p @ off
    local = glob.copy()
    parents = sk.parents
    local[:, 1:] = np.einsum("tkji,tkjl->tkil", glob[:, parents[1:]], glob[:, 1:])
    quats = canonical_quat(Rotation.from_matrix(local.reshape(-1, 3, 3)).as_quat().reshape(n, j, 4))
    dt = float(np.median(np.diff(tr.time))) if n > 1 else 1.0 / tr.meta.get("record_hz", 120.0)
    # built in the model's (heading-turned) frame with turned offsets, then turned back
    turned = Motion(skeleton=sk.transformed(ry), frame_time=dt, root_translation=root, rotations=quats,
                    unit=1.0, up="z")
    return turned.transformed(ry.T)


def write_motion_bvh(motion: Motion, path: str | os.PathLike[str], unit: float = 1.0, up: str = "y") -> None:
    """Write a project-frame motion as BVH in ``unit`` (metres per file unit) with ``up`` up."""
    write_bvh(motion.with_up(up).scaled(1.0 / unit), path, precision=6)


def write_joint_csv(tr: Trajectory, names: list[str], q: FloatArray, q_ref: FloatArray,
                    path: str | os.PathLike[str]) -> None:
    """Time and every joint angle (rad), simulated and reference, one row per sample (``q``, ``q_ref``:
    (T, J), from :func:`bipedsim.sim.outputs.joint_series`)."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["time_s"] + names + [f"{n}_ref" for n in names])
    for i in range(tr.num_samples):
        w.writerow([f"{tr.time[i]:.4f}"] + [f"{v:.6f}" for v in q[i]] + [f"{v:.6f}" for v in q_ref[i]])
    atomic_write_text(Path(path), buf.getvalue())
