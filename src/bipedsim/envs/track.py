"""``bipedsim/Track-v0``: the balance controller tracking a clip, as a Gymnasium environment.

An episode is one rollout (:class:`~bipedsim.sim.rollout.Rollout`, the loop ``bipedsim run`` drives),
stepped one control period per :meth:`TrackEnv.step`. The action is a residual (rad) on the balance
controller's PD targets (:attr:`~bipedsim.control.base.Controller.target_offset`; zero: today's
controller exactly), or absolute targets (``absolute=True``). An episode ends (``terminated``) when the
body falls by the body kind's own rule (:class:`~bipedsim.sim.rollout.FallDetector`, checked as the
rollout checks it) or the simulation diverges, and is truncated after ``seconds``.

Observation: a flat float32 vector; :attr:`TrackEnv.layout` maps each part's name to its slice:

==================  ==========  ==================================================================
part                size        what (units)
==================  ==========  ==================================================================
``joint_pos``       nq - 7      joint positions below the root (rad; a ball joint: its quaternion)
``joint_vel``       nv - 6      joint velocities (rad/s)
``root_height``     1           the root's height above the floor (m)
``root_quat``       4           the root's orientation, world frame (w, x, y, z)
``root_vel``        6           the root's linear velocity (m/s, world) and angular velocity (rad/s, local)
``foot_contact``    feet        each foot's vertical contact force over the body's weight
``phase``           2           sin, cos of 2 pi x the reference's frame over its length
``gait_state``      5           one-hot gait state (0 for a body without a gait machine; SIMBICON 1-4)
``target_pose``     nq - 7      the reference's pose now (as ``joint_pos``)
==================  ==========  ==================================================================
"""

from __future__ import annotations

import math
import os
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.envs.settings import PushRanges, RewardWeights, TrackSettings, track_settings
from bipedsim.errors import ConfigError
from bipedsim.model.ground import Ground
from bipedsim.sim.push import Push, check_pushes
from bipedsim.sim.rollout import Outcome, Rollout, RolloutSpec
from bipedsim.sim.runner import Scenario, load_scenario, record_made, start_state

FloatArray = npt.NDArray[np.float64]
#: gait states the observation's one-hot covers (0: none; SIMBICON's 1-4)
GAIT_STATES = 5
#: rgb_array frames: pixels (height, width), camera distance (m), elevation (degrees), look-at height (m)
RENDER_SIZE = (480, 640)
CAMERA = (3.0, -15.0, 0.9)


