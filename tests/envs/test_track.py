"""``bipedsim/Track-v0``: Gymnasium's checks pass on a humanoid walk, a generated capture and a creature;
a zero action is today's controller exactly (the episode is ``bipedsim run``'s rollout); residuals and
absolute targets reach the PD targets; episodes are reproducible from their seed; the vector form steps."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from bvh_fixtures import CMU_UNIT_M, _standin_motion, _text
from gymnasium.utils.env_checker import check_env

import bipedsim.envs  # noqa: F401 - registers the environments
from bipedsim.data import HORSE_WALK
from bipedsim.envs import TrackEnv
from bipedsim.errors import ConfigError
from bipedsim.render.gl import RenderError, choose_backend
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario


@pytest.fixture(scope="module")
def walk_env() -> TrackEnv:
    env = TrackEnv(seconds=2.0)
    yield env
    env.close()


def _checked(env: gym.Env) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the unbounded Box's "probably too high" advice
        check_env(env, skip_render_check=True)


def test_check_env_passes_on_the_builtin_walk(walk_env: TrackEnv) -> None:
    _checked(walk_env)


def _episode(env: TrackEnv, action: np.ndarray | None = None, seed: int = 0) -> tuple[int, dict]:
    env.reset(seed=seed)
    a = np.zeros(env.action_space.shape) if action is None else action
    n, done, info = 0, False, {}
    while not done:
        _, _, term, trunc, info = env.step(a)
        n, done = n + 1, term or trunc
    return n, info


def test_a_zero_action_episode_is_the_run_commands_rollout(walk_env: TrackEnv) -> None:
    n, info = _episode(walk_env)
    out = info["outcome"]
    ref, _ = run_scenario(load_scenario(None), RolloutSpec(seconds=2.0))
    assert out.outcome == ref.outcome == "no_fall"
    assert out.distance_m == ref.distance_m and out.tracking_rmse_rad == ref.tracking_rmse_rad
    assert out.steps == ref.steps and n * walk_env.run.every == ref.steps
    assert out.config["seconds"] == 2.0 and out.versions["mujoco"]


def test_a_residual_moves_the_pd_targets(walk_env: TrackEnv) -> None:
    _, still = _episode(walk_env)
    bent = np.zeros(walk_env.action_space.shape, dtype=np.float32)
    bent[list(walk_env.target_names).index(walk_env.target_names[0])] = 0.3
    _, moved = _episode(walk_env, bent)
    assert moved["outcome"].distance_m != still["outcome"].distance_m


def test_absolute_targets_replace_the_controllers() -> None:
    env = TrackEnv(seconds=1.0, absolute=True)
    assert env.action_space.high[0] == pytest.approx(np.pi)
    n, info = _episode(env)  # every hinge held at 0 rad: the walk stops walking (and may fall)
    assert info["outcome"].distance_m < 0.5 or info["outcome"].outcome == "fall"
    env.close()


def test_observation_layout_covers_the_vector(walk_env: TrackEnv) -> None:
    obs, _ = walk_env.reset(seed=0)
    lay = walk_env.layout
    assert sum(s.stop - s.start for s in lay.values()) == obs.shape[0]
    data = walk_env.run.data
    assert obs[lay["root_height"]][0] == pytest.approx(data.qpos[2], rel=1e-6)
    assert obs[lay["gait_state"]].sum() == 1.0
    assert np.allclose(np.linalg.norm(obs[lay["phase"]]), 1.0)
    assert len(walk_env.target_names) == walk_env.action_space.shape[0] == 26


def test_pushes_are_drawn_from_the_seed_and_reach_the_episode() -> None:
    env = TrackEnv(seconds=2.0, pushes={"magnitude": (250.0, 300.0), "start": (0.5, 1.0), "count": 2})
    env.reset(seed=3)
    first = list(env.pushes)
    env.reset(seed=3)
    assert env.pushes == first and len(first) == 2
    env.reset(seed=4)
    assert env.pushes != first
    _, info = _episode(env, seed=3)
    assert info["outcome"].extra["push_start_s"] == pytest.approx(first[0].start, abs=0.01)
    env.close()


def test_bad_arguments_are_config_errors_naming_the_key() -> None:
    with pytest.raises(ConfigError, match="ground"):
        TrackEnv(ground="slope")
    with pytest.raises(ConfigError, match="reward.trackin"):
        TrackEnv(reward={"trackin": 1.0})
    with pytest.raises(ConfigError, match="pushes.start"):
        TrackEnv(pushes={"start": (2.0, 1.0)})


def test_sync_vector_env_steps() -> None:
    envs = gym.vector.SyncVectorEnv([lambda: gym.make("bipedsim/Track-v0", seconds=0.5) for _ in range(2)])
    obs, _ = envs.reset(seed=[0, 1])
    assert obs.shape == (2, 98)
    for _ in range(5):
        obs, rew, term, trunc, _ = envs.step(envs.action_space.sample())
    assert np.isfinite(obs).all() and rew.shape == (2,) and not term.any()
    envs.close()


def _capture(tmp_path: Path) -> Path:
    """A generated CMU-style walk (31 joints, 120 fps, CRLF)."""
    path = tmp_path / "walk31.bvh"
    path.write_bytes(_text(_standin_motion("holden31", CMU_UNIT_M, "y", 120.0), eol="\r\n"))
    return path


@pytest.mark.slow
@pytest.mark.parametrize("which", ["capture", "creature"])
def test_check_env_and_1000_random_steps(which: str, tmp_path: Path) -> None:
    env = TrackEnv(_capture(tmp_path) if which == "capture" else HORSE_WALK, seconds=1.0)
    assert env.scenario.profile == ("humanoid" if which == "capture" else "creature")
    _checked(env)
    env.reset(seed=1)
    for _ in range(1000):
        obs, _, term, trunc, _ = env.step(env.action_space.sample())
        assert np.isfinite(obs).all()
        if term or trunc:
            env.reset()
    env.close()


RENDER = """
import numpy as np, bipedsim.envs, gymnasium as gym
env = gym.make("bipedsim/Track-v0", seconds=0.5, render_mode="rgb_array")
env.reset(seed=0)
img = env.render()
assert img.shape == (480, 640, 3) and img.dtype == np.uint8
sky = img[5, 5].astype(int)
body = (np.abs(img.astype(int) - sky).sum(axis=2) > 60)[100:400, 220:420]
print(body.mean())
"""


def test_an_rgb_array_frame_shows_the_body() -> None:
    try:
        backend = choose_backend()
    except RenderError as exc:
        pytest.skip(f"no headless GL here: {exc}")
    env = {"MUJOCO_GL": backend, "PYOPENGL_PLATFORM": backend}
    import os

    p = subprocess.run([sys.executable, "-c", RENDER], env={**os.environ, **env}, capture_output=True, text=True,
                       timeout=120, check=False)
    assert p.returncode == 0, p.stderr[-2000:]
    assert float(p.stdout.strip().splitlines()[-1]) > 0.02  # the body covers part of the frame's middle


def test_the_docs_residual_policy_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    """The ten-line example of docs/python_api.md and README.md (a residual policy stepping the
    environment): the same in both, and it runs."""
    repo = Path(__file__).resolve().parents[2]
    examples = []
    for doc in (repo / "docs" / "python_api.md", repo / "README.md"):
        blocks = [b.split("```", 1)[0] for b in doc.read_text(encoding="utf-8").split("```python\n")[1:]]
        examples.append(next(b for b in blocks if "Track-v0" in b))
    assert examples[0] == examples[1]
    exec(compile(examples[0], "docs/python_api.md", "exec"), {})
    outcome, distance = capsys.readouterr().out.split()
    assert outcome in ("no_fall", "fall", "push_not_applied") and float(distance) > 0.5


def test_the_environment_walks_the_ground_it_is_given() -> None:
    """``ground`` takes the ``--ground`` terms: the body's model carries the ground, the episode runs on it."""
    from bipedsim.model.ground import terrain_of

    env = TrackEnv(ground="slope:6", seconds=0.5)
    t = terrain_of(env.model)
    assert t is not None and t.height(5.0, 0.0) != pytest.approx(0.0, abs=1e-3)
    env.reset(seed=0)
    done = False
    while not done:
        _, _, term, trunc, _ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
        done = term or trunc
    assert not term
    env.close()


def test_interleaved_episodes_leave_mujoco_s_warning_handler_as_it_was() -> None:
    """Several open episodes (a vector of environments) step in turn; MuJoCo's one process-wide warning
    handler is a rollout's only during its step, so none is left installed."""
    import mujoco

    a, b = TrackEnv(seconds=0.2), TrackEnv(seconds=0.2)
    a.reset(seed=0)
    b.reset(seed=1)
    zero = np.zeros(a.action_space.shape, dtype=np.float32)
    a.step(zero)
    b.step(zero)
    a.close()
    b.step(zero)
    b.close()
    assert mujoco.get_mju_user_warning() is None
