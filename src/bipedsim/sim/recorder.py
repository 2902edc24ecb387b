"""Recording a rollout: everything rendering, plotting and export need, saved as ``trajectory.npz``.

Per recorded sample (``record_hz``, default 120 Hz): time (s), qpos, qvel, actuator torques (N*m,
saved as ``ctrl``), each
foot's vertical contact force (N, touch sensors), FSM state, reference frame, the reference's qpos
at that frame (root at the reference's own place), applied external forces per body (N, world),
and the centre of mass (m).
"""

from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.errors import BipedsimError

FloatArray = npt.NDArray[np.float64]
FORMAT = "bipedsim.Trajectory/1"


@dataclass
class Trajectory:
    time: FloatArray
    qpos: FloatArray
    qvel: FloatArray
    ctrl: FloatArray
    contact_force: FloatArray  # (T, 2) left, right
    fsm_state: npt.NDArray[np.int64]
    ref_frame: FloatArray
    ref_qpos: FloatArray
    xfrc: FloatArray  # (T, nbody, 3)
    com: FloatArray
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def num_samples(self) -> int:
        return int(len(self.time))

    def save(self, path: str | os.PathLike[str]) -> None:
        from bipedsim.io import atomic_write_bytes

        buf = io.BytesIO()
        meta = dict(self.meta, format=FORMAT)
        np.savez_compressed(buf, time=self.time, qpos=self.qpos, qvel=self.qvel, ctrl=self.ctrl,
                            contact_force=self.contact_force, fsm_state=self.fsm_state, ref_frame=self.ref_frame,
                            ref_qpos=self.ref_qpos, xfrc=self.xfrc, com=self.com,
                            meta=np.array(json.dumps(meta, default=str)))
        atomic_write_bytes(path, buf.getvalue())

    @staticmethod
    def load(path: str | os.PathLike[str]) -> Trajectory:
        try:
            with np.load(path, allow_pickle=False) as z:
                meta = json.loads(str(z["meta"]))
                if meta.get("format") != FORMAT:
                    raise ValueError(f"format {meta.get('format')!r}")
                return Trajectory(time=z["time"], qpos=z["qpos"], qvel=z["qvel"], ctrl=z["ctrl"],
                                  contact_force=z["contact_force"], fsm_state=z["fsm_state"], ref_frame=z["ref_frame"],
                                  ref_qpos=z["ref_qpos"], xfrc=z["xfrc"], com=z["com"], meta=meta)
        except (OSError, KeyError, ValueError) as exc:
            raise BipedsimError(f"{path}: not a bipedsim trajectory ({exc})") from None

    def pushes(self) -> list[tuple[float, float, int, FloatArray]]:
        """(start s, end s, body id, mean force N) of every window with an external force."""
        mag = np.linalg.norm(self.xfrc, axis=2)  # (T, nbody)
        out = []
        for b in range(mag.shape[1]):
            on = mag[:, b] > 1e-9
            if not on.any():
                continue
            edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
            for s, e in zip(edges[::2], edges[1::2]):
                out.append((float(self.time[s]), float(self.time[e - 1]), b, self.xfrc[s:e, b].mean(axis=0)))
        return out


class Recorder:
    """A rollout hook that samples the state at ``record_hz``."""

    def __init__(self, model: mujoco.MjModel, record_hz: float = 120.0) -> None:
        if not record_hz > 0:
            raise BipedsimError(f"record rate must be positive, got {record_hz}")
        self.model = model
        self.every = max(1e-9, 1.0 / record_hz)
        self.next_t = 0.0
        self.rows: dict[str, list[Any]] = {k: [] for k in ("time", "qpos", "qvel", "ctrl", "contact_force", "fsm_state",
                                                           "ref_frame", "ref_qpos", "xfrc", "com")}

    def __call__(self, t: float, data: mujoco.MjData, ctrl: Any) -> None:
        if t + 1e-9 < self.next_t:
            return
        self.next_t += self.every
        r = self.rows
        r["time"].append(t)
        r["qpos"].append(data.qpos.copy())
        r["qvel"].append(data.qvel.copy())
        tau = getattr(ctrl, "torque", None)
        if tau is None:
            r["ctrl"].append(data.ctrl.copy())
        else:  # torques per actuator (data.ctrl holds servo targets for servo joints)
            row = np.zeros(self.model.nu)
            row[ctrl.h.actuator] = tau
            r["ctrl"].append(row)
        r["contact_force"].append([sum(float(data.sensordata[a]) for a in ctrl.touch[s]) for s in ("left", "right")])
        r["fsm_state"].append(ctrl.fsm.state)
        r["ref_frame"].append(ctrl.frame)
        r["ref_qpos"].append(ctrl.reference_qpos())
        r["xfrc"].append(data.xfrc_applied[:, :3].copy())
        r["com"].append(data.subtree_com[1].copy())

    def trajectory(self, meta: dict[str, Any] | None = None) -> Trajectory:
        r = self.rows
        if not r["time"]:
            raise BipedsimError("nothing was recorded")
        return Trajectory(time=np.array(r["time"]), qpos=np.array(r["qpos"]), qvel=np.array(r["qvel"]),
                          ctrl=np.array(r["ctrl"]), contact_force=np.array(r["contact_force"]),
                          fsm_state=np.array(r["fsm_state"], dtype=np.int64), ref_frame=np.array(r["ref_frame"]),
                          ref_qpos=np.array(r["ref_qpos"]), xfrc=np.array(r["xfrc"]), com=np.array(r["com"]),
                          meta=dict(meta or {}, record_hz=1.0 / self.every))
