"""``bipedsim view``: the controller running live in MuJoCo's interactive viewer (``mujoco.viewer``,
passive mode), driving the one rollout loop (:class:`~bipedsim.sim.rollout.Rollout`) at the wall clock.

Keys (:data:`KEYS`): ``1``-``8`` push the torso (a creature: its root) from one of eight directions
(``1`` from behind, i.e. forward, then every 45 degrees counter-clockwise: ``3`` pushes left, ``5``
backward, ``7`` right) with :attr:`ViewSettings.push_magnitude` N for :attr:`ViewSettings.push_duration`
s; space pauses and resumes; ``-`` halves the speed, ``=`` doubles it (within :data:`SPEEDS`);
Backspace restarts from the reference's start. The mouse is MuJoCo's own: double-click a body to
select it, then Ctrl + right-drag pulls it (a force), Ctrl + left-drag turns it (a torque); its wrench
reaches ``data.xfrc_applied`` on every physics step, added to the pushes. Drawn in the scene: an arrow
per acting push (or pull), and a ball above the root coloured by the gait state (:data:`STATE_RGBA`).
"""

from __future__ import annotations

import math
import os
import queue
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from bipedsim.control.base import Controller
from bipedsim.errors import BipedsimError
from bipedsim.sim.push import Push, PushSchedule
from bipedsim.sim.rollout import Rollout, RolloutSpec
from bipedsim.sim.runner import Scenario, start_state

#: GLFW key codes the viewer answers (the key callback's argument)
KEY_SPACE, KEY_MINUS, KEY_EQUAL, KEY_BACKSPACE = 32, 45, 61, 259
KEY_DIGIT_1 = 49
#: what each key does (for the help line and the docs)
KEYS = {"1-8": "push from 8 directions (1 forward, 3 left, 5 backward, 7 right)", "space": "pause / resume",
        "-": "half speed", "=": "double speed", "Backspace": "restart"}
#: playback speeds (x real time) the - and = keys step through
SPEEDS = (1 / 16, 1 / 8, 1 / 4, 1 / 2, 1.0, 2.0)
#: the gait-state ball's colour per state (0: no gait machine; SIMBICON's 1-4), RGBA
STATE_RGBA = ((0.6, 0.6, 0.6, 1.0), (0.2, 0.5, 1.0, 1.0), (0.1, 0.8, 0.3, 1.0), (1.0, 0.6, 0.1, 1.0),
              (0.9, 0.2, 0.6, 1.0))
#: N per m of a drawn push arrow; the gait-state ball's radius (m) and height above the root (m)
ARROW_N_PER_M, BALL_RADIUS_M, BALL_ABOVE_M = 400.0, 0.05, 0.6


class ViewerError(BipedsimError):
    """The interactive viewer cannot open here (no display, or its GL window fails)."""


@dataclass(frozen=True)
class ViewSettings:
    """What ``bipedsim view`` runs: the run length, the key pushes and the frame rate."""

    #: simulated seconds of one run (then it holds its last pose until restarted)
    seconds: float = field(default=600.0, metadata={"gt": 0.0})
    #: N; a key push's horizontal force: a firm shove the default walk recovers from
    push_magnitude: float = field(default=200.0, metadata={"gt": 0.0})
    #: s; a key push's duration
    push_duration: float = field(default=0.2, metadata={"gt": 0.0})
    #: frames per second the viewer is synced at
    fps: float = field(default=60.0, metadata={"gt": 0.0})
    #: s; the most simulated time one frame catches up (a slow machine slows down instead of stalling)
    max_catch_up: float = field(default=0.1, metadata={"gt": 0.0})


@dataclass(frozen=True)
class Command:
    """One key's command: ``push`` (``direction`` degrees from the heading), ``pause``, ``slower``,
    ``faster`` or ``restart``."""

    kind: str
    direction: float = 0.0


def key_command(key: int) -> Command | None:
    """The command of GLFW key code ``key`` (:data:`KEYS`), or None for a key the viewer keeps."""
    if KEY_DIGIT_1 <= key < KEY_DIGIT_1 + 8:
        return Command("push", 45.0 * (key - KEY_DIGIT_1))
    return {KEY_SPACE: Command("pause"), KEY_MINUS: Command("slower"), KEY_EQUAL: Command("faster"),
            KEY_BACKSPACE: Command("restart")}.get(key)


