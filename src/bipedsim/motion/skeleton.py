"""The :class:`Skeleton` type: joint names, tree, rest offsets and BVH channel layout."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError

#: Channel names a BVH joint may carry.
POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")
ALL_CHANNELS = POSITION_CHANNELS + ROTATION_CHANNELS

#: How the position channels of a joint combine with its OFFSET.
#: ``"replace"``: the channel values are the joint's local translation (OFFSET is only the rest pose);
#: ``"add"``: the local translation is OFFSET + channel values.
POSITION_MODES = ("replace", "add")


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint tree in the order joints appear in the file (parents before children).

    Attributes:
        names: joint names, unique.
        parents: (J,) parent index of each joint, ``-1`` for the root (exactly one root, index 0).
        offsets: (J, 3) rest offset of each joint from its parent, in the motion's length unit and
            axes (see :attr:`Motion.unit` and :attr:`Motion.up`).
        channels: per joint, the BVH channel names in file order (e.g. ``("Zrotation", "Xrotation",
            "Yrotation")``); rotations are intrinsic in that order.
        position_modes: per joint, how position channels combine with the OFFSET (``"replace"`` or
            ``"add"``); ``""`` for joints without position channels.
        end_site_parents: (E,) joint index each End Site hangs from.
        end_site_offsets: (E, 3) End Site offsets from that joint.
    """

    names: tuple[str, ...]
    parents: npt.NDArray[np.int64]
    offsets: npt.NDArray[np.float64]
    channels: tuple[tuple[str, ...], ...]
    position_modes: tuple[str, ...] = ()
    end_site_parents: npt.NDArray[np.int64] = field(
        default_factory=lambda: np.zeros(0, dtype=np.int64))
    end_site_offsets: npt.NDArray[np.float64] = field(
        default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self) -> None:
        parents = np.asarray(self.parents, dtype=np.int64).reshape(-1)
        offsets = np.asarray(self.offsets, dtype=np.float64).reshape(-1, 3)
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "channels", tuple(tuple(c) for c in self.channels))
        modes = tuple(self.position_modes) or tuple(
            "replace" if any(c in POSITION_CHANNELS for c in ch) else "" for ch in self.channels)
        object.__setattr__(self, "position_modes", modes)
        object.__setattr__(self, "end_site_parents",
                           np.asarray(self.end_site_parents, dtype=np.int64).reshape(-1))
        object.__setattr__(self, "end_site_offsets",
                           np.asarray(self.end_site_offsets, dtype=np.float64).reshape(-1, 3))
        n = len(self.names)
        if n == 0:
            raise ModelError("a skeleton needs at least one joint")
        if not (len(parents) == len(offsets) == len(self.channels) == len(modes) == n):
            raise ModelError(
                f"skeleton arrays disagree in length: {n} names, {len(parents)} parents, "
                f"{len(offsets)} offsets, {len(self.channels)} channel lists, {len(modes)} modes")
        if len(set(self.names)) != n:
            dup = sorted({x for x in self.names if self.names.count(x) > 1})
            raise ModelError(f"joint names must be unique; repeated: {dup}")
        if parents[0] != -1 or np.any(parents[1:] < 0):
            raise ModelError("joint 0 must be the only root (parent -1)")
        if np.any(parents[1:] >= np.arange(1, n)):
            raise ModelError("every joint must come after its parent")
        for name, ch in zip(self.names, self.channels):
            bad = [c for c in ch if c not in ALL_CHANNELS]
            if bad or len(set(ch)) != len(ch):
                raise ModelError(f"joint {name!r}: bad channel list {list(ch)}")
        for name, mode in zip(self.names, modes):
            if mode not in ("", *POSITION_MODES):
                raise ModelError(f"joint {name!r}: position mode {mode!r} not in {POSITION_MODES}")

    # ------------------------------------------------------------------ queries
    @property
    def num_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of joint ``name``; raises ``KeyError`` naming the known joints if absent."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no joint {name!r}; joints are {list(self.names)}") from None

    def rotation_order(self, j: int) -> str:
        """Rotation channel axes of joint ``j`` in file order, e.g. ``"ZXY"`` ('' if none)."""
        return "".join(c[0] for c in self.channels[j] if c in ROTATION_CHANNELS)

    def has_positions(self, j: int) -> bool:
        return any(c in POSITION_CHANNELS for c in self.channels[j])

    def children(self, j: int) -> list[int]:
        return [int(i) for i in np.flatnonzero(self.parents == j)]

    def subtree(self, j: int) -> list[int]:
        """Joint ``j`` and all its descendants, in skeleton order."""
        inside = np.zeros(self.num_joints, dtype=bool)
        inside[j] = True
        for i in range(j + 1, self.num_joints):
            if inside[self.parents[i]]:
                inside[i] = True
        return [int(i) for i in np.flatnonzero(inside)]

    def depth(self) -> npt.NDArray[np.int64]:
        d = np.zeros(self.num_joints, dtype=np.int64)
        for i in range(1, self.num_joints):
            d[i] = d[self.parents[i]] + 1
        return d

    # ------------------------------------------------------------------ transforms
    def replace(self, **changes: object) -> Skeleton:
        """A copy with some fields replaced."""
        fields = {"names": self.names, "parents": self.parents, "offsets": self.offsets,
                      "channels": self.channels, "position_modes": self.position_modes,
                      "end_site_parents": self.end_site_parents, "end_site_offsets": self.end_site_offsets}
        fields.update(changes)
        return Skeleton(**fields)  # type: ignore[arg-type]

    def scaled(self, factor: float) -> Skeleton:
        """All lengths multiplied by ``factor``."""
        return self.replace(offsets=self.offsets * factor,
                            end_site_offsets=self.end_site_offsets * factor)

    def transformed(self, basis: npt.NDArray[np.float64]) -> Skeleton:
        """Offsets expressed in a new world basis: ``o' = C @ o`` for a 3x3 matrix ``C``."""
        c = np.asarray(basis, dtype=np.float64)
        return self.replace(offsets=self.offsets @ c.T, end_site_offsets=self.end_site_offsets @ c.T)

    def same_structure(self, other: Skeleton) -> bool:
        return self.names == other.names and np.array_equal(self.parents, other.parents)

    def __repr__(self) -> str:
        return f"Skeleton({self.num_joints} joints, root={self.names[0]!r})"
