"""Rerun logging (viz): episodes of real rollouts saved to .rrd, read back and checked;
the kinematics against MuJoCo's; the value images; the sinks; a headless render.

No test opens a viewer window: the render test runs the viewer headless on a software
renderer (Mesa's lavapipe, Debian package mesa-vulkan-drivers) and is skipped, saying so,
only where no Vulkan driver is installed.
"""

import glob
import io
import math
import socket
import time
import warnings

import mujoco
import numpy as np
import psutil
import pytest
import rerun as rr

from lwrl import tasks
from lwrl.cli import main as cli
from lwrl.runners.config import RunConfig
from lwrl.viz.scenes import mountain_car
from lwrl.runners.recording import EpisodeRecording
from lwrl.runners.run import EpisodeResults, make_agents
from lwrl.viz import names, scene, value
from lwrl.viz import rerun as viz

MAX_STEPS = 150
"""Rollouts are cut there (random actions end some tasks' episodes sooner)."""


def rollout(domain, task, plant, seed=0, agent=0, episode=0, steps=None) -> EpisodeRecording:
    """A random-action episode of the suite's dm_env environment, with made-up Q-values, TD
    errors and weights of the task's NRBF."""
    env = tasks.load(domain, task, plant=plant, seed=seed)
    definition = tasks.definition(domain, task)
    rng = np.random.default_rng(seed)
    ts = env.reset()
    states, observations = [env.physics.state_vector()], [np.array(list(ts.observation.values()))]
    actions, rewards, uptime = [], [], []
    for _ in range(steps or MAX_STEPS):
        action = int(rng.integers(definition.num_actions))
        ts = env.step(action)
        actions.append(action)
        rewards.append(ts.reward)
        uptime.append(env.task.uptime)
        states.append(env.physics.state_vector())
        observations.append(np.array(list(ts.observation.values())))
        if ts.last():
            break
    count = len(actions)
    features = agents_of(f"{domain}.{task}").features
    return EpisodeRecording(
        task=f"{domain}.{task}", plant=plant, agent=agent, seed=seed, episode=episode,
        timestep=definition.control_timestep, state_names=definition.state_names,
        controls=definition.controls, states=np.array(states), observations=np.array(observations),
        actions=np.array(actions), rewards=np.array(rewards), td_errors=rng.normal(size=count),
        q_values=rng.normal(size=(count + 1, definition.num_actions)), uptime=np.array(uptime),
        weights=rng.normal(size=(definition.num_actions, features.num_features)))


def agents_of(task: str, **settings):
    """One untrained agent of the task's default learner (its values, value box, points)."""
    return make_agents(RunConfig(task=task, agents=1, **settings))


def read_chunks(path) -> dict:
    """`{entity path: [(chunk, record batch), ...]}` of the .rrd's first recording."""
    chunks = {}
    for chunk in rr.chunk.RrdReader(path).stream():
        chunks.setdefault(chunk.entity_path.lstrip("/"), []).append((chunk, chunk.to_record_batch()))
    return chunks


def temporal(chunks, path, episode=None):
    """The one temporal record batch of `path` (of `episode`, where several episodes share
    the path): each series goes in whole as one chunk."""
    batches = [batch for chunk, batch in chunks[path] if not chunk.is_static
               and (episode is None or set(column(batch, names.EPISODE)) == {episode})]
    assert len(batches) == 1, f"{path}: {len(batches)} temporal chunks"
    return batches[0]


def static(chunks, path):
    batches = [batch for chunk, batch in chunks[path] if chunk.is_static]
    assert batches, f"{path} has no static data"
    return batches[-1]


def column(batch, name) -> list:
    return batch.column(name).to_pylist()


def scalars(batch) -> np.ndarray:
    return np.array(column(batch, "Scalars:scalars"), dtype=np.float64)


def nanos(seconds) -> np.ndarray:
    return np.round(np.asarray(seconds) * 1e9).astype(np.int64)


def durations(batch) -> np.ndarray:
    return batch.column(names.SIM_TIME).cast("int64").to_numpy()


# --- a whole recording, written and read back, over the suite ----------------------------


