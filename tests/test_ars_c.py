"""ARS that learns in C (lwrl.export.learner, the form of agent/ars_c.py) takes the steps of
ARS's equations (agent/random_search.py, agent/running_stats.py: the JAX learner's own
functions) on the directions it draws from lwrl's stream.

The C learner, compiled in double and driven through ctypes on the analytic plant (episodes
of at most 2 s, some cut by the time limit), and the equations, driven on the same episodes
by the same calls (`Equations`: the directions drawn
from `agent.streams.gaussian` in the C learner's order), must take the same action at every
step and end every iteration with the same policy and V2 scale (to 1e-12: the sums may be
added in another order). The float build learns: its cart-pole agents' episodes grow
longer; it learns on the emulated Cortex-M4 as on the host. Its RAM is its object file's,
and continuous actions are refused in one line.
"""

import subprocess

import numpy as np
import pytest

pytest.importorskip("jax", reason="ARS is a JAX population: pip install 'lwrl[jax]'")

from test_learner_c import (COMPILER, STRICT, CLearner, episode_lengths,  # noqa: E402
                            learns_on_the_emulated_m4, needs_compiler, needs_emulated_m4)

from lwrl.agent import random_search, running_stats, streams  # noqa: E402
from lwrl.export import learner  # noqa: E402
from lwrl.export.c import section_sizes  # noqa: E402
from lwrl.tasks.batched import BatchedEnv  # noqa: E402


