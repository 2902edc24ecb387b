"""The :class:`Motion` type and the operations on it: FK, resampling, slicing, concatenation,
mirroring, unit scaling and up-axis conversion.

Quaternions are scalar-last ``(x, y, z, w)`` as in :mod:`scipy.spatial.transform`, canonicalised to
``w >= 0``. A joint's global rotation is ``G[j] = G[parent] @ L[j]`` and its position
``P[j] = P[parent] + G[parent] @ t[j]`` where ``t[j]`` is its local translation (the OFFSET, or the
position channels for joints that have them).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation, Slerp

from bipedsim.errors import BVHError, ModelError
from bipedsim.motion.conventions import (
    PROJECT_UP,
    axis_index,
    horizontal_axes,
    up_basis,
)
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]


#: Farthest (m) any length of a motion may reach -- a joint's position on any frame, a bone or an End
#: Site -- once in metres: 100 km, far past any capture volume or recorded walk. A value beyond it is a
#: corrupt number or a wrong unit, and far beyond it (1e300) the fits and rotations computed from the
#: positions overflow (an SVD that does not converge, speeds of inf m/s).
MAX_POSITION_M = 1e5


def check_extent(motion: Motion, source: str | os.PathLike[str] | None = None) -> None:
    """Raise :class:`BVHError` naming ``source`` (the file the motion was read from) where a length of
    ``motion`` -- the root's position, a position channel, an OFFSET or an End Site -- is not finite or
    lies beyond :data:`MAX_POSITION_M` once in metres (``motion.unit`` metres per unit). Every command
    that builds a body or describes a file checks the motion it read (before anything is computed from
    it)."""
    unit = float(motion.unit)
    sk = motion.skeleton
    names = sk.names
    checks: list[tuple[str, FloatArray, Any]] = [
        ("the root's position", motion.root_translation, lambda f, j: f"{names[0]}, frame {f + 1}"),
        ("a joint's OFFSET", sk.offsets[None], lambda f, j: names[j]),
        ("an End Site's OFFSET", np.asarray(sk.end_site_offsets)[None],
         lambda f, j: f"below {names[sk.end_site_parents[j]]}")]
    if motion.translations is not None:
        checks.append(("a position channel", motion.translations, lambda f, j: f"{names[j]}, frame {f + 1}"))
    for what, values, where in checks:
        if values.size == 0:
            continue
        with np.errstate(over="ignore", invalid="ignore"):  # 1e308 in cm is inf m: beyond the bound too
            size = np.abs(values).max(axis=-1) * unit  # largest coordinate (m) per frame (and joint)
        bad = ~(size <= MAX_POSITION_M)  # also NaN
        if bad.any():
            at = np.unravel_index(int(np.argmax(bad)), bad.shape)
            f, j = (int(at[0]), int(at[1]) if len(at) > 1 else 0)
            value = float(size[at])
            raise BVHError(f"{what} ({where(f, j)}) has a coordinate of {value:.3g} m (at {unit:g} m per file "
                           f"unit); a motion stays within {MAX_POSITION_M:g} m of its origin: the file's numbers are "
                           "corrupt, or its unit is wrong (--scale)", source)


def canonical_quat(q: FloatArray) -> FloatArray:
    """Quaternions (..., 4) scalar-last, normalised, with ``w >= 0``."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0, -q, q)


