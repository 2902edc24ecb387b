"""Recording a rollout: everything rendering, plotting and export need, saved as ``trajectory.npz``.

Per recorded sample (``record_hz``, default 120 Hz): time (s), qpos, qvel, actuator torques (N*m,
saved as ``ctrl``), each foot's vertical contact force (N, touch sensors), FSM state, reference frame,
the reference's qpos at that frame (root at the reference's own place), applied external forces per
body (N, world), and the centre of mass (m). A run that tracks a clip also keeps the clip itself
(``clip_qpos``, one row per clip frame, with ``clip_frame_time`` and ``clip_start_frame`` in the meta): the
clip at the run's time, which the reference frame is not once resynchronisation moves it, for the
ghost of ``bipedsim render --ghost`` and for :mod:`bipedsim.sim.fidelity`.

Storage is compact so memory stays flat in the run length (a 600 s run at 120 Hz is 72,000 samples):
samples go into preallocated numpy buffers, never Python lists of small arrays (about 3 kB a sample
with their object headers, 480 MB peak for 600 s), and each field has the smallest type that keeps
what its readers need (:data:`SAMPLE_DTYPES`).
"""

from __future__ import annotations

import json
import math
import os
import zipfile
from dataclasses import dataclass, field
from typing import IO, Any

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.base import Controller
from bipedsim.errors import BipedsimError, ConfigError
from bipedsim.files import atomic_writer

FloatArray = npt.NDArray[np.floating]
FORMAT = "bipedsim.Trajectory/1"
#: Stored type of each field. The simulated body's positions (qpos, COM), time and reference frame
#: stay float64: rendering and BVH export replay qpos exactly and world positions reach hundreds of
#: metres in long runs. Velocities, torques, forces and the reference pose (drawn as a ghost, plotted,
#: written with 6 decimals) are float32: 7 significant digits, far below what they are measured or
#: shown to. The FSM state is a small integer.
SAMPLE_DTYPES: dict[str, type[np.generic]] = {
    "time": np.float64, "qpos": np.float64, "qvel": np.float32, "ctrl": np.float32, "contact_force": np.float32,
    "fsm_state": np.int8, "ref_frame": np.float64, "ref_qpos": np.float32, "xfrc": np.float32, "com": np.float64}
#: Samples per buffer block when the run length is not known in advance.
CHUNK_SAMPLES = 4096
#: Bytes handed to the compressor at a time when saving.
SAVE_CHUNK_BYTES = 1 << 20
#: Fewest samples per second worth calling a trajectory (rendering and plots interpolate nothing).
MIN_RECORD_HZ = 1.0


