"""The :class:`ReferenceClip` type: a motion on one MJCF model, ready to track."""

from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.files import atomic_write_bytes

FloatArray = npt.NDArray[np.float64]


@dataclass
class ReferenceClip:
    """A motion retargeted onto one model.

    Attributes:
        qpos: (T, nq) generalized positions per frame (free joint: position m, quaternion w x y z;
            hinges rad; balls quaternions).
        qvel: (T, nv) generalized velocities (m/s, rad/s), central differences on the manifold.
        frame_time: seconds per frame.
        contacts: (T, F) bool, foot ``f`` on the ground at frame ``t``.
        foot_names: the F feet (``left``/``right`` for humanoids; end-effector bodies for creatures).
        foot_heights: (T, F) lowest point of each foot above the floor (m).
        events: per foot, frame indices of ``strike`` (contact begins) and ``liftoff`` (ends).
        model_hash: hash of the MJCF text the clip was made for ('' if unknown).
        joint_names: the model's joint names, in order.
        source: where the motion came from (a path, "generated", ...).
        vertical_shift: metres added to the root height so the lowest foot touches the floor.
        trimmed_frames: leading source frames dropped as a glitch (e.g. a T-pose before the take).
        floor_slope: (dz/dx, dz/dy) of the capture's floor, removed from the root height.
    """

    qpos: FloatArray
    qvel: FloatArray
    frame_time: float
    contacts: npt.NDArray[np.bool_]
    foot_names: list[str]
    foot_heights: FloatArray
    events: dict[str, dict[str, list[int]]] = field(default_factory=dict)
    model_hash: str = ""
    joint_names: list[str] = field(default_factory=list)
    source: str = ""
    vertical_shift: float = 0.0
    trimmed_frames: int = 0
    floor_slope: tuple[float, float] = (0.0, 0.0)

    @property
    def num_frames(self) -> int:
        return int(self.qpos.shape[0])

    @property
    def duration(self) -> float:
        return (self.num_frames - 1) * self.frame_time

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write as ``.npz`` (atomically)."""
        meta = {"frame_time": self.frame_time, "foot_names": self.foot_names, "events": self.events,
                "model_hash": self.model_hash, "joint_names": self.joint_names, "source": self.source,
                "vertical_shift": self.vertical_shift, "trimmed_frames": self.trimmed_frames,
                "floor_slope": list(self.floor_slope), "format": "bipedsim.ReferenceClip/1"}
        buf = io.BytesIO()
        np.savez_compressed(buf, qpos=self.qpos, qvel=self.qvel, contacts=self.contacts,
                            foot_heights=self.foot_heights, meta=np.array(json.dumps(meta)))
        atomic_write_bytes(path, buf.getvalue())

    @staticmethod
    def load(path: str | os.PathLike[str], expect_hash: str | None = None) -> ReferenceClip:
        """Read a clip; with ``expect_hash``, refuse a clip made for another model."""
        try:
            with np.load(path, allow_pickle=False) as z:
                meta = json.loads(str(z["meta"]))
                clip = ReferenceClip(qpos=z["qpos"], qvel=z["qvel"], contacts=z["contacts"],
                                     foot_heights=z["foot_heights"], frame_time=meta["frame_time"],
                                     foot_names=meta["foot_names"], events=meta["events"],
                                     model_hash=meta["model_hash"], joint_names=meta["joint_names"],
                                     source=meta["source"], vertical_shift=meta["vertical_shift"],
                                     trimmed_frames=meta.get("trimmed_frames", 0),
                                     floor_slope=tuple(meta.get("floor_slope", (0.0, 0.0))))
        except (OSError, KeyError, ValueError) as exc:
            raise ModelError(f"{path}: not a bipedsim reference clip ({exc})") from None
        if expect_hash is not None and clip.model_hash and clip.model_hash != expect_hash:
            raise ModelError(f"{path}: made for model {clip.model_hash}, not this one ({expect_hash}); "
                             f"retarget the motion again")
        return clip


#: Percentile of a foot's heights taken as its resting level on the floor.
STANCE_LEVEL_PERCENTILE = 5.0


def foot_speeds(pos: FloatArray, dt: float) -> FloatArray:
    """(T, F) horizontal speeds (m/s) of foot positions (T, F, 3), central differences."""
    if len(pos) < 2:
        return np.zeros(pos.shape[:2])
    return np.linalg.norm(np.gradient(pos[..., :2], dt, axis=0), axis=-1)


def contact_labels(low: FloatArray, sp: FloatArray, height: float, speed: float) -> npt.NDArray[np.bool_]:
    """(T, F) contact flags: lowest point within ``height`` (m) of that foot's resting level (its
    5th-percentile height: captures often leave one foot's geometry a little off the floor) and
    horizontal speed below ``speed`` (m/s, central differences)."""
    level = np.percentile(low, STANCE_LEVEL_PERCENTILE, axis=0) if len(low) else 0.0
    return (low < level + height) & (sp < speed)


def debounce(contacts: npt.NDArray[np.bool_], dt: float, min_gap: float = 0.06,
             min_contact: float = 0.12) -> npt.NDArray[np.bool_]:
    """Contact flags without chatter: gaps shorter than ``min_gap`` s are filled, then contacts
    shorter than ``min_contact`` s dropped (a foot brushing the floor is not a step)."""
    out = contacts.copy()
    gap, con = max(1, int(round(min_gap / dt))), max(1, int(round(min_contact / dt)))
    for k in range(out.shape[1]):
        c = out[:, k]
        for value, length in ((False, gap), (True, con)):
            runs = np.flatnonzero(np.diff(np.concatenate([[not value], c == value, [not value]]).astype(int)))
            for start, stop in zip(runs[::2], runs[1::2]):
                inner = start > 0 and stop < len(c)  # runs touching the clip's ends are kept
                if stop - start < length and inner:
                    c[start:stop] = not value
    return out


def gait_events(contacts: npt.NDArray[np.bool_], feet: list[str]) -> dict[str, dict[str, list[int]]]:
    """Frames where each foot's contact begins (``strike``) and ends (``liftoff``)."""
    out: dict[str, dict[str, list[int]]] = {}
    for k, f in enumerate(feet):
        c = contacts[:, k].astype(int)
        d = np.diff(c)
        out[f] = {"strike": [int(i) + 1 for i in np.flatnonzero(d == 1)],
                  "liftoff": [int(i) + 1 for i in np.flatnonzero(d == -1)]}
    return out