@pytest.fixture
def saved(task_plant, tmp_path):
    """Two episodes (agents 0 and 1), a value function, learning curves and the blueprint of
    one task and plant, saved to an .rrd and read back."""
    domain, task, plant = task_plant
    name = f"{domain}.{task}"
    episodes = [rollout(domain, task, plant, seed=3, agent=0, episode=0),
                rollout(domain, task, plant, seed=4, agent=1, episode=7)]
    agents = agents_of(name)
    rng = np.random.default_rng(0)
    results = EpisodeResults(
        steps=rng.integers(10, 500, size=(3, 6)).astype(float), returns=-rng.random((3, 6)),
        uptime=rng.random((3, 6)), truncated=np.zeros((3, 6), bool), diverged_episode=np.full(3, -1))
    results.returns[2, 4:] = np.nan  # an agent that stopped
    path = tmp_path / "run.rrd"
    rec = viz.open_recording("lwrl_test", rrd_path=path)
    viz.send_blueprint(rec, name)
    geometry = viz.log_task_scene(rec, name)
    logged = [viz.log_episode(rec, episode, value_ranges=agents.value_box())
              for episode in episodes]
    images = viz.log_value_function(rec, name, agents, episodes[1].weights, episode=7)
    curves = viz.log_learning_curves(rec, results, seeds=[10, 11, 12])
    viz.close_recording(rec)
    return dict(name=name, domain=domain, plant=plant, episodes=episodes, agents=agents,
                results=results, path=path, geometry=geometry, logged=logged, images=images,
                curves=curves, chunks=read_chunks(path))


def test_entity_paths_and_stores(saved):
    """Every entity logged is in the file, with the recording's and the blueprint's stores."""
    chunks = saved["chunks"]
    reader = rr.chunk.RrdReader(saved["path"])
    assert [s.application_id for s in reader.recordings()] == ["lwrl_test"]
    assert [s.application_id for s in reader.blueprints()] == ["lwrl_test"]
    expected = set(saved["geometry"]) | set(saved["curves"]) | {names.SCENE}
    for logged in saved["logged"]:
        expected |= {p for key, p in logged.items() if key != "bodies"} | set(logged["bodies"])
    expected |= {names.MAX_Q, names.GREEDY_ACTION, names.CENTROIDS, names.VALUE_STATE,
                 names.TRAJECTORY}
    assert expected <= set(chunks), sorted(expected - set(chunks))


def test_steps_timelines_and_values_of_an_episode(saved):
    """The second episode's series: T rows of rewards at steps 1..T, T + 1 states at 0..T,
    sim_time = step * timestep, its episode index, and the recording's own numbers."""
    chunks = saved["chunks"]
    episode = saved["episodes"][1]
    paths = saved["logged"][1]
    steps = episode.steps
    assert steps >= 5
    reward = temporal(chunks, paths["reward"])
    assert column(reward, names.STEP) == list(range(1, steps + 1))
    np.testing.assert_array_equal(durations(reward), nanos(np.arange(1, steps + 1) * episode.timestep))
    assert column(reward, names.EPISODE) == [7] * steps
    np.testing.assert_array_equal(scalars(reward)[:, 0], episode.rewards)
    np.testing.assert_array_equal(scalars(temporal(chunks, paths["return"]))[:, 0], np.cumsum(episode.rewards))
    for j, variable in enumerate(episode.state_names):
        batch = temporal(chunks, paths[f"state/{variable}"])
        assert column(batch, names.STEP) == list(range(steps + 1))
        np.testing.assert_array_equal(scalars(batch)[:, 0], episode.states[:, j])
    action = temporal(chunks, paths["action"])
    assert column(action, names.STEP) == list(range(steps))
    np.testing.assert_array_equal(scalars(action)[:, 0], episode.actions)
    np.testing.assert_array_equal(scalars(temporal(chunks, paths["control"]))[:, 0],
                                  np.asarray(episode.controls)[episode.actions])
    np.testing.assert_array_equal(scalars(temporal(chunks, paths["q"])), episode.q_values)
    np.testing.assert_array_equal(scalars(temporal(chunks, paths["td_error"]))[:, 0], episode.td_errors)
    if np.all(np.isnan(episode.uptime)):
        assert "uptime" not in paths
    else:
        np.testing.assert_array_equal(scalars(temporal(chunks, paths["uptime"]))[:, 0], episode.uptime)
    names_batch = static(chunks, paths["q"])
    assert len(column(names_batch, "SeriesLines:names")[0]) == len(episode.controls)