def write_npz_compressed(f: IO[bytes], arrays: dict[str, np.ndarray]) -> None:
    """What ``np.savez_compressed(f, **arrays)`` writes (``np.load`` reads it), streamed from the arrays'
    own memory in :data:`SAVE_CHUNK_BYTES` pieces: numpy's writer copies 16 MiB chunks, which for a long
    run is a fifth of the peak memory."""
    with zipfile.ZipFile(f, mode="w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf:
        for name, a in arrays.items():
            a = np.asarray(a) if a.flags.c_contiguous else a.copy()  # (ascontiguousarray makes 0-d arrays 1-d)
            with zf.open(f"{name}.npy", mode="w", force_zip64=True) as out:
                np.lib.format.write_array_header_2_0(out, np.lib.format.header_data_from_array_1_0(a))
                data = memoryview(a.reshape(-1)).cast("B") if a.size else memoryview(b"")
                for i in range(0, len(data), SAVE_CHUNK_BYTES):
                    out.write(data[i:i + SAVE_CHUNK_BYTES])


@dataclass
class Trajectory:
    """A recorded rollout, one row per sample (see the module's text for units and :data:`SAMPLE_DTYPES`)."""

    time: FloatArray
    qpos: FloatArray
    qvel: FloatArray
    ctrl: FloatArray
    contact_force: FloatArray  # (T, feet) N, in the controller's foot_names order (humanoid: left, right)
    fsm_state: npt.NDArray[np.integer]
    ref_frame: FloatArray
    ref_qpos: FloatArray
    xfrc: FloatArray  # (T, nbody, 3)
    com: FloatArray
    meta: dict[str, Any] = field(default_factory=dict)
    #: (F, nq) the tracked clip's qpos per frame (float32, as the reference pose), or None: a run without
    #: a clip (key poses) or a file written before clips were kept; see :meth:`clip_pose_frames`
    clip_qpos: FloatArray | None = None

    @property
    def num_samples(self) -> int:
        return int(len(self.time))

    def arrays(self) -> dict[str, np.ndarray]:
        """Every per-sample field by name, in :data:`SAMPLE_DTYPES` order."""
        return {k: getattr(self, k) for k in SAMPLE_DTYPES}

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write ``path`` (.npz, compressed), atomically. Fields are stored in :data:`SAMPLE_DTYPES`;
        the archive is streamed into the file, never built whole in memory."""
        arrays = {k: np.asarray(v, dtype=SAMPLE_DTYPES[k]) for k, v in self.arrays().items()}
        if self.clip_qpos is not None:
            arrays["clip_qpos"] = np.asarray(self.clip_qpos, dtype=np.float32)
        arrays["meta"] = np.array(json.dumps(dict(self.meta, format=FORMAT), default=str))
        with atomic_writer(path) as f:
            write_npz_compressed(f, arrays)

    @staticmethod
    def load(path: str | os.PathLike[str]) -> Trajectory:
        """Read a file written by :meth:`save`; :class:`BipedsimError` names the file and what is wrong."""
        try:
            if not os.path.isfile(path):
                raise ValueError("no such file")
            if not zipfile.is_zipfile(path):  # else numpy tries it as a pickle and says so
                raise ValueError("not an .npz archive")
            with np.load(path, allow_pickle=False) as z:
                meta = json.loads(str(z["meta"]))
                if meta.get("format") != FORMAT:
                    raise ValueError(f"format {meta.get('format')!r}")
                clip = z["clip_qpos"] if "clip_qpos" in z.files else None
                return Trajectory(**{k: z[k] for k in SAMPLE_DTYPES}, meta=meta, clip_qpos=clip)
        except (OSError, KeyError, ValueError) as exc:
            raise BipedsimError(f"{path}: not a bipedsim trajectory ({exc})") from None

    def with_clip(self, clip_qpos: FloatArray, frame_time: float, start_frame: float) -> Trajectory:
        """This trajectory keeping the clip it tracked: ``clip_qpos`` (F, nq) per frame, ``frame_time``
        (s per frame) and the frame the run started at (``start_frame``; sample time 0 is that frame)."""
        self.clip_qpos = np.asarray(clip_qpos, dtype=np.float32)
        self.meta = dict(self.meta, clip_frame_time=float(frame_time), clip_start_frame=float(start_frame))
        return self

    def clip_pose_frames(self) -> tuple[FloatArray, float, float] | None:
        """(clip qpos per frame, frame time s, start frame) of the clip the run tracked, or None when the
        file keeps none."""
        if self.clip_qpos is None or "clip_frame_time" not in self.meta:
            return None
        return self.clip_qpos, float(self.meta["clip_frame_time"]), float(self.meta.get("clip_start_frame", 0.0))

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
                out.append((float(self.time[s]), float(self.time[e - 1]), b,
                            self.xfrc[s:e, b].astype(np.float64).mean(axis=0)))
        return out


#: Trajectory samples per second unless a run asks for another rate.
DEFAULT_RECORD_HZ = 120.0

class Recorder:
    """A rollout hook that samples the state at ``record_hz`` (1/s) into preallocated buffers.

    ``seconds``: the run length (s), when known: the buffers are sized for it once (untouched memory
    costs nothing until written, so a run that ends early pays only for what it recorded). Otherwise
    they grow in blocks of :data:`CHUNK_SAMPLES`. ``key`` names the rate where an error reports it
    (the command line passes its flag).
    """

    def __init__(self, model: mujoco.MjModel, record_hz: float = DEFAULT_RECORD_HZ, seconds: float | None = None,
                 key: str = "record_hz", feet: int = 2) -> None:
        # one sample per physics step at most: the recorder runs between steps
        max_hz = 1.0 / model.opt.timestep
        if not MIN_RECORD_HZ <= record_hz <= max_hz:  # also NaN
            raise ConfigError(f"must be a rate in [{MIN_RECORD_HZ:g}, {max_hz:g}] samples/s (at most one per "
                              f"physics step of {model.opt.timestep:g} s), got {record_hz}", key=key)
        self.model = model
        self.every = 1.0 / record_hz
        self.next_t = 0.0
        self._layout: dict[str, tuple[int, ...]] = {
            "time": (), "qpos": (model.nq,), "qvel": (model.nv,), "ctrl": (model.nu,), "contact_force": (feet,),
            "fsm_state": (), "ref_frame": (), "ref_qpos": (model.nq,), "xfrc": (model.nbody, 3), "com": (3,)}
        self._blocks: list[dict[str, np.ndarray]] = []
        self._used: list[int] = []  # samples written per block
        first = CHUNK_SAMPLES
        if seconds is not None and math.isfinite(seconds) and seconds > 0:
            first = int(math.ceil(seconds * record_hz)) + 2  # the sample at t = 0 and rounding
        self._add_block(first)

    @property
    def num_samples(self) -> int:
        return sum(self._used)

    def _add_block(self, n: int) -> None:
        # np.zeros maps fresh pages: memory is only taken as samples are written
        self._blocks.append({k: np.zeros((n, *shape), dtype=SAMPLE_DTYPES[k]) for k, shape in self._layout.items()})
        self._used.append(0)

    def __call__(self, t: float, data: mujoco.MjData, ctrl: Controller) -> None:
        if t + 1e-9 < self.next_t:
            return
        self.next_t += self.every
        if self._used[-1] == len(self._blocks[-1]["time"]):
            self._add_block(CHUNK_SAMPLES)
        b, i = self._blocks[-1], self._used[-1]
        b["time"][i] = t
        b["qpos"][i] = data.qpos
        b["qvel"][i] = data.qvel
        b["ctrl"][i] = ctrl.actuator_torques()
        b["contact_force"][i] = ctrl.foot_forces(data)
        b["fsm_state"][i] = ctrl.gait_state()
        b["ref_frame"][i] = ctrl.frame
        b["ref_qpos"][i] = ctrl.reference_qpos()
        b["xfrc"][i] = data.xfrc_applied[:, :3]
        b["com"][i] = data.subtree_com[1]
        self._used[-1] += 1

    def _consolidate(self) -> dict[str, np.ndarray]:
        """The recorded samples as one array per field. Several blocks are joined field by field, each
        block's field dropped once copied, so the peak is the data plus one field, not twice the data."""
        if len(self._blocks) > 1:
            joined = {}
            for k in self._layout:
                joined[k] = np.concatenate([b.pop(k)[:n] for b, n in zip(self._blocks, self._used)])
            self._blocks, self._used = [joined], [len(joined["time"])]
        n = self._used[0]
        return {k: v[:n] for k, v in self._blocks[0].items()}

    def trajectory(self, meta: dict[str, Any] | None = None) -> Trajectory:
        """The samples so far (arrays share the recorder's buffers: no copy)."""
        if not self.num_samples:
            raise BipedsimError("nothing was recorded")
        return Trajectory(**self._consolidate(), meta=dict(meta or {}, record_hz=1.0 / self.every))