@dataclass
class ViewState:
    """What the keys change: paused, the speed (an index into :data:`SPEEDS`), a restart asked for,
    the pushes fired and not yet applied."""

    paused: bool = False
    speed: int = SPEEDS.index(1.0)
    restart: bool = False
    pushes: list[float] = field(default_factory=list)  #: directions (degrees) of pushes to fire

    def apply(self, cmd: Command) -> None:
        if cmd.kind == "push":
            self.pushes.append(cmd.direction)
        elif cmd.kind == "pause":
            self.paused = not self.paused
        elif cmd.kind == "slower":
            self.speed = max(0, self.speed - 1)
        elif cmd.kind == "faster":
            self.speed = min(len(SPEEDS) - 1, self.speed + 1)
        elif cmd.kind == "restart":
            self.restart = True

    @property
    def factor(self) -> float:
        return SPEEDS[self.speed]


class LiveForces:
    """The rollout's ``before_step`` hook in the viewer: the scheduled pushes (``--push``, through
    :class:`~bipedsim.sim.push.PushSchedule`, which clears ``xfrc_applied`` first), the key pushes and
    the mouse's perturbation (:func:`mujoco.mjv_applyPerturbForce`, added after the clearing, so the
    loop keeps it)."""

    def __init__(self, model: mujoco.MjModel, pushes: list[Push], ctrl: Controller) -> None:
        self.model = model
        self.schedule = PushSchedule(model, list(pushes))
        self.schedule.check_controller(ctrl)
        self.perturb: Any = None  #: the viewer's MjvPerturb (set once the viewer is open)
        #: key pushes acting: (body, force N world, end time s)
        self.keyed: list[tuple[int, np.ndarray, float]] = []

    def fire(self, direction: float, magnitude: float, duration: float, t: float, data: mujoco.MjData,
             ctrl: Controller) -> None:
        a = ctrl.heading(data) + math.radians(direction)
        self.keyed.append((ctrl.root_body if self._torso() < 0 else self._torso(),
                           np.array([magnitude * math.cos(a), magnitude * math.sin(a), 0.0]), t + duration))

    def _torso(self) -> int:
        return mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "torso")

    def __call__(self, t: float, data: mujoco.MjData, ctrl: Controller) -> None:
        self.schedule(t, data, ctrl)
        self.keyed = [k for k in self.keyed if t < k[2]]
        for body, force, _ in self.keyed:
            data.xfrc_applied[body, :3] += force
        pulled = self.perturb is not None and bool(self.perturb.active)
        if pulled:  # MuJoCo sets the selected body's row: the pushes on it are added back
            sel = int(self.perturb.select)
            pushed = data.xfrc_applied[sel].copy()
            mujoco.mjv_applyPerturbForce(self.model, data, self.perturb)
            data.xfrc_applied[sel] += pushed
        if self.keyed or pulled:
            ctrl.set_external_force(True, t)


def display_problem(env: dict[str, str] | None = None, platform: str = sys.platform) -> str | None:
    """Why no window can open here (Linux and the BSDs without ``DISPLAY`` or ``WAYLAND_DISPLAY``), or None."""
    env = dict(os.environ) if env is None else env
    if platform.startswith(("linux", "freebsd", "openbsd")) and not (env.get("DISPLAY") or env.get("WAYLAND_DISPLAY")):
        return ("no display: the live viewer needs a desktop session (DISPLAY or WAYLAND_DISPLAY is not set); "
                "use `bipedsim run --video` for a rendered video instead")
    return None


def start_run(sc: Scenario, settings: ViewSettings, pushes: list[Push], data: mujoco.MjData | None = None
              ) -> tuple[Rollout, LiveForces]:
    """A fresh rollout of ``sc`` from the reference's start (in ``data`` when given: the state the viewer
    shows), with the live forces as its hook."""
    ctrl = sc.controller()
    spec, qpos0, qvel0, noise = start_state(sc, RolloutSpec(seconds=settings.seconds), ctrl)
    forces = LiveForces(sc.built.model, pushes, ctrl)
    run = Rollout(sc.built.model, sc.built.plan, ctrl, spec, initial_qpos=qpos0, initial_qvel=qvel0,
                  qvel_noise=noise, before_step=[forces], data=data)
    return run, forces