class Equations:
    """ARS's iterations as the JAX learner's functions compute them, called as the C
    learner is (`lwrl_begin`, `lwrl_learn`), drawing its directions from the C learner's
    stream in its order."""

    def __init__(self, form_values: dict, dim: int, actions: int):
        weights = form_values["weights"][0]
        self.mean, self.std = weights[:dim], weights[dim:2 * dim]
        self.theta = weights[2 * dim:].reshape(actions, dim)
        self.stats = {"count": np.float64(form_values["count"]),
                      "mean": np.array(form_values["states_mean"]),
                      "p": np.array(form_values["states_p"])}
        self.stream = np.array([form_values["seed"]], dtype=np.uint64)
        self.v2 = bool(form_values["v2"])
        self.n, self.top = form_values["directions"], form_values["top"]
        self.alpha, self.nu = form_values["alpha"], form_values["nu"]
        self.returns = np.zeros(2 * self.n)
        self.rollout, self.under_way, self.total = 0, False, 0.0
        self.iterations = 0
        self.draw()

    def draw(self):
        with np.errstate(over="ignore"):  # SplitMix64 wraps around, as in C
            self.deltas = np.array([[streams.gaussian(self.stream, 0)
                                     for _ in range(self.theta.size)]
                                    for _ in range(self.n)]).reshape(self.n, *self.theta.shape)

    def act(self, observation) -> int:
        """The rollout's action, `random_search`'s; the state enters the statistics."""
        x = (np.asarray(random_search.v2_state(observation, self.mean, self.std)) if self.v2
             else observation)
        self.stats = {name: np.asarray(value) for name, value in
                      running_stats.stats_add(self.stats, observation).items()}
        k = self.rollout
        theta = random_search.perturbed(self.theta, self.deltas[k // 2], self.nu,
                                        1.0 if k % 2 == 0 else -1.0)
        return int(random_search.discrete_action(theta, x))

    def end(self):
        self.under_way = False
        self.returns[self.rollout] = self.total
        self.rollout += 1
        if self.rollout == 2 * self.n:
            self.theta = np.asarray(random_search.ars_step(
                self.theta, self.deltas, self.returns[0::2], self.returns[1::2], self.alpha,
                self.top))
            if self.v2:
                self.mean, self.std = (np.asarray(v) for v in random_search.v2_scale(self.stats))
            self.rollout, self.iterations = 0, self.iterations + 1
            self.draw()

    def step(self, first, reward, discount, observation) -> int:
        if first:
            if self.under_way:
                self.end()
            self.under_way, self.total = True, 0.0
            return self.act(observation)
        self.total += reward
        if discount == 0.0:
            self.end()
            return 0
        return self.act(observation)

    @property
    def weights(self) -> np.ndarray:
        return np.concatenate([self.mean, self.std, self.theta.ravel()])


def c_learner(tmp_path, task, seed, dtype="double", **settings):
    source = learner.from_task(task, seed=seed, learner="ars", **settings)
    return source, CLearner(source, dtype, tmp_path)


@needs_compiler
@pytest.mark.parametrize("task, seed, settings, iterations", [
    ("cartpole.balance", 3, {"directions": 3, "top": 2}, 5),
    ("cartpole.balance", 5, {"directions": 2, "variant": "v1", "learning_rate": 0.5}, 5),
    ("acrobot.swingup", 1, {"directions": 2, "delta_std": 0.3}, 2),
], ids=["cartpole_v2_top", "cartpole_v1", "acrobot_v2"])
def test_the_c_learner_takes_the_equations_steps(tmp_path, task, seed, settings, iterations):
    source, c = c_learner(tmp_path, task, seed, **settings)
    equations = Equations(source.form.values(np.float64), source.agents.dim,
                          source.agents.action_space.n)
    np.testing.assert_array_equal(c.weights, equations.weights)
    domain, name = task.split(".")
    env = BatchedEnv(domain, name, "analytic", seeds=[seed], time_limit=2.0)
    ts, steps, moved, cut = env.reset(), 0, 0, 0
    while equations.iterations < iterations:
        first, reward, discount, observation = (ts.first()[0], ts.reward[0], ts.discount[0],
                                                ts.observation[0])
        before = equations.iterations
        action = equations.step(first, reward, discount, observation)
        c_action = c.step(first, reward, discount, observation)
        assert c_action == action, f"step {steps}: C {c_action}, the equations {action}"
        if equations.iterations > before:
            np.testing.assert_allclose(c.weights, equations.weights, rtol=1e-12, atol=1e-15,
                                       err_msg=f"after iteration {equations.iterations}")
            moved += not np.array_equal(equations.theta, 0.0)
        cut += bool(ts.last()[0] and discount != 0.0)
        ts = env.step(np.array([action]))
        steps += 1
    assert moved and cut and not c.diverged


@needs_compiler
def test_the_float_learner_learns_to_balance_longer(tmp_path):
    """Four cart-pole agents in float (seeds 0-3), one plant each, episodes of at most 5 s,
    24 iterations of 4 directions: the mean length of their last 16 episodes is at least
    twice that of their first 16."""
    seeds, episodes = [0, 1, 2, 3], 24 * 8
    learners = [c_learner(tmp_path / str(seed), "cartpole.balance", seed, "float",
                          directions=4)[1] for seed in seeds]
    lengths = episode_lengths(learners, "cartpole.balance", seeds, episodes, 5.0)
    first, last = lengths[:, :16].mean(), lengths[:, -16:].mean()
    print(f"\nmean episode length: first 16 {first:.1f}, last 16 {last:.1f}")
    assert last >= 2 * first


@needs_compiler
def test_the_ram_it_declares_is_its_objects_static_data(tmp_path):
    """`ram_bytes` against the object file's .bss and .data, as for the Sarsa learner: equal
    up to the compiler's alignment padding."""
    source = learner.from_task("acrobot.swingup", seed=0, learner="ars", directions=5)
    for dtype in ("float", "double"):
        written = learner.write_learner(source, tmp_path / dtype, dtype)
        obj = tmp_path / dtype / "learner.o"
        subprocess.run([COMPILER, *STRICT, "-O2", "-c", written["source"], "-o", str(obj)],
                       check=True)
        static = sum(v for k, v in section_sizes(obj).items() if k.startswith((".bss", ".data")))
        assert written["ram"]["total"] <= static <= written["ram"]["total"] + 64, (dtype, static)


@needs_emulated_m4
def test_it_learns_on_the_emulated_cortex_m4_as_on_the_host(capsys):
    """`lwrl device run TASK --learner ars`: every episode's steps equal on both builds."""
    out = learns_on_the_emulated_m4(capsys, "mountain_car.cost_to_go", "ars", 8)
    assert "ARS V2-t, linear policy 3 x 2, 8 directions" in out


def test_continuous_actions_have_no_c_learner():
    source = learner.from_task("pendulum.swingup", seed=0, learner="ars_continuous",
                               actions="continuous")
    with pytest.raises(ValueError, match="cannot learn in C: the device's programs exchange an "
                                         "action index") as error:
        source.form
    assert "\n" not in str(error.value)