def test_body_poses_follow_the_states(saved):
    """Each moving body's Transform3D per step is MuJoCo's kinematics of the recorded state
    (qpos = the state's even entries), for both plants; the car rides on sin(3x)."""
    chunks = saved["chunks"]
    episode = saved["episodes"][0]
    if saved["domain"] == "mountain_car":
        batch = temporal(chunks, names.body_path("car"), episode=0)
        translation = np.array(column(batch, "Transform3D:translation"))[:, 0]
        np.testing.assert_allclose(translation[:, 0], episode.states[:, 0], rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(translation[:, 2], np.sin(3 * episode.states[:, 0]), atol=1e-6)
        return
    model = scene.load_model(saved["domain"])
    xpos, xquat = scene.body_poses_mujoco(model, episode.states[:, 0::2])
    bodies = scene.moving_bodies(model)
    assert saved["logged"][0]["bodies"] == [names.body_path(scene.body_name(model, b)) for b in bodies]
    for body in bodies:
        batch = temporal(chunks, names.body_path(scene.body_name(model, body)), episode=0)
        assert column(batch, names.STEP) == list(range(episode.steps + 1))
        translation = np.array(column(batch, "Transform3D:translation"))[:, 0]
        quaternion = np.array(column(batch, "Transform3D:quaternion"))[:, 0]
        np.testing.assert_allclose(translation, xpos[:, body], atol=1e-6)
        np.testing.assert_allclose(quaternion, xquat[:, body][:, [1, 2, 3, 0]], atol=1e-6)
    if saved["domain"] == "cartpole":  # the cart slides by x, the pole turns by theta
        cart = np.array(column(temporal(chunks, "scene/cart", 0), "Transform3D:translation"))[:, 0]
        np.testing.assert_allclose(cart[:, 0], episode.states[:, 0], atol=1e-6)
        pole = np.array(column(temporal(chunks, "scene/pole", 0), "Transform3D:quaternion"))[:, 0]
        np.testing.assert_allclose(2 * np.arctan2(pole[:, 1], pole[:, 3]), episode.states[:, 2], atol=1e-5)


def test_static_scene_geometry(saved):
    """The geoms are static, in their bodies' frames, with the model's sizes and colours."""
    chunks = saved["chunks"]
    assert static(chunks, names.SCENE).column("ViewCoordinates:xyz") is not None
    for path in saved["geometry"]:
        assert all(chunk.is_static for chunk, _ in chunks[path]), path
    if saved["domain"] == "mountain_car":
        hill = np.array(column(static(chunks, f"{names.WORLD}/hill"), "LineStrips3D:strips")[0][0])
        np.testing.assert_allclose(hill[:, 2], np.sin(3 * hill[:, 0]), atol=1e-6)
        assert hill[0, 0] == pytest.approx(-1.2) and hill[-1, 0] == pytest.approx(0.5)
        return
    model = scene.load_model(saved["domain"])
    expected = {f"scene/{scene.body_name(model, model.geom_bodyid[g])}/{scene.geom_name(model, g)}"
                for g in range(model.ngeom)}
    assert expected <= set(saved["geometry"])
    if saved["domain"] == "cartpole":
        cart = static(chunks, "scene/cart/cart")
        np.testing.assert_allclose(column(cart, "Boxes3D:half_sizes")[0][0], [0.25, 0.12, 0.08], rtol=1e-6)
        rgba = column(cart, "Boxes3D:colors")[0][0]
        assert rgba == int.from_bytes(bytes([76, 128, 204, 255]), "big")  # rgba 0.3 0.5 0.8 1, rounded
        assert "scene/world/floor/grid" in chunks
    elif saved["domain"] == "acrobot":  # two capsules of l1 = l2 = 1 m, the tip at the end
        for link in ("upper_link", "lower_link"):
            capsule = static(chunks, f"scene/{link}/{link}")
            assert column(capsule, "Capsules3D:lengths")[0] == [pytest.approx(1.0)]
            assert column(capsule, "Capsules3D:radii")[0] == [pytest.approx(0.04)]
        tip = static(chunks, "scene/lower_link/tip")
        np.testing.assert_allclose(column(tip, "Ellipsoids3D:centers")[0][0], [0, 0, -1], atol=1e-7)
    elif saved["domain"] == "pendulum":
        rod = static(chunks, "scene/pendulum/rod")
        assert column(rod, "Capsules3D:lengths")[0] == [pytest.approx(1.0)]
        assert column(rod, "Capsules3D:radii")[0] == [pytest.approx(0.02)]
        bob = static(chunks, "scene/pendulum/bob")
        np.testing.assert_allclose(column(bob, "Ellipsoids3D:centers")[0][0], [0, 0, 1], atol=1e-7)


def test_value_images_and_learning_curves(saved):
    """The value images are size x size at the episode (and step 0), the centroids over
    them; the learning curves hold each agent's numbers and their mean, NaN left out."""
    chunks = saved["chunks"]
    image = temporal(chunks, names.MAX_Q)
    assert column(image, names.EPISODE) == [7] and column(image, names.STEP) == [0]
    fmt = column(image, "Image:format")[0][0]
    assert (fmt["width"], fmt["height"]) == (value.GRID, value.GRID)
    assert len(column(image, "Image:buffer")[0][0]) == value.GRID * value.GRID * 3
    assert column(image, "max_q_min")[0][0] == pytest.approx(saved["images"]["max_q"].min())
    greedy = np.array(column(temporal(chunks, names.GREEDY_ACTION), "SegmentationImage:buffer")[0][0])
    np.testing.assert_array_equal(greedy, saved["images"]["greedy"].ravel())
    centroids = np.array(column(static(chunks, names.CENTROIDS), "Points2D:positions")[0])
    assert len(centroids) == RunConfig(task=saved["name"]).settings.n ** 2
    assert np.all((centroids > 0) & (centroids < value.GRID))
    state = temporal(chunks, names.VALUE_STATE, episode=7)
    assert column(state, names.STEP) == list(range(saved["episodes"][1].steps + 1))
    results = saved["results"]
    returns = temporal(chunks, "curves/returns/agent2")
    assert column(returns, names.EPISODE) == [0, 1, 2, 3]
    np.testing.assert_array_equal(scalars(returns)[:, 0], results.returns[2, :4])
    mean = temporal(chunks, "curves/returns/mean")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        np.testing.assert_allclose(scalars(mean)[:, 0], np.nanmean(results.returns, axis=0))
    steps = temporal(chunks, "curves/steps/agent0")
    np.testing.assert_array_equal(scalars(steps)[:, 0], results.steps[0])
    assert column(static(chunks, "curves/steps/agent1"), "SeriesLines:names")[0] == ["agent 1 (seed 11)"]


def test_episodes_recorded_by_training(tmp_path):
    """Episodes recorded by `lwrl.runners.run.run` (MuJoCo pendulum, batched path) log as they
    are: their states, rewards and final weights' value function read back."""
    from lwrl.runners.run import run

    config = RunConfig(task="pendulum.swingup", plant="mujoco", agents=2, episodes=2, seed=5)
    agent, results = run(config, record=[(0, 1), (1, 0)])
    assert [(r.agent, r.episode) for r in results.recordings] == [(0, 1), (1, 0)]
    path = tmp_path / "trained.rrd"
    rec = viz.open_recording("lwrl_test", rrd_path=path)
    viz.send_blueprint(rec, config.task)
    viz.log_task_scene(rec, config.task)
    model = viz.load_model(config.task)
    logged = [viz.log_episode(rec, r, model=model, value_ranges=agent.value_box())
              for r in results.recordings]
    images = viz.log_value_function(rec, config.task, agent, results.recordings[0].weights,
                                    episode=1)
    viz.log_learning_curves(rec, results, config.seeds)
    viz.close_recording(rec)
    chunks = read_chunks(path)
    for recording, paths in zip(results.recordings, logged):
        reward = temporal(chunks, paths["reward"])
        assert column(reward, names.STEP)[-1] == recording.steps
        np.testing.assert_array_equal(scalars(reward)[:, 0], recording.rewards)
        np.testing.assert_array_equal(scalars(temporal(chunks, paths["state/angle"]))[:, 0],
                                      recording.states[:, 0])
        np.testing.assert_array_equal(scalars(temporal(chunks, paths["uptime"]))[:, 0], recording.uptime)
    grid = value.value_grid(config.task, *agent.value_box())
    expected_q = agent.action_values(grid.states(), agent.arrays.weights[0]).max(axis=-1)
    np.testing.assert_allclose(images["max_q"], expected_q)
    np.testing.assert_array_equal(scalars(temporal(chunks, "curves/steps/agent1"))[:, 0], results.steps[1])


# --- the pieces -------------------------------------------------------------------------

CHAIN = """
<mujoco>
  <worldbody>
    <body name="a" pos="0.3 -0.2 1" quat="0.9 0.1 0.3 0.2">
      <joint name="s" type="slide" axis="0.6 0 0.8"/>
      <joint name="h" type="hinge" axis="0 1 0" pos="0.1 0.2 -0.3" ref="0.4"/>
      <geom type="box" size="0.1 0.2 0.3"/>
      <body name="b" pos="0 0 0.5" euler="0.2 0.1 0">
        <joint name="h2" type="hinge" axis="1 1 0" pos="0 0.05 0"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0.3" size="0.05"/>
        <body name="fixed_child" pos="0.1 0 0.2"><geom type="sphere" size="0.02"/></body>
      </body>
    </body>
    <body name="static_body" pos="1 2 3" euler="0.3 0 0"><geom type="cylinder" size="0.1 0.2"/></body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("model_name", ["pendulum", "cartpole", "chain"])
def test_vectorised_kinematics_is_mujocos(model_name):
    """`body_poses` (all states at once) equals `mj_kinematics` state by state, on the suite's
    models and on a chain with joint offsets, rotated bodies, a ref angle and fixed bodies."""
    model = (mujoco.MjModel.from_xml_string(CHAIN) if model_name == "chain"
             else scene.load_model(model_name))
    qpos = np.random.default_rng(1).normal(scale=2.0, size=(50, model.nq))
    xpos, xquat = scene.body_poses(model, qpos)
    ref_pos, ref_quat = scene.body_poses_mujoco(model, qpos)
    np.testing.assert_allclose(xpos, ref_pos, atol=1e-12)
    np.testing.assert_allclose(xquat, ref_quat, atol=1e-12)


def test_geoms_in_rerun_match_mujoco():
    """A capsule's Rerun start point and length reproduce MuJoCo's end points; a sphere and
    a box keep their centres and sizes."""
    model = mujoco.MjModel.from_xml_string(CHAIN)
    capsule = next(g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE)
    (_, arch), = scene.geom_archetypes(model, capsule)
    start = np.array(arch.translations.as_arrow_array().to_pylist()[0])
    length = arch.lengths.as_arrow_array().to_pylist()[0]
    quat = model.geom_quat[capsule]
    end = start + scene.quat_rotate(quat, [0, 0, length])
    np.testing.assert_allclose(sorted([start.tolist(), end.tolist()]),
                               sorted([[0, 0, 0], [0.4, 0, 0.3]]), atol=1e-6)
    for g in range(model.ngeom):
        assert scene.geom_archetypes(model, g), f"geom {g} not drawn"


def test_mountain_car_car_follows_the_slope():
    """The car sits at (x, 0, sin 3x) with its x axis along the hill's tangent."""
    x = np.linspace(-1.2, 0.5, 7)
    translation, quaternion = mountain_car.car_poses(np.stack([x, np.zeros_like(x)], axis=1))["car"]
    np.testing.assert_allclose(translation[:, 2], np.sin(3 * x))
    forward = scene.quat_rotate(quaternion[:, [3, 0, 1, 2]], [1.0, 0.0, 0.0])
    tangent = np.stack([np.ones_like(x), np.zeros_like(x), 3 * np.cos(3 * x)], axis=1)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    np.testing.assert_allclose(forward, tangent, atol=1e-12)


@pytest.mark.parametrize("task", tasks.TASK_NAMES)
def test_value_grid_q_and_pixels(task):
    """Q over the grid is phi(s) . w at each cell's state; a state maps to the pixel whose
    cell holds it; all-zero weights make every action tie (class 0)."""
    agents = agents_of(task)
    features = agents.features
    grid = value.value_grid(task, *agents.value_box(), size=20)
    weights = np.random.default_rng(2).normal(size=(3, features.num_features))
    q = value.values_on_grid(grid, agents, weights)[1]
    states = grid.states()
    for (i, j) in [(0, 0), (19, 0), (7, 13), (19, 19)]:
        np.testing.assert_allclose(q[i, j], weights @ features.features(states[i, j]))
        u, v = grid.to_pixels(states[i, j][None])[0]
        assert (int(u), int(v)) == (j, i)
    u_axis, v_axis = value.value_axes(task)
    assert states[0, 0, v_axis] > states[-1, 0, v_axis]  # velocity up
    assert states[0, 0, u_axis] < states[0, -1, u_axis]
    assert np.all(value.greedy_classes(np.zeros((4, 4, 3))) == 0)
    np.testing.assert_array_equal(value.greedy_classes(np.array([[1.0, 3.0, 2.0]])), [2])


@pytest.mark.parametrize("task", tasks.TASK_NAMES)
@pytest.mark.parametrize("kind", ["nrbf", "cmac"])
def test_q_on_grid_equals_the_feature_maps(task, kind):
    """The NRBF's factorised evaluation (and the CMAC's state-by-state one) give the feature
    map's own phi(s) . w over the grid, in and far beyond the ranges; the state values are
    their maximum."""
    agents = agents_of(task, features=kind)
    features = agents.features
    weights = np.random.default_rng(3).normal(size=(2, features.num_features))
    low, high = map(np.array, tasks.definition(*tasks.split_name(task)).ranges)
    for scale in (1, 40):
        grid = value.value_grid(task, low * scale, high * scale, size=17)
        expected = features.features(grid.states().reshape(-1, features.dim)) @ weights.T
        values, q = value.values_on_grid(grid, agents, weights)
        np.testing.assert_allclose(q.reshape(-1, 2), expected, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(values, q.max(axis=-1))
    assert (value.plane_points(agents.feature_points(), grid) is None) == (kind == "cmac")


def test_task_names_resolve_through_the_suite():
    assert names.task_definition("cartpole").name == "cartpole.balance"
    assert names.task_definition("pendulum.swingup").controls == (-5.0, 5.0)
    with pytest.raises(ValueError, match="unknown task 'cartpole.swingup'; available: mountain_car"):
        names.task_definition("cartpole.swingup")


def test_an_episode_without_value_ranges_has_no_value_path(tmp_path):
    path = tmp_path / "plain.rrd"
    rec = viz.open_recording("lwrl_test", rrd_path=path)
    viz.log_episode(rec, rollout("pendulum", "swingup", "analytic", steps=5))
    viz.close_recording(rec)
    chunks = read_chunks(path)
    assert names.VALUE_STATE not in chunks and names.TRAJECTORY not in chunks
    assert any(entity.startswith(names.STATE) for entity in chunks)


def test_cartpole_slice_goes_through_the_centre():
    """The cart-pole images slice (theta, theta_dot) at x = x_dot = 0."""
    states = value.value_grid("cartpole.balance", *agents_of("cartpole.balance").value_box(),
                              size=8).states()
    assert np.all(states[..., :2] == 0)
    assert states[..., 2].min() > -math.radians(12) and states[..., 2].max() < math.radians(12)


# --- sinks, viewers and servers ---------------------------------------------------------


@pytest.fixture
def no_display(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")


def test_open_recording_needs_a_sink_and_a_display(no_display, tmp_path):
    """No sink: ValueError. spawn=True without a display: ViewerUnavailable alone, a warning
    and the file only when there is also an .rrd."""
    with pytest.raises(ValueError, match="needs a sink"):
        viz.open_recording("lwrl_test")
    with pytest.raises(viz.ViewerUnavailable, match="no display"):
        viz.open_recording("lwrl_test", spawn=True)
    with pytest.warns(RuntimeWarning, match="no Rerun viewer"):
        rec = viz.open_recording("lwrl_test", rrd_path=tmp_path / "a.rrd", spawn=True)
    viz.log_task_scene(rec, "pendulum")
    viz.close_recording(rec)
    assert "scene/pendulum/rod" in read_chunks(tmp_path / "a.rrd")


def test_view_binds_localhost(no_display, tmp_path):
    """`view` runs the viewer bound to 127.0.0.1; without a display only the web viewer."""
    command = viz.view_command("x.rrd", web=True, web_port=9191)
    assert command[1:] == ["x.rrd", "--bind", "127.0.0.1", "--web-viewer", "--web-viewer-port", "9191"]
    assert viz.view_command("x.rrd", web=True, web_port=9191, grpc_port=9292)[4:6] == ["--port", "9292"]
    assert viz.web_viewer_url(9191, 9292) == \
        "http://127.0.0.1:9191/?url=rerun%2Bhttp%3A%2F%2F127.0.0.1%3A9292%2Fproxy"
    with pytest.raises(FileNotFoundError):
        viz.view(tmp_path / "missing.rrd")
    (tmp_path / "a.rrd").write_bytes(viz.RRD_MAGIC)
    with pytest.raises(viz.ViewerUnavailable, match="no display"):
        viz.view(tmp_path / "a.rrd")


def test_grpc_server_listens_on_localhost_only():
    """A served recording listens on 127.0.0.1, not on every interface."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    rec = viz.open_recording("lwrl_test", serve_port=port)
    try:
        listening = [c.laddr for c in psutil.Process().net_connections(kind="tcp")
                     if c.status == psutil.CONN_LISTEN and c.laddr.port == port]
        assert listening and all(address.ip == "127.0.0.1" for address in listening)
    finally:
        viz.close_recording(rec)


def test_learning_curves_first_skips_episodes(tmp_path):
    """`first` sends only the episodes from there on (a growing run, piece by piece)."""
    results = EpisodeResults.empty(2, 5)
    results.steps[:] = np.arange(10).reshape(2, 5)
    rec = viz.open_recording("lwrl_test", rrd_path=tmp_path / "c.rrd")
    viz.log_learning_curves(rec, results, first=3)
    viz.close_recording(rec)
    chunks = read_chunks(tmp_path / "c.rrd")
    assert column(temporal(chunks, "curves/steps/agent1"), names.EPISODE) == [3, 4]
    assert "curves/returns/agent0" not in chunks  # all NaN


def test_recording_shapes_are_checked():
    recording = rollout("pendulum", "swingup", "analytic", steps=5)
    recording.rewards = recording.rewards[:-1]
    with pytest.raises(ValueError, match="rewards"):
        viz.log_episode(None, recording)


# --- a headless render --------------------------------------------------------------------

VULKAN_DRIVERS = "/usr/share/vulkan/icd.d/*.json"


def test_headless_render_is_not_blank(tmp_path, capsys):
    """`lwrl view FILE.rrd --screenshot PNG` (`rerun - --headless --screenshot-to PNG <
    FILE.rrd`) renders the layout: the PNG has the window's size and varied pixels, and the
    3-D scene's corner of it is not flat."""
    if not glob.glob(VULKAN_DRIVERS):
        pytest.skip("no Vulkan driver for the headless viewer: "
                    "apt-get install mesa-vulkan-drivers (Mesa's lavapipe software renderer)")
    from PIL import Image

    path = tmp_path / "pendulum.rrd"
    rec = viz.open_recording("lwrl_test", rrd_path=path)
    viz.send_blueprint(rec, "pendulum.swingup")
    viz.log_task_scene(rec, "pendulum.swingup")
    recording = rollout("pendulum", "swingup", "mujoco", steps=60)
    agents = agents_of("pendulum.swingup")
    viz.log_episode(rec, recording, value_ranges=agents.value_box())
    viz.log_value_function(rec, "pendulum.swingup", agents, recording.weights, episode=0)
    viz.close_recording(rec)
    png = tmp_path / "shot.png"
    assert cli.main(["view", str(path), "--screenshot", str(png), "--window-size", "960x600"]) == 0
    assert f"wrote {png}: the first screen of {path} in a 960x600 window" in capsys.readouterr().out
    pixels = np.asarray(Image.open(png).convert("RGB"), dtype=np.float64)
    assert pixels.shape[1] >= 960 and pixels.shape[0] >= 600
    assert pixels.std() > 10
    height, width = pixels.shape[:2]
    scene_part = pixels[int(0.1 * height):int(0.4 * height), int(0.15 * width):int(0.4 * width)]
    assert scene_part.std() > 5
    assert len(np.unique(scene_part.reshape(-1, 3), axis=0)) > 20


# --- the first screen of a recording, opened as a user opens it ---------------------------


def view_pixels(viewer, view_id) -> np.ndarray:
    """One view of the viewer's screen, as an RGB array."""
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(viewer.take_screenshot(view_id))).convert("RGB"))


def saturated(pixels) -> int:
    """Pixels of a colour (a plotted series, an image), not of the viewer's greys."""
    pixels = pixels.astype(int)
    return int(((pixels.max(axis=-1) - pixels.min(axis=-1)) > 80).sum())


def near(pixels, colors, tolerance: float = 40.0) -> float:
    """The share of pixels within `tolerance` of one of `colors`."""
    distance = np.linalg.norm(pixels[:, :, None, :].astype(float) - np.asarray(colors, float), axis=-1)
    return float((distance.min(axis=-1) < tolerance).mean())


def cursor_positions(viewer, seconds: float) -> set:
    """Where the time cursor of the viewer's recording sits, sampled for `seconds` (it must
    be on the `step` timeline)."""
    found, stop = set(), time.monotonic() + seconds
    while time.monotonic() < stop:
        recording = viewer.get_state().recordings[0]
        assert recording.current_timeline == names.STEP, recording.current_timeline
        found.add(recording.current_time)
        time.sleep(0.1)
    return found


def test_a_recording_opens_on_its_last_logged_episode(tmp_path):
    """A recording of `lwrl train --rrd`, opened by its path as a user opens it, with no
    click: the time cursor plays within the last logged episode on the `step` timeline (here
    a Mountain-Car run whose first logged episode is ten times longer, which the viewer
    would otherwise play through); the max_a Q panel shows an image, the greedy-action panel
    the actions' colours, and every state variable's plot a line."""
    if not glob.glob(VULKAN_DRIVERS):
        pytest.skip("no Vulkan driver for the headless viewer: "
                    "apt-get install mesa-vulkan-drivers (Mesa's lavapipe software renderer)")
    from lwrl.cli.rerun_options import send_run
    from lwrl.runners.run import run

    config = RunConfig(task="mountain_car.cost_to_go", agents=1, episodes=12, seed=0)
    agent, results = run(config, record=[(0, 0), (0, 11)])
    first, last = results.recordings
    assert first.steps > 5 * last.steps
    path = tmp_path / "mountain_car.rrd"
    send_run(config, results, agent, rrd_path=path)
    definition = names.task_definition(config.task)
    with viz.headless_viewer() as viewer:
        viewer.open(str(path))
        state = viewer.get_state()
        views = {view.name: view.view_id for view in state.views}
        wanted = ["max_a Q", "greedy action", *definition.state_names]
        assert set(wanted) <= set(views), sorted(views)
        deadline, shots, cursor = time.monotonic() + 90, {}, set()
        while True:  # the viewer loads the file's chunks lazily, after `open` returns
            cursor |= cursor_positions(viewer, seconds=0.5)
            shots = {name: view_pixels(viewer, views[name]) for name in wanted}
            empty = [name for name in definition.state_names if saturated(shots[name]) < 50]
            if len(np.unique(shots["max_a Q"].reshape(-1, 3), axis=0)) < 200:
                empty.append("max_a Q")
            if near(shots["greedy action"], value.action_colors(definition.controls)) < 0.3:
                empty.append("greedy action")
            if not empty or time.monotonic() > deadline:
                break
            time.sleep(0.5)
        cursor |= cursor_positions(viewer, seconds=3.0)  # it loops: never past the episode
    from PIL import Image

    for name, pixels in shots.items():
        Image.fromarray(pixels).save(tmp_path / f"{name.replace(' ', '_')}.png")
    assert not empty, f"empty after 90 s: {empty} (the views' pictures are in {tmp_path})"
    assert len(cursor) > 1 and 0 <= min(cursor) and max(cursor) <= last.steps, sorted(cursor)
