"""The suite's tasks as Gymnasium environments (optional: needs `gymnasium>=1.0`).

    import gymnasium
    import lwrl.gym  # registers the ids below
    env = gymnasium.make("lwrl/cartpole-balance-mujoco-v0")
    observation, info = env.reset(seed=0)
    observation, reward, terminated, truncated, info = env.step(1)

or, without the import, `gymnasium.make("lwrl.gym:lwrl/cartpole-balance-mujoco-v0")`
(Gymnasium 1.x imports the module named before the colon; it no longer loads plugins from
entry points). Every `(domain, task, plant)` of the suite's dm_env environments
(`tasks.ENVIRONMENT_PLANTS`) is registered as `lwrl/{domain}-{task}-{plant}-v0`
(`ENV_IDS`); `register_envs()` registers them again if needed and is idempotent.

`SuiteEnv` wraps the suite's dm_env environment (`tasks.load`):

- **Actions**: `Discrete(n)`, the task's action indices (action i applies `controls[i]`).
- **Observations**: a float64 `Box` of shape `(d,)` in the order of the task's state names
  (`observation_names`), within the task's `bounds` (`TaskDefinition.bounds`, stated and
  argued in each domain's module), which hold the terminal observation too.
- **Episode end**: `terminated` on a terminal state (the dm_env step's discount 0); `truncated` on the task's own time limit
  (discount 1). Never both. No `TimeLimit` wrapper is registered: the task truncates, and
  `time_limit=` changes where. Stepping after the end without `reset()` raises.
- **Seeding**: `reset(seed=s)` seeds Gymnasium's `np_random`, and the task draws its starts
  from that very generator (`env.unwrapped.suite_task.random`). Gymnasium's generator for seed s is
  NumPy's `default_rng(s)`, so `reset(seed=s)` followed by seedless resets gives the
  starts of `tasks.load(..., seed=s)` followed by its resets.
- **reset options**: `{"state": [...]}` starts the episode in that state (the task's state
  variables, e.g. the pendulum's angle need not be wrapped); the random start is still
  drawn, so later starts do not depend on it. The state must be non-terminal with its
  observation inside the Box (a state no episode reaches, e.g. a huge speed, can still
  leave the Box on the next step).
- **info**: `uptime_s` (the episode's up-time so far, in seconds; `None` for Mountain-Car,
  which has none: the dm_env's NaN would make `check_env`'s determinism check fail, since
  NaN != NaN), `steps` (steps of the episode) and `plant`.
- **Rendering**: none (`render_mode=None` only): the suite runs without an OpenGL display.
- **make() kwargs**: the task's and plant's options (`time_limit`, `track_limit`,
  `integrator`, `equations`) as in `tasks.load`; unknown ones raise a `ValueError` naming
  the allowed.
  `seed` is not one (use `reset(seed=...)`), and kwargs cannot change the id's domain,
  task or plant.
"""

try:
    import gymnasium
    from gymnasium import spaces
except ImportError as error:  # pragma: no cover - only without gymnasium
    raise ImportError("lwrl.gym needs gymnasium (pip install 'lwrl[gymnasium]'); "
                      "the rest of the suite does not") from error
import numpy as np

from lwrl import tasks
from lwrl.tasks.task_definition import check_finite_state

NAMESPACE = "lwrl"
VERSION = 0
ENTRY_POINT = "lwrl.gym:SuiteEnv"


def env_id(domain: str, task: str, plant: str) -> str:
    """The Gymnasium id of `domain.task` on `plant`, e.g. `lwrl/cartpole-balance-mujoco-v0`."""
    return f"{NAMESPACE}/{domain}-{task}-{plant}-v{VERSION}"


ENVIRONMENTS = {env_id(domain, task, plant): (domain, task, plant)
             for domain, task in tasks.ALL_TASKS for plant in tasks.ENVIRONMENT_PLANTS[domain]}
"""`(domain, task, plant)` of each registered id."""
ENV_IDS = tuple(ENVIRONMENTS)
"""The registered ids, every task on every plant of a dm_env environment."""


def observation_bounds(definition) -> tuple:
    """`(low, high)` float64 arrays that hold every observation of an episode of the task,
    the terminal one included: the task's own `bounds`."""
    low, high = definition.bounds
    return np.array(low, dtype=np.float64), np.array(high, dtype=np.float64)


def _options(domain: str, task: str, plant: str) -> list:
    """The make() kwargs that `domain.task` on `plant` takes (those `tasks.resolve` allows,
    less `plant` and `seed`, which the id and `reset` set)."""
    return tasks.task_options(domain, task) + tasks.plant_option_names(domain, plant)


