"""Independent BVH forward kinematics for tests.

Two references that share no code with bipedsim:
- ``bvhio_positions``: the ``bvhio`` package's own parser and hierarchy (glm, float32); it treats every
  position channel as absolute ("replace").
- ``naive_positions``: bvhio's raw channel parse + a plain per-joint matrix loop written here from the
  BVH definition (intrinsic Euler in channel order), honouring a given position mode per joint.
"""

from __future__ import annotations

import numpy as np


def bvhio_positions(path: str, frames: list[int] | None = None) -> tuple[list[str], np.ndarray]:
    import bvhio

    root = bvhio.readAsHierarchy(path)
    layout = [j for j, _, _ in root.layout()]
    names = [j.Name for j in layout]
    n = len(root.Keyframes)
    frames = list(range(n)) if frames is None else frames
    out = np.zeros((len(frames), len(layout), 3))
    for k, f in enumerate(frames):
        root.loadPose(f)
        for i, j in enumerate(layout):
            p = j.PositionWorld
            out[k, i] = (p.x, p.y, p.z)
    return names, out


def _rot(axis: str, deg: float) -> np.ndarray:
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    if axis == "X":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "Y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def naive_positions(path: str, modes: dict[str, str], frames: list[int]) -> tuple[list[str], np.ndarray]:
    import bvhio

    bvh = bvhio.readAsBvh(path)
    joints = []

    def walk(j, parent):
        joints.append((j, parent))
        idx = len(joints) - 1
        for c in j.Children:
            walk(c, idx)

    walk(bvh.Root, -1)
    # raw channel values per joint, re-read from the file's motion section through bvhio's own
    # tokenisation of frame lines
    with open(path) as f:
        lines = [ln for ln in f.read().splitlines()]
    mi = next(i for i, ln in enumerate(lines) if ln.strip() == "MOTION")
    data = [ln.split() for ln in lines[mi + 3:] if ln.strip()]
    out = np.zeros((len(frames), len(joints), 3))
    for k, fr in enumerate(frames):
        vals = [float(x) for x in data[fr]]
        ci = 0
        g = [None] * len(joints)
        p = [None] * len(joints)
        for i, (j, parent) in enumerate(joints):
            off = np.array([j.Offset.x, j.Offset.y, j.Offset.z], dtype=float)
            t = off.copy()
            r = np.eye(3)
            pos_ch = {}
            for ch in j.Channels:
                v = vals[ci]
                ci += 1
                if ch.endswith("position"):
                    pos_ch["XYZ".index(ch[0])] = v
                else:
                    r = r @ _rot(ch[0], v)
            if pos_ch:
                mode = modes.get(j.Name, "replace")
                for a, v in pos_ch.items():
                    t[a] = v + (off[a] if mode == "add" else 0.0)
            if parent < 0:
                g[i], p[i] = r, t
            else:
                g[i] = g[parent] @ r
                p[i] = p[parent] + g[parent] @ t
            out[k, i] = p[i]
    return [j.Name for j, _ in joints], out