@dataclass(eq=False)
class Motion:
    """A skeleton animated over time.

    Attributes:
        skeleton: the joint tree.
        frame_time: seconds per frame (> 0).
        root_translation: (T, 3) the root joint's position, in ``unit`` lengths and ``up`` axes.
        rotations: (T, J, 4) local joint rotations, quaternions scalar-last.
        translations: optional (T, J, 3) local translations of every joint (used for joints with
            position channels; others hold their OFFSET). ``None`` when only the root translates.
        unit: metres per length unit of this motion (1.0 once converted to metres).
        up: the up axis of this motion's frame, ``"y"`` or ``"z"`` (the project uses ``"z"``).
    """

    skeleton: Skeleton
    frame_time: float
    root_translation: FloatArray
    rotations: FloatArray
    translations: FloatArray | None = None
    unit: float = 1.0
    up: str = PROJECT_UP

    def __post_init__(self) -> None:
        self.root_translation = np.asarray(self.root_translation, dtype=np.float64).reshape(-1, 3)
        t = self.root_translation.shape[0]
        j = self.skeleton.num_joints
        self.rotations = np.asarray(self.rotations, dtype=np.float64).reshape(t, j, 4)
        if self.translations is not None:
            self.translations = np.asarray(self.translations, dtype=np.float64).reshape(t, j, 3)
        if not (self.frame_time > 0 and np.isfinite(self.frame_time)):
            raise ModelError(f"frame_time must be a positive number of seconds, got {self.frame_time}")
        if self.up not in ("y", "z"):
            raise ModelError(f"up must be 'y' or 'z', got {self.up!r}")

    # ------------------------------------------------------------------ basic facts
    @property
    def num_frames(self) -> int:
        return int(self.root_translation.shape[0])

    @property
    def num_joints(self) -> int:
        return self.skeleton.num_joints

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame."""
        return (self.num_frames - 1) * self.frame_time

    def local_translations(self) -> FloatArray:
        """(T, J, 3) local translation of every joint (root: ``root_translation``)."""
        if self.translations is not None:
            out = self.translations.copy()
        else:
            out = np.broadcast_to(self.skeleton.offsets, (self.num_frames, self.num_joints, 3)).copy()
        out[:, 0] = self.root_translation
        return out

    def travel_joint(self) -> int:
        """The joint that carries the body's travel: the root, unless the root stands still and a
        joint below it translates (root-on-a-child layouts: a static root at the floor, the translation
        on the hips), then the first joint that does."""
        if self.translations is None or self.num_frames < 2:
            return 0
        span = np.ptp(self.root_translation, axis=0).max()
        size = float(np.abs(self.skeleton.offsets).max()) or 1.0
        if span > 1e-6 * size:
            return 0
        moving = np.ptp(self.translations, axis=0).max(axis=1) > 1e-6 * size
        moving[0] = False
        return int(np.argmax(moving)) if moving.any() else 0

    def travel(self) -> FloatArray:
        """(T, 3) global position of :meth:`travel_joint` (the root's translation when it moves)."""
        j = self.travel_joint()
        return self.root_translation.copy() if j == 0 else self.fk()[0][:, j]

    def rebased(self, frame: int, limb_frames: dict[int, int] | None = None) -> Motion:
        """The same motion on a skeleton whose rest pose (every rotation identity) is the pose of
        ``frame`` (root at the origin): each joint's frame is turned to be world-parallel there.
        Offsets, End Sites and position channels turn with their parent's frame; forward
        kinematics is unchanged on every frame (tested). For skeletons whose identity pose is no body
        (bone-aligned joint frames: every bone along +X), so that rest-pose geometry means something."""
        sk = self.skeleton
        g = forward_kinematics(self)[1]  # (T, J, 3, 3)
        # G'_j(t) = G_j(t) B_j with B_j = G_j(frame)^T: every global rotation is identity at the frame
        base = g[frame].transpose(0, 2, 1).copy()
        if limb_frames:
            # a limb's joints take their frame from the limb's own frame, turned about up by the
            # heading change of the limb's first joint's parent between the two frames
            u = axis_index(self.up)
            for top, f in limb_frames.items():
                p = int(sk.parents[top])
                turn = _yaw_between(g[frame, p], g[f, p], u)
                for j in sk.subtree(top):
                    base[j] = (turn @ g[f, j]).T
        return self.reframed(base, g)

    def reframed(self, base: FloatArray, g: FloatArray | None = None) -> Motion:
        """The same motion with each joint's frame turned by ``base`` (J, 3, 3): global rotations
        G'_j = G_j B_j on every frame; offsets, End Sites and position channels turn with their parent's
        frame, so forward kinematics is unchanged (``g``: the global rotations, if known)."""
        sk = self.skeleton
        g = forward_kinematics(self)[1] if g is None else g
        new_g = np.einsum("tjab,jbc->tjac", g, base)
        par = sk.parents
        loc = new_g.copy()
        loc[:, 1:] = np.einsum("tjba,tjbc->tjac", new_g[:, par[1:]], new_g[:, 1:])
        # bone_j = G_p o_j = G'_p B_p^T o_j, so o'_j = B_p^T o_j (End Sites and position channels alike)
        off = sk.offsets.copy()
        off[1:] = np.einsum("jba,jb->ja", base[par[1:]], sk.offsets[1:])
        es_par = sk.end_site_parents
        es = np.einsum("jba,jb->ja", base[es_par], sk.end_site_offsets) if len(es_par) else sk.end_site_offsets
        trans = None
        if self.translations is not None:
            trans = self.translations.copy()
            trans[:, 1:] = np.einsum("jba,tjb->tja", base[par[1:]], self.translations[:, 1:])
        quats = canonical_quat(Rotation.from_matrix(loc.reshape(-1, 3, 3)).as_quat().reshape(loc.shape[:2] + (4,)))
        return self.copy(skeleton=sk.replace(offsets=off, end_site_offsets=es), rotations=quats, translations=trans)

    def copy(self, **changes: object) -> Motion:
        fields = {"skeleton": self.skeleton, "frame_time": self.frame_time,
                      "root_translation": self.root_translation.copy(),
                      "rotations": self.rotations.copy(),
                      "translations": None if self.translations is None else self.translations.copy(),
                      "unit": self.unit, "up": self.up}
        fields.update(changes)
        return Motion(**fields)  # type: ignore[arg-type]

    # ------------------------------------------------------------------ kinematics
    def fk(self) -> tuple[FloatArray, FloatArray]:
        """Forward kinematics: global joint positions (T, J, 3) and rotation matrices (T, J, 3, 3)."""
        return forward_kinematics(self)

    def end_site_positions(self, fk: tuple[FloatArray, FloatArray] | None = None) -> FloatArray:
        """(T, E, 3) global positions of the End Sites; ``fk``: this motion's :meth:`fk` when the caller
        has it already (a long clip's rotations are its largest array)."""
        pos, rot = self.fk() if fk is None else fk
        sk = self.skeleton
        p = sk.end_site_parents
        return pos[:, p] + np.einsum("teij,ej->tei", rot[:, p], sk.end_site_offsets)

    # ------------------------------------------------------------------ time
    def __getitem__(self, index: slice) -> Motion:
        if not isinstance(index, slice):
            raise TypeError("index a Motion with a slice of frames, e.g. motion[10:50]")
        return self.slice(index.start, index.stop, index.step)

    def slice(self, start: int | None = None, stop: int | None = None, step: int | None = None) -> Motion:
        """Frames ``start:stop:step``; the frame time is multiplied by ``step``."""
        s = slice(start, stop, step)
        idx = np.arange(self.num_frames)[s]
        if idx.size == 0:
            raise ModelError(f"slice {start}:{stop}:{step} of a {self.num_frames}-frame motion is empty")
        k = 1 if step is None else int(step)
        if k <= 0:
            raise ModelError("slice step must be positive")
        return self.copy(frame_time=self.frame_time * k, root_translation=self.root_translation[idx],
                         rotations=self.rotations[idx],
                         translations=None if self.translations is None else self.translations[idx])

    def resample(self, fps: float) -> Motion:
        """The same motion at a new frame rate: slerp for rotations, linear for translations.

        Covers the same time span ``[0, duration]``; the last new frame is at or before the end.
        """
        if not fps > 0:
            raise ModelError(f"fps must be positive, got {fps}")
        t_old = np.arange(self.num_frames) * self.frame_time
        n_new = int(np.floor(self.duration * fps + 1e-9)) + 1
        # the last new time may land a rounding step past the clip's end: it is the end
        t_new = np.minimum(np.arange(n_new) / fps, t_old[-1])
        if self.num_frames == 1:
            idx = np.zeros(n_new, dtype=int)
            return self.copy(frame_time=1.0 / fps, root_translation=self.root_translation[idx],
                             rotations=self.rotations[idx],
                             translations=None if self.translations is None else self.translations[idx])
        rot = np.empty((n_new, self.num_joints, 4))
        for j in range(self.num_joints):
            rot[:, j] = Slerp(t_old, Rotation.from_quat(self.rotations[:, j]))(t_new).as_quat()

        def lerp(a: FloatArray) -> FloatArray:
            flat = a.reshape(self.num_frames, -1)
            out = np.stack([np.interp(t_new, t_old, flat[:, c]) for c in range(flat.shape[1])], axis=1)
            return out.reshape((n_new,) + a.shape[1:])

        return self.copy(frame_time=1.0 / fps, root_translation=lerp(self.root_translation),
                         rotations=canonical_quat(rot),
                         translations=None if self.translations is None else lerp(self.translations))

    # ------------------------------------------------------------------ frames and units
    def scaled(self, factor: float) -> Motion:
        """All lengths multiplied by ``factor`` (``unit`` divided by it, so metres are unchanged)."""
        return self.copy(skeleton=self.skeleton.scaled(factor),
                         root_translation=self.root_translation * factor,
                         translations=None if self.translations is None else self.translations * factor,
                         unit=self.unit / factor)

    def similar(self, factor: float) -> Motion:
        """The motion of a body ``factor`` times the size moving at the same Froude number (dynamic
        similarity under the same gravity): in metres, every length x ``factor`` and the frame time x
        sqrt(``factor``), so speeds scale by sqrt(``factor``) and accelerations stay those of gravity."""
        if not (factor > 0 and np.isfinite(factor)):
            raise ModelError(f"a similar motion needs a size factor > 0, got {factor}")
        m = self.in_metres().scaled(factor)
        return m.copy(frame_time=self.frame_time * float(np.sqrt(factor)), unit=1.0)

    def in_metres(self) -> Motion:
        """Lengths converted to metres (``unit`` becomes 1)."""
        return self if self.unit == 1.0 else self.scaled(self.unit)

    def transformed(self, basis: FloatArray, up: str | None = None) -> Motion:
        """The motion seen in a rotated world basis ``C`` (proper rotation): ``p' = C p``,
        ``R' = C R C^T`` for the root, offsets ``C o``, and child rotations ``C R C^T`` too, which keeps
        FK consistent: every global position maps to ``C p``."""
        c = np.asarray(basis, dtype=np.float64)
        rc = Rotation.from_matrix(c)
        q = (rc * Rotation.from_quat(self.rotations.reshape(-1, 4)) * rc.inv()).as_quat()
        tr = None if self.translations is None else self.translations @ c.T
        return self.copy(skeleton=self.skeleton.transformed(c), root_translation=self.root_translation @ c.T,
                         rotations=canonical_quat(q).reshape(self.rotations.shape), translations=tr,
                         up=self.up if up is None else up)

    def with_up(self, up: str) -> Motion:
        """The motion in a frame whose up axis is ``up`` (``"y"`` or ``"z"``)."""
        return self if up == self.up else self.transformed(up_basis(self.up, up), up=up)

    def to_project_frame(self) -> Motion:
        """Metres, Z up: the frame everything inside bipedsim uses."""
        return self.in_metres().with_up(PROJECT_UP)

    # ------------------------------------------------------------------ heading and alignment
    def heading(self) -> FloatArray:
        """(T,) yaw (rad) of the root about the up axis, measured from a fixed horizontal axis."""
        u = axis_index(self.up)
        h0, h1 = horizontal_axes(self.up)
        ref = np.zeros(3)
        ref[h0] = 1.0
        fwd = Rotation.from_quat(self.rotations[:, 0]).apply(ref)
        fwd[:, u] = 0.0
        return np.arctan2(fwd[:, h1], fwd[:, h0])

    def rotated_about_up(self, yaw: float, pivot: FloatArray | None = None) -> Motion:
        """The whole motion turned by ``yaw`` rad about the up axis through ``pivot``."""
        axis = np.zeros(3)
        axis[axis_index(self.up)] = 1.0
        r = Rotation.from_rotvec(axis * yaw)
        pv = np.zeros(3) if pivot is None else np.asarray(pivot, dtype=np.float64)
        root = r.apply(self.root_translation - pv) + pv
        rots = self.rotations.copy()
        rots[:, 0] = canonical_quat((r * Rotation.from_quat(self.rotations[:, 0])).as_quat())
        tr = None
        if self.translations is not None:
            tr = self.translations.copy()
            tr[:, 0] = root
        return self.copy(root_translation=root, rotations=rots, translations=tr)

    # ------------------------------------------------------------------ mirroring
    def mirrored(self, axis: str | None = None, pairs: dict[str, str] | None = None) -> Motion:
        """Left and right exchanged: the motion reflected across the body's sagittal plane.

        ``axis``: the lateral axis (the plane's normal); detected from the left/right offsets when
        omitted. ``pairs``: left/right joint names; found from the usual naming patterns when omitted.
        The skeleton is kept; for a symmetric skeleton the result's FK is the exact reflection.
        """
        sk = self.skeleton
        pairs = pairs if pairs is not None else left_right_pairs(sk.names)
        perm = np.arange(sk.num_joints)
        for a, b in pairs.items():
            perm[sk.index(a)] = sk.index(b)
            perm[sk.index(b)] = sk.index(a)
        k = lateral_axis(sk, pairs) if axis is None else axis_index(axis)
        n = np.zeros(3)
        n[k] = 1.0
        m = np.eye(3) - 2.0 * np.outer(n, n)
        q = self.rotations[:, perm].copy()
        v = q[..., :3]
        q[..., :3] = -v + 2.0 * (v @ n)[..., None] * n
        tr = None
        if self.translations is not None:
            tr = self.translations[:, perm] @ m.T
        return self.copy(root_translation=self.root_translation @ m.T, rotations=canonical_quat(q),
                         translations=tr)


# ---------------------------------------------------------------------- module functions
def _yaw_between(a: FloatArray, b: FloatArray, u: int) -> FloatArray:
    """The rotation about axis ``u`` that turns the heading of rotation ``b`` onto that of ``a``
    (headings: each rotation's most horizontal axis projected on the horizontal plane)."""
    k = int(np.argmin(np.abs(a[u])))
    h = [i for i in range(3) if i != u]
    ang = np.arctan2(a[h[1], k], a[h[0], k]) - np.arctan2(b[h[1], k], b[h[0], k])
    return Rotation.from_rotvec(ang * np.eye(3)[u]).as_matrix()


#: Frames converted at a time in forward kinematics: the per-frame temporaries stay a few MiB whatever the
#: clip's length (only the results grow with it).
FK_CHUNK_FRAMES = 2048


def forward_kinematics(motion: Motion) -> tuple[FloatArray, FloatArray]:
    """Global joint positions (T, J, 3) and rotation matrices (T, J, 3, 3), vectorised over frames (a
    block of :data:`FK_CHUNK_FRAMES` at a time)."""
    sk = motion.skeleton
    t, j = motion.num_frames, motion.num_joints
    local_t = motion.local_translations()
    g = np.empty((t, j, 3, 3))
    p = np.empty((t, j, 3))
    parents = sk.parents
    for a in range(0, t, FK_CHUNK_FRAMES):
        b = min(a + FK_CHUNK_FRAMES, t)
        local_r = Rotation.from_quat(motion.rotations[a:b].reshape(-1, 4)).as_matrix().reshape(b - a, j, 3, 3)
        gc, pc, lt = g[a:b], p[a:b], local_t[a:b]
        gc[:, 0] = local_r[:, 0]
        pc[:, 0] = lt[:, 0]
        for i in range(1, j):
            pi = parents[i]
            gp = gc[:, pi]
            np.matmul(gp, local_r[:, i], out=gc[:, i])
            pc[:, i] = pc[:, pi] + np.einsum("tij,tj->ti", gp, lt[:, i])
    return p, g


_SIDE_PATTERNS = [
    (re.compile(r"Left"), "Right"), (re.compile(r"Right"), "Left"),
    (re.compile(r"left"), "right"), (re.compile(r"right"), "left"),
    (re.compile(r"LEFT"), "RIGHT"), (re.compile(r"RIGHT"), "LEFT"),
    (re.compile(r"(?<=[._\-])L$"), "R"), (re.compile(r"(?<=[._\-])R$"), "L"),
    (re.compile(r"(?<=[._\-])l$"), "r"), (re.compile(r"(?<=[._\-])r$"), "l"),
    (re.compile(r"^L(?=[A-Z_])"), "R"), (re.compile(r"^R(?=[A-Z_])"), "L"),
    (re.compile(r"^l(?=[A-Z_])"), "r"), (re.compile(r"^r(?=[A-Z_])"), "l"),
]


def left_right_pairs(names: tuple[str, ...]) -> dict[str, str]:
    """Map each left joint name to its right partner, from the usual naming patterns
    (``Left*/Right*``, ``l*/r*`` before a capital, ``*_L/*_R``, ``*.L/*.R``)."""
    present = set(names)
    out: dict[str, str] = {}
    for name in names:
        for pat, rep in _SIDE_PATTERNS:
            if pat.search(name):
                other = pat.sub(rep, name, count=1)
                if other != name and other in present and other not in out and name not in out:
                    out[name] = other
                break
    return out


def lateral_axis(skeleton: Skeleton, pairs: dict[str, str]) -> int:
    """The axis along which paired left/right rest offsets differ most (the sagittal normal)."""
    diff = np.zeros(3)
    for a, b in pairs.items():
        diff += np.abs(skeleton.offsets[skeleton.index(a)] - skeleton.offsets[skeleton.index(b)])
    if not diff.any():
        raise ModelError("cannot find the lateral axis: left/right offsets are identical; pass axis=")
    return int(np.argmax(diff))


def concatenate(motions: list[Motion], align: bool = True) -> Motion:
    """Join motions of one skeleton end to start.

    With ``align``, each following motion is turned about the up axis so its root heading at its
    first frame matches the previous motion's last frame, and shifted horizontally so its root starts
    where the previous one ended (height is kept). Frame time, unit and up axis must agree.
    """
    if not motions:
        raise ModelError("concatenate needs at least one motion")
    first = motions[0]
    out = [first]
    for m in motions[1:]:
        if not m.skeleton.same_structure(first.skeleton):
            raise ModelError("concatenate: motions have different skeletons")
        if not np.isclose(m.frame_time, first.frame_time) or m.unit != first.unit or m.up != first.up:
            raise ModelError("concatenate: frame time, unit and up axis must agree; resample or convert first")
        if align:
            prev = out[-1]
            yaw = prev.heading()[-1] - m.heading()[0]
            m = m.rotated_about_up(yaw, pivot=m.root_translation[0])
            shift = prev.root_translation[-1] - m.root_translation[0]
            shift[axis_index(m.up)] = 0.0
            m = m.copy(root_translation=m.root_translation + shift,
                       translations=None if m.translations is None else _shift_root(m.translations, shift))
        out.append(m)
    trans = None
    if any(m.translations is not None for m in out):
        trans = np.concatenate([m.local_translations() for m in out])
    return first.copy(root_translation=np.concatenate([m.root_translation for m in out]),
                      rotations=np.concatenate([m.rotations for m in out]), translations=trans)


def _shift_root(translations: FloatArray, shift: FloatArray) -> FloatArray:
    out = translations.copy()
    out[:, 0] += shift
    return out
