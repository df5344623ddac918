"""Gymnasium's rendering conventions: `render_mode="rgb_array"` frames (MuJoCo's first
camera for the models, on either plant; the viewer's Mountain-Car drawing without OpenGL),
`"human"` where a display exists, `metadata["render_fps"]` from the control step, and
`RecordVideo` writing a video of an episode."""

import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from lwrl import tasks  # noqa: E402
from lwrl.gym import ENV_IDS, ENVIRONMENTS, SuiteEnv  # noqa: E402

MOUNTAIN_CAR = "lwrl/mountain_car-cost_to_go-analytic-v0"
CAR = (200, 60, 50)
"""The car's colour in Mountain-Car's Drawing."""


@pytest.mark.parametrize("id_", ENV_IDS)
def test_render_fps_is_one_frame_per_control_step(id_):
    domain, task, _ = ENVIRONMENTS[id_]
    env = gymnasium.make(id_)
    step = tasks.definition(domain, task).control_timestep
    assert env.metadata["render_fps"] == 1.0 / step
    assert {"pendulum": 50, "cartpole": 50, "acrobot": 5, "mountain_car": 1}.get(
        domain, 1.0 / step) == pytest.approx(env.metadata["render_fps"])  # lwrl's own, pinned
    assert set(env.metadata["render_modes"]) <= {"human", "rgb_array"}
    assert set(type(env.unwrapped).metadata["render_modes"]) == {"human", "rgb_array"}


def car_column(frame) -> float:
    columns = np.nonzero(np.all(frame == CAR, axis=2))[1]
    assert len(columns) > 10, "no car in the picture"
    return float(columns.mean())


def test_mountain_car_frames_draw_the_hill_and_the_car_where_it_is():
    env = gymnasium.make(MOUNTAIN_CAR, render_mode="rgb_array")
    env.reset(seed=0)
    columns = []
    for x in (-1.1, -0.5, 0.0, 0.4):
        env.reset(options={"state": [x, 0.0]})
        frame = env.render()
        assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8
        assert np.sum(np.all(frame == (90, 160, 90), axis=2)) > 200  # the hill's green line
        columns.append(car_column(frame))
    assert columns == sorted(columns) and columns[-1] - columns[0] > 100  # left to right
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gymnasium.make(MOUNTAIN_CAR, render_mode="rgb_array").unwrapped)


MODELS = """
import json, sys
import numpy as np
import gymnasium
import lwrl.gym
from gymnasium.utils.env_checker import check_env
domain, task = sys.argv[1], sys.argv[2]
envs = [gymnasium.make(f"lwrl/{domain}-{task}-{plant}-v0", render_mode="rgb_array")
        for plant in ("mujoco", "analytic")]
rng = np.random.default_rng(0)
frames, moved = [], []
for env in envs:
    observation, _ = env.reset(seed=4)
    frames.append(env.render())
    for _ in range(5):
        env.step(int(rng.integers(env.action_space.n)))
    moved.append(env.render())
state = envs[0].unwrapped.dm_env.physics.state_vector()
same = [env.reset(options={"state": state})[0] is not None and env.render() for env in envs]
check_env(envs[0].unwrapped)
print(json.dumps({"shape": list(frames[0].shape), "dtype": str(frames[0].dtype),
                  "std": float(frames[0].std()),
                  "plants_agree": bool(np.array_equal(frames[0], frames[1])),
                  "same_state_same_frame": bool(np.array_equal(same[0], same[1])),
                  "moved": bool(not np.array_equal(frames[0], moved[0]))}))
"""


@pytest.mark.parametrize("domain, task", [(d, t) for d, t in tasks.ALL_TASKS if tasks.domain(d).model])
def test_models_are_drawn_from_their_first_camera_on_either_plant(opengl, domain, task):
    """Headless (`MUJOCO_GL=egl`): a picture, the same on both plants for the same state
    (the analytic plant's state drawn by MuJoCo too), a new one once the state moved, and
    Gymnasium's checker passes with rendering."""
    result = subprocess.run([sys.executable, "-c", MODELS, domain, task], capture_output=True,
                            text=True, timeout=300, env={**os.environ, "MUJOCO_GL": opengl})
    assert result.returncode == 0, result.stderr[-3000:]
    seen = json.loads(result.stdout.splitlines()[-1])
    assert seen["shape"] == [240, 320, 3] and seen["dtype"] == "uint8" and seen["std"] > 5
    assert seen["plants_agree"] and seen["same_state_same_frame"] and seen["moved"]


@pytest.mark.skipif(os.environ.get("MUJOCO_GL", "").lower() not in ("disable", "off"),
                    reason="this process may render with OpenGL (MUJOCO_GL is not disable)")
def test_a_model_without_opengl_says_how_to_get_it():
    with pytest.raises(ValueError, match=r"draws pendulum's MuJoCo model with OpenGL, which this "
                                         r"process has not: set MUJOCO_GL=egl"):
        SuiteEnv("pendulum", "swingup", "mujoco", render_mode="rgb_array")


def test_bad_render_modes(monkeypatch):
    with pytest.raises(ValueError, match=r"render_mode must be None, 'human' or 'rgb_array'; "
                                         r"got 'ansi'"):
        SuiteEnv("mountain_car", "cost_to_go", render_mode="ansi")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    if sys.platform.startswith("linux"):
        with pytest.raises(ValueError, match="render_mode='human' needs a display"):
            SuiteEnv("mountain_car", "cost_to_go", render_mode="human")
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setitem(sys.modules, "pygame", None)  # not installed
    with pytest.raises(ValueError, match="shows frames with pygame: pip install pygame"):
        SuiteEnv("mountain_car", "cost_to_go", render_mode="human")


def test_human_rendering_shows_the_episode_in_a_window():
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        pytest.skip("no display (DISPLAY or WAYLAND_DISPLAY) to open a window on")
    pytest.importorskip("pygame", reason="render_mode='human' needs pygame (pip install pygame)")
    env = gymnasium.make(MOUNTAIN_CAR, render_mode="human", time_limit=5)
    env.reset(seed=0)
    for _ in range(5):
        env.step(2)
    assert env.render() is None
    env.close()


def test_record_video_writes_an_episode(tmp_path):
    """Gymnasium's `RecordVideo` over a Mountain-Car episode of 30 steps at the
    environment's one frame per step: 31 frames."""
    pytest.importorskip("moviepy", reason="RecordVideo writes videos with moviepy "
                                          "(pip install -e '.[video]')")
    from moviepy import VideoFileClip

    env = gymnasium.make(MOUNTAIN_CAR, render_mode="rgb_array", time_limit=30)
    env = gymnasium.wrappers.RecordVideo(env, str(tmp_path / "videos"), name_prefix="mountain_car")
    env.reset(seed=0)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(2)
        done = terminated or truncated
    env.close()
    video, = (tmp_path / "videos").glob("mountain_car-episode-0.mp4")
    clip = VideoFileClip(str(video))
    assert clip.fps == 1 and clip.size == [320, 240] and clip.duration == pytest.approx(31, abs=1)
    first = clip.get_frame(0)
    assert first.shape == (240, 320, 3) and first.std() > 5
    clip.close()