class TrackEnv(gym.Env):
    """The body tracking its reference under the balance controller, with a policy's residual on the
    controller's PD targets (module text: observation, action, reward, termination).

    ``bvh``: a clip any ``bipedsim run --bvh`` takes, humanoid or creature (None: the built-in walk);
    ``controller``: a controller YAML; ``profile``: the body kind (None: measured); ``pushes``: random
    pushes per episode (:class:`PushRanges` or its dict); ``ground``: ``--ground`` terms (``"slope:8"``,
    a list of them, or a :class:`~bipedsim.model.ground.Ground`; None: flat); ``reconstruct``: search a
    humanoid clip's feed-forward correction first (minutes; off by default here). The other settings:
    :class:`TrackSettings`."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(self, bvh: str | os.PathLike[str] | None = None, controller: str | os.PathLike[str] | None = None,
                 *, seconds: float | None = None, pushes: PushRanges | dict[str, Any] | None = None,
                 ground: str | list[str] | Ground | None = None, absolute: bool | None = None,
                 action_limit: float | None = None,
                 init_noise: float | None = None, reward: RewardWeights | dict[str, Any] | None = None,
                 profile: str | None = None, reconstruct: bool = False, render_mode: str | None = None,
                 scenario: Scenario | None = None) -> None:
        ground = ground if isinstance(ground, Ground) or ground is None else Ground.parse(ground, key="ground")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"unknown render mode {render_mode!r}; modes: rgb_array", key="render_mode")
        self.settings: TrackSettings = track_settings(seconds, action_limit=action_limit, absolute=absolute,
                                                      init_noise=init_noise, reward=reward, pushes=pushes)
        self.scenario = scenario or load_scenario(controller, bvh, profile=profile, reconstruct=reconstruct,
                                                  ground=ground)
        self.render_mode = render_mode
        self.model = self.scenario.built.model
        probe = self.scenario.controller()
        self.target_names: tuple[str, ...] = probe.target_names()
        if not self.target_names:
            raise ConfigError(f"the {self.scenario.profile} controller takes no PD target offsets", key="bvh")
        self._feet = len(probe.foot_names())
        self._weight = float(np.sum(self.model.body_mass)) * -float(self.model.opt.gravity[2])
        self._torso = self._upright_body(probe.root_body)
        self._frames = max(1, self.scenario.clip.num_frames)
        self.layout = self._layout()
        n_obs = max(s.stop for s in self.layout.values())
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, shape=(n_obs,), dtype=np.float32)
        lim = math.pi if self.settings.absolute else self.settings.action_limit
        self.action_space = gym.spaces.Box(-lim, lim, shape=(len(self.target_names),), dtype=np.float32)
        self.run: Rollout | None = None
        self.pushes: list[Push] = []
        self._renderer: Any = None
        self._camera: Any = None

    # ------------------------------------------------------------------ the layout
    def _layout(self) -> dict[str, slice]:
        nj, vj = self.model.nq - 7, self.model.nv - 6
        sizes = [("joint_pos", nj), ("joint_vel", vj), ("root_height", 1), ("root_quat", 4), ("root_vel", 6),
                 ("foot_contact", self._feet), ("phase", 2), ("gait_state", GAIT_STATES), ("target_pose", nj)]
        out, at = {}, 0
        for name, n in sizes:
            out[name] = slice(at, at + n)
            at += n
        return out

    def _upright_body(self, root: int) -> int:
        torso = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "torso")
        return torso if torso >= 0 else root

    # ------------------------------------------------------------------ the episode
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[npt.NDArray[np.float32], dict[str, Any]]:
        """A new episode from the reference's start (the seed draws the pushes and initial noise)."""
        super().reset(seed=seed)
        self._close_run()
        s = self.settings
        noise_seed = int(self.np_random.integers(2**31 - 1)) if s.init_noise > 0 else 0
        self.pushes = self._draw_pushes()
        check_pushes(self.pushes, s.seconds)
        sc = self.scenario
        ctrl = sc.controller()
        ctrl.target_absolute = s.absolute
        spec, qpos0, qvel0, noise = start_state(sc, RolloutSpec(seconds=s.seconds, seed=noise_seed,
                                                                init_noise=s.init_noise), ctrl)
        self._spec = spec
        self.run = run = Rollout(sc.built.model, sc.built.plan, ctrl, spec, initial_qpos=qpos0, initial_qvel=qvel0,
                           qvel_noise=noise, pushes=self.pushes or None)
        # views into the state, made once: MuJoCo makes a new array object on every attribute read
        self._qpos, self._qvel = run.data.qpos, run.data.qvel
        self._up = run.data.xmat[self._torso]
        return self._observation(), {"time": 0.0}

    def _draw_pushes(self) -> list[Push]:
        r = self.settings.pushes
        if r is None or r.count == 0:
            return []
        rng, out = self.np_random, []
        for _ in range(r.count):
            dur = float(rng.uniform(*r.duration))
            start = min(float(rng.uniform(*r.start)), max(self.settings.seconds - dur, 0.0))
            out.append(Push(magnitude=float(rng.uniform(*r.magnitude)), direction=float(rng.uniform(*r.direction)),
                            duration=dur, start=start, body=self._push_body()))
        return sorted(out, key=lambda p: p.start or 0.0)

    def _push_body(self) -> str:
        return "torso" if self.scenario.profile == "humanoid" else self.model.body(1).name

    def step(self, action: Any) -> tuple[npt.NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        """One control period with ``action`` on the PD targets: (observation, reward, terminated,
        truncated, info); info has the time (s) and, at the episode's end, its :class:`Outcome`."""
        run = self.run
        if run is None or run.done:
            raise ConfigError("step() before reset(), or after the episode ended: call reset()", key="step")
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape[0] != self.action_space.shape[0]:
            raise ConfigError(f"expected {self.action_space.shape[0]} values, got {a.shape[0]}", key="action")
        # an all-zero residual is no offset at all: today's controller, bit for bit
        run.ctrl.target_offset = a if (self.settings.absolute or a.any()) else None
        run.step()
        verdict = run.verdict[0]
        terminated = verdict in ("fall", "diverged")
        truncated = run.done and not terminated
        info: dict[str, Any] = {"time": run.time}
        if run.done:
            info["outcome"] = self.outcome()
        return self._observation(), self._reward(a, terminated), terminated, truncated, info

    def outcome(self) -> Outcome:
        """The episode's :class:`Outcome` so far (at its end: as ``bipedsim run`` reports it)."""
        if self.run is None:
            raise ConfigError("no episode yet: call reset()", key="outcome")
        out = self.run.finish()
        record_made(out, self.scenario, self._spec, self.pushes)
        return out

    # ------------------------------------------------------------------ observation and reward
    def _observation(self) -> npt.NDArray[np.float32]:
        run = self.run
        assert run is not None
        data, ctrl, lay, qpos, qvel = run.data, run.ctrl, self.layout, self._qpos, self._qvel
        obs = np.empty(self.observation_space.shape[0], dtype=np.float32)
        obs[lay["joint_pos"]] = qpos[7:]
        obs[lay["joint_vel"]] = qvel[6:]
        obs[lay["root_height"]] = qpos[2]
        obs[lay["root_quat"]] = qpos[3:7]
        obs[lay["root_vel"]] = qvel[0:6]
        obs[lay["foot_contact"]] = np.asarray(ctrl.foot_forces(data), dtype=np.float64) / self._weight
        angle = 2.0 * math.pi * ((ctrl.frame % self._frames) / self._frames)
        obs[lay["phase"]] = (math.sin(angle), math.cos(angle))
        state = np.zeros(GAIT_STATES)
        state[min(max(int(ctrl.gait_state()), 0), GAIT_STATES - 1)] = 1.0
        obs[lay["gait_state"]] = state
        obs[lay["target_pose"]] = ctrl.reference_qpos()[7:]
        return obs

    def _reward(self, action: FloatArray, fell: bool) -> float:
        run = self.run
        assert run is not None
        w = self.settings.reward
        e = run.ctrl.tracking_error
        rms = float(np.sqrt(e.dot(e) / max(len(e), 1)))
        up = float(self._up[8])  # the body's up axis, z component
        r = w.tracking * math.exp(-((rms / w.tracking_scale) ** 2)) + w.upright * max(0.0, up)
        if not self.settings.absolute:
            r -= w.action * float(action.dot(action)) / max(len(action), 1)
        return r + (w.fall if fell else 0.0)

    # ------------------------------------------------------------------ rendering and closing
    def render(self) -> npt.NDArray[np.uint8] | None:
        """An RGB frame (H, W, 3) of the body now, the camera following it (``render_mode="rgb_array"``;
        MuJoCo's GL backend is the process's ``MUJOCO_GL``, e.g. ``egl`` headless)."""
        if self.render_mode != "rgb_array" or self.run is None:
            return None
        if self._renderer is None:
            self._renderer, self._camera = make_renderer(self.model)
        data = self.run.data
        self._camera.lookat[:] = (data.xpos[1, 0], data.xpos[1, 1], CAMERA[2])
        self._renderer.update_scene(data, camera=self._camera)
        return self._renderer.render()

    def _close_run(self) -> None:
        if self.run is not None:
            self.run.close()
            self.run = None

    def close(self) -> None:
        self._close_run()
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def make_renderer(model: mujoco.MjModel) -> tuple[Any, Any]:
    """A MuJoCo renderer of :data:`RENDER_SIZE` for ``model`` and a free camera at :data:`CAMERA`; a
    :class:`~bipedsim.render.gl.RenderError` saying how to get one where GL does not start."""
    from bipedsim.render.gl import RenderError

    h, w = RENDER_SIZE
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, w)
    model.vis.global_.offheight = max(model.vis.global_.offheight, h)
    try:
        renderer = mujoco.Renderer(model, h, w)
    except Exception as exc:  # MuJoCo raises several types when no GL context can be made
        raise RenderError(f"cannot render rgb_array frames: {exc}; set MUJOCO_GL=egl (or osmesa) before "
                          "importing bipedsim for headless rendering") from None
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.distance, cam.elevation = CAMERA[0], CAMERA[1]
    return renderer, cam
