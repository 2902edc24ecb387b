"""The :class:`ReferenceClip` type: a motion on one MJCF model, ready to track."""

from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError

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

    @property
    def num_frames(self) -> int:
        return int(self.qpos.shape[0])

    @property
    def duration(self) -> float:
        return (self.num_frames - 1) * self.frame_time

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write as ``.npz`` (atomically)."""
        from bipedsim.io import atomic_write_bytes

        meta = {"frame_time": self.frame_time, "foot_names": self.foot_names, "events": self.events,
                "model_hash": self.model_hash, "joint_names": self.joint_names, "source": self.source,
                "vertical_shift": self.vertical_shift, "format": "bipedsim.ReferenceClip/1"}
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
                                     source=meta["source"], vertical_shift=meta["vertical_shift"])
        except (OSError, KeyError, ValueError) as exc:
            raise ModelError(f"{path}: not a bipedsim reference clip ({exc})") from None
        if expect_hash is not None and clip.model_hash and clip.model_hash != expect_hash:
            raise ModelError(f"{path}: made for model {clip.model_hash}, not this one ({expect_hash}); "
                             f"retarget the motion again")
        return clip


def contact_labels(low: FloatArray, pos: FloatArray, dt: float, height: float, speed: float) -> npt.NDArray[np.bool_]:
    """(T, F) contact flags: lowest point below ``height`` (m) and horizontal speed below ``speed``
    (m/s, central differences)."""
    if len(pos) > 1:
        vel = np.gradient(pos[..., :2], dt, axis=0)
        sp = np.linalg.norm(vel, axis=-1)
    else:
        sp = np.zeros(low.shape)
    return (low < height) & (sp < speed)


def gait_events(contacts: npt.NDArray[np.bool_], feet: list[str]) -> dict[str, dict[str, list[int]]]:
    """Frames where each foot's contact begins (``strike``) and ends (``liftoff``)."""
    out: dict[str, dict[str, list[int]]] = {}
    for k, f in enumerate(feet):
        c = contacts[:, k].astype(int)
        d = np.diff(c)
        out[f] = {"strike": [int(i) + 1 for i in np.flatnonzero(d == 1)],
                  "liftoff": [int(i) + 1 for i in np.flatnonzero(d == -1)]}
    return out


def check_clip_model(clip: ReferenceClip, nq: int) -> None:
    if clip.qpos.shape[1] != nq:
        raise ModelError(f"clip has {clip.qpos.shape[1]} position coordinates, the model {nq}")