def draw(scn: Any, run: Rollout, forces: LiveForces) -> None:
    """The viewer's own scene geoms: an arrow per acting push, the gait-state ball."""
    data = run.data
    scn.ngeom = 0
    t = run.time
    acting = [(a.body, a.force) for a in forces.schedule.fired if a.start <= t < a.end]
    acting += [(b, f) for b, f, _ in forces.keyed]
    for body, f in acting:
        if scn.ngeom >= scn.maxgeom:
            return
        tip = data.xipos[body]
        g = scn.geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), np.zeros(9),
                            np.array([1.0, 0.2, 0.1, 1.0], dtype=np.float32))
        mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_ARROW, 0.03, tip - f / ARROW_N_PER_M, tip)
        scn.ngeom += 1
    if scn.ngeom < scn.maxgeom:
        state = min(max(run.ctrl.gait_state(), 0), len(STATE_RGBA) - 1)
        pos = data.xpos[run.ctrl.root_body] + np.array([0.0, 0.0, BALL_ABOVE_M])
        mujoco.mjv_initGeom(scn.geoms[scn.ngeom], mujoco.mjtGeom.mjGEOM_SPHERE, np.full(3, BALL_RADIUS_M), pos,
                            np.eye(3).ravel(), np.array(STATE_RGBA[state], dtype=np.float32))
        scn.ngeom += 1


def status_text(run: Rollout, state: ViewState) -> tuple[str, str]:
    """The overlay's two columns: names (time, speed, gait state, status) and their values."""
    verdict, when, why = run.verdict
    status = ("paused" if state.paused else "running") if not run.done else (
        f"{verdict} at {when:.2f} s: {why}" if when is not None else "ended") + " (Backspace restarts)"
    return ("time\nspeed\ngait state\nstatus",
            f"{run.time:.2f} s\nx{state.factor:g}\n{run.ctrl.gait_state()}\n{status}")


def view(sc: Scenario, pushes: list[Push] | None = None, settings: ViewSettings | None = None,
         say: Any = None) -> None:
    """Run ``sc``'s controller in MuJoCo's interactive viewer until its window is closed (module text:
    keys and mouse). A :class:`ViewerError` without a display or where the window does not open."""
    settings = settings or ViewSettings()
    pushes = list(pushes or [])
    problem = display_problem()
    if problem:
        raise ViewerError(problem)
    import mujoco.viewer

    commands: queue.SimpleQueue[Command] = queue.SimpleQueue()

    def on_key(key: int) -> None:  # the viewer's thread: hand the command to the loop
        cmd = key_command(key)
        if cmd is not None:
            commands.put(cmd)

    run, forces = start_run(sc, settings, pushes)
    try:
        handle = mujoco.viewer.launch_passive(sc.built.model, run.data, key_callback=on_key)
    except Exception as exc:  # GLFW's and MuJoCo's own types: any failure to open the window
        run.close()
        raise ViewerError(f"the viewer window did not open: {exc}") from None
    if say is not None:
        say("keys: " + "; ".join(f"{k} {v}" for k, v in KEYS.items()) + "; mouse: double-click a body, Ctrl + "
            "right-drag to pull it")
    _loop(handle, sc, settings, pushes, run, forces, commands)


def _loop(handle: Any, sc: Scenario, settings: ViewSettings, pushes: list[Push], run: Rollout, forces: LiveForces,
          commands: queue.SimpleQueue[Command]) -> None:
    state = ViewState()
    frame = 1.0 / settings.fps
    last = time.perf_counter()
    try:
        with handle:
            forces.perturb = handle.perturb
            while handle.is_running():
                while not commands.empty():
                    state.apply(commands.get())
                if state.restart:
                    run.close()
                    run, forces = start_run(sc, settings, pushes, run.data)
                    forces.perturb = handle.perturb
                    state.restart = False
                now = time.perf_counter()
                if not state.paused and not run.done:
                    for d in state.pushes:
                        forces.fire(d, settings.push_magnitude, settings.push_duration, run.time, run.data, run.ctrl)
                    state.pushes.clear()
                    goal = run.time + min((now - last) * state.factor, settings.max_catch_up)
                    while run.time < goal and run.step():
                        pass
                last = now
                with handle.lock():
                    draw(handle.user_scn, run, forces)
                handle.set_texts((None, mujoco.mjtGridPos.mjGRID_TOPLEFT, *status_text(run, state)))
                handle.sync()
                time.sleep(max(0.0, frame - (time.perf_counter() - now)))
    finally:
        run.close()