class SuiteEnv(gymnasium.Env):
    """One task of the suite on one plant, as a Gymnasium environment (see the module).

    `SuiteEnv(domain, task, plant=None, **options)` takes the arguments of `tasks.load`
    except `seed` (seed with `reset(seed=...)`). `dm_env` is the wrapped dm_env environment,
    `definition` the task's `TaskDefinition`, `step_limit` its truncation step (`inf`
    for none).
    """

    metadata = {"render_modes": []}

    def __init__(self, domain: str, task: str, plant=None, render_mode=None, **options):
        if render_mode is not None:
            raise ValueError(f"the lwrl environments do not render; render_mode must be None, "
                             f"got {render_mode!r}")
        _, plant, _ = tasks.resolve(domain, task, plant)  # checks the names
        allowed = _options(domain, task, plant)
        unknown = sorted(set(options) - set(allowed))
        if unknown:
            hint = "; seed the environment with reset(seed=...)" if "seed" in unknown else ""
            raise ValueError(f"unknown option {unknown[0]!r} for {domain}.{task} on the {plant} "
                             f"plant; allowed: {', '.join(allowed) or 'none'}{hint}")
        definition, plant, _ = tasks.resolve(domain, task, plant, **options)  # checks the values
        self.domain, self.task_name, self.plant = domain, task, plant
        self.options = dict(options)
        self.dm_env = tasks.load(domain, task, plant=plant, **options)
        self.definition = definition
        self.step_limit = definition.step_limit
        self.observation_names = tuple(definition.state_names)
        self.render_mode = None
        self.action_space = spaces.Discrete(definition.num_actions)
        low, high = observation_bounds(definition)
        self.observation_space = spaces.Box(low, high, dtype=np.float64)
        self._spec = None
        self._episode_over = True
        self._started = False

    @property
    def spec(self):
        """The `EnvSpec` that `gymnasium.make` sets; an lwrl id must match the env's
        domain, task and plant (make() kwargs cannot change them)."""
        return self._spec

    @spec.setter
    def spec(self, value):
        expected = ENVIRONMENTS.get(getattr(value, "id", None))
        actual = (self.domain, self.task_name, self.plant)
        if expected is not None and expected != actual:
            raise ValueError(
                f"{value.id} is {expected[0]}.{expected[1]} on the {expected[2]} plant; make() "
                f"kwargs asked for {actual[0]}.{actual[1]} on the {actual[2]} plant: use "
                f"{env_id(*actual)} instead")
        self._spec = value

    @property
    def suite_task(self):
        """The dm_control task (`tasks.base.SuiteTask`): `uptime`, `steps`, `random`."""
        return self.dm_env.task

    def _observation(self, observation) -> np.ndarray:
        """A new float64 array `(d,)` from a dm_env observation (an ordered dict)."""
        return np.array([observation[name] for name in self.observation_names], dtype=np.float64)

    def _info(self) -> dict:
        return {"uptime_s": self.suite_task.uptime if self.definition.has_uptime else None,
                "steps": self.suite_task.steps, "plant": self.plant}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self._episode_over = True  # until this reset succeeds
        options = {} if options is None else dict(options)
        unknown = sorted(set(options) - {"state"})
        if unknown:
            raise ValueError(f"unknown reset option {unknown[0]!r}; allowed: state")
        self.suite_task.random = self.np_random
        observation = self._observation(self.dm_env.reset().observation)
        if "state" in options:
            observation = self._start_in(options["state"])
        self._episode_over = False
        self._started = True
        return observation, self._info()

    def _start_in(self, state) -> np.ndarray:
        """Put the plant in `state` after the reset; return its observation."""
        state = check_finite_state(state, self.definition.state_names)
        if state.ndim != 1:
            raise ValueError(f"reset state must have shape ({len(self.observation_names)},); "
                             f"got shape {state.shape}")
        if self.definition.terminal(state[None])[0]:
            raise ValueError(f"reset state {state.tolist()} is terminal for {self.definition.name}")
        observation = self.definition.observe(state[None])[0]
        if observation not in self.observation_space:
            raise ValueError(f"reset state {state.tolist()} observes as {observation.tolist()}, "
                             f"outside the observation space {self.observation_space}")
        physics = self.dm_env.physics
        with physics.reset_context():
            physics.set_state_vector(state)
        return self._observation(self.suite_task.get_observation(physics))

    def step(self, action):
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if self._episode_over:
            raise RuntimeError("the episode has ended (terminated or truncated); call reset()")
        if not self.action_space.contains(action):
            raise ValueError(f"action must be an integer in 0..{self.action_space.n - 1}; "
                             f"got {action!r}")
        time_step = self.dm_env.step(int(action))
        terminated = bool(time_step.last() and time_step.discount == 0.0)
        truncated = bool(time_step.last() and not terminated)
        self._episode_over = terminated or truncated
        return (self._observation(time_step.observation), float(time_step.reward), terminated,
                truncated, self._info())

    def render(self):
        return None

    def close(self):
        self.dm_env.close()


def register_envs() -> tuple:
    """Register every id of `ENV_IDS` with Gymnasium (those not registered yet); return
    `ENV_IDS`. Calling it again does nothing."""
    for id_, (domain, task, plant) in ENVIRONMENTS.items():
        if id_ not in gymnasium.envs.registry:
            gymnasium.register(id=id_, entry_point=ENTRY_POINT,
                               kwargs={"domain": domain, "task": task, "plant": plant})
    return ENV_IDS


register_envs()
