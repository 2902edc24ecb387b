"""``bipedsim view``: without a display it exits 2 with one line; the keys' commands, the state they change,
the live forces (scheduled pushes, key pushes and the mouse's perturbation together on the body) and the
overlay, each without a window."""

from __future__ import annotations

import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from bipedsim.render.viewer import (
    KEY_BACKSPACE,
    KEY_DIGIT_1,
    KEY_EQUAL,
    KEY_MINUS,
    KEY_SPACE,
    SPEEDS,
    Command,
    ViewSettings,
    ViewState,
    display_problem,
    draw,
    key_command,
    start_run,
    status_text,
)
from bipedsim.sim.push import Push
from bipedsim.sim.runner import load_scenario


def test_view_without_a_display_exits_2_with_one_line() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    p = subprocess.run([sys.executable, "-m", "bipedsim.cli", "view"], env=env, capture_output=True, text=True,
                       timeout=60, check=False)
    assert p.returncode == 2 and p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bipedsim view: error: no display")


def test_display_problem_reads_the_session() -> None:
    assert display_problem({}, "linux") and display_problem({"DISPLAY": ""}, "linux")
    assert display_problem({"DISPLAY": ":0"}, "linux") is None
    assert display_problem({"WAYLAND_DISPLAY": "wayland-0"}, "linux") is None
    assert display_problem({}, "darwin") is None and display_problem({}, "win32") is None


def test_keys_map_to_commands() -> None:
    dirs = [key_command(KEY_DIGIT_1 + i) for i in range(8)]
    assert [c.direction for c in dirs] == [0, 45, 90, 135, 180, 225, 270, 315] and {c.kind for c in dirs} == {"push"}
    assert key_command(KEY_DIGIT_1 + 8) is None and key_command(ord("A")) is None  # the viewer's own keys stay
    assert [key_command(k).kind for k in (KEY_SPACE, KEY_MINUS, KEY_EQUAL, KEY_BACKSPACE)] == \
        ["pause", "slower", "faster", "restart"]


def test_view_state_follows_the_commands() -> None:
    s = ViewState()
    assert s.factor == 1.0
    for _ in range(10):
        s.apply(Command("slower"))
    assert s.factor == SPEEDS[0]
    for _ in range(10):
        s.apply(Command("faster"))
    assert s.factor == SPEEDS[-1]
    s.apply(Command("pause"))
    s.apply(Command("push", 90.0))
    s.apply(Command("restart"))
    assert s.paused and s.pushes == [90.0] and s.restart
    s.apply(Command("pause"))
    assert not s.paused


def test_live_forces_add_key_pushes_and_the_mouse_to_the_schedule() -> None:
    sc = load_scenario(None)
    run, forces = start_run(sc, ViewSettings(seconds=1.0), [Push(magnitude=100.0, direction=90.0, duration=0.5,
                                                                   start=0.0)])
    try:
        torso = sc.built.model.body("torso").id
        forces.fire(0.0, 200.0, 0.2, run.time, run.data, run.ctrl)
        model = sc.built.model
        scn = mujoco.MjvScene(model, maxgeom=100)
        mujoco.mjv_updateScene(model, run.data, mujoco.MjvOption(), None, mujoco.MjvCamera(),
                               mujoco.mjtCatBit.mjCAT_ALL, scn)
        pert = mujoco.MjvPerturb()  # the torso selected and pulled 0.5 m up, as the viewer's mouse does
        pert.select = torso
        mujoco.mjv_initPerturb(model, run.data, scn, pert)
        pert.active = mujoco.mjtPertBit.mjPERT_TRANSLATE
        pert.refpos[:] += (0.0, 0.0, 0.5)
        pert.refselpos[:] += (0.0, 0.0, 0.5)
        f = run.data.xfrc_applied
        forces(0.0, run.data, run.ctrl)  # the hook, as the loop calls it before a physics step
        pushed = f[torso].copy()
        assert np.linalg.norm(pushed[:2]) == pytest.approx(np.hypot(100.0, 200.0), rel=1e-9)  # both pushes
        f[:] = 0.0
        mujoco.mjv_applyPerturbForce(model, run.data, pert)
        mouse = f[torso].copy()
        assert mouse[2] > 100.0
        forces.perturb = pert
        forces(0.0, run.data, run.ctrl)
        assert np.allclose(f[torso], pushed + mouse, rtol=1e-12, atol=1e-9)  # the pull on top of the pushes
        run.step()
        scn = mujoco.MjvScene(model, maxgeom=10)
        draw(scn, run, forces)
        assert scn.ngeom == 3  # two push arrows and the gait-state ball
        left, right = status_text(run, ViewState())
        assert left.splitlines() == ["time", "speed", "gait state", "status"] and "running" in right
        while run.step():
            pass
        assert "Backspace restarts" in status_text(run, ViewState())[1]
        again, _ = start_run(sc, ViewSettings(seconds=1.0), [], data=run.data)  # restart in the same state
        assert again.data is run.data and again.time == 0.0 and not np.any(again.data.xfrc_applied)
        again.close()
    finally:
        run.close()
