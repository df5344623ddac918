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
(`ENV_IDS`), and beside it with continuous actions as
`lwrl/{domain}-{task}-{plant}-continuous-v0` (`CONTINUOUS_ENV_IDS`); each task on its
domain's default plant also as `lwrl/{domain}-{task}-v0` and `lwrl/{domain}-{task}-continuous-v0`
(`DEFAULT_ENV_IDS`, e.g. `gymnasium.make("lwrl/pendulum-swingup-v0")`); `register_envs()`
registers them again if needed and is idempotent.

`SuiteEnv` wraps the suite's dm_env environment (`tasks.load`):

- **Actions**: `Discrete(n)`, the task's action indices (action i applies `controls[i]`);
  with continuous actions (the `-continuous` ids, `actions="continuous"`) a float64
  `Box(low, high, (1,))`, the actuator's range (`TaskDefinition.control_range`: the
  pendulum's torque in [-5, 5] N m, the cart-pole's force in [-10, 10] N, Mountain-Car's
  thrust in [-1, 1], the acrobot's elbow torque in [-1, 1] N m, at the paper's values),
  whose action is the control itself. Shape (1,), as dm_control's and Gymnasium's own
  one-actuator tasks (Pendulum-v1) have it; float64, the plants' type, so that an action
  reaches the plant unrounded, as the dm_env environment's does (the Box takes float32
  arrays too). An action outside the range is clipped to it, as an actuator saturates
  (Pendulum-v1 clips too); NaN or an infinity raises a `ValueError`. For a learner that
  expects actions in [-1, 1] (Stable-Baselines3's advice, which `check_env` warns of), wrap
  the environment in Gymnasium's own `gymnasium.wrappers.RescaleAction(env, -1.0, 1.0)`:
  it maps [-1, 1] affinely onto the actuator's range.
- **Observations**: a float64 `Box` of shape `(d,)` in the order of the task's state names
  (`observation_names`), within the task's `bounds` (`TaskDefinition.bounds`, stated and
  argued in each domain's module), which hold the terminal observation too.
- **Episode end**: `terminated` on a terminal state (the dm_env step's discount 0);
  `truncated` on the task's own time limit (discount 1), never both. Every id has the
  task's limit at its default options as its `max_episode_steps` (`max_episode_steps()`;
  `env.spec.max_episode_steps`, as Gymnasium's own ids have it), so `gymnasium.make` wraps
  the environment in Gymnasium's `TimeLimit` at the step the task truncates at by itself.
  Where a terminal state falls on that very step, `TimeLimit` marks it `truncated` too (its
  rule, as on CartPole-v1): read `terminated` first, as Stable-Baselines3 does. The earlier
  of the two limits ends an episode: to lengthen one, give both, e.g.
  `gymnasium.make(id, time_limit=120.0, max_episode_steps=6000)` on the pendulum, or
  `max_episode_steps=None` with the task's `time_limit=` alone; `SuiteEnv` made directly has
  the task's limit only. The vector environment (`gymnasium.make_vec`) truncates at the
  earlier of the two itself, never both. Stepping after the end without `reset()` raises.
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
- **Rendering** (`viz.drawing.Painter`): `render_mode="rgb_array"` makes `render()` return
  the state as a `(240, 320, 3)` uint8 frame: MuJoCo's picture from the model's first
  camera for the domains with an MJCF model, on either plant (OpenGL: a display, or
  `MUJOCO_GL=egl` set before importing lwrl, headless), and for Mountain-Car the hill and
  the car that the Rerun viewer draws (the domain's `Drawing`), painted without OpenGL.
  `render_mode="human"` shows each state in a window as it is reached (pygame, where a
  display exists). `metadata["render_modes"]` of an environment lists the modes this
  process can draw it in (what Gymnasium's `check_env` tries). `metadata["render_fps"]` is one frame per control step: 50 for the
  pendulum and the cart-pole, 5 for the acrobot, and 1 for Mountain-Car, whose step is its
  unit of time (`RecordVideo(env, folder, fps=30)` plays it faster).
- **Vector environments**: `gymnasium.make_vec(id, num_envs=B)` gives `SuiteVectorEnv`
  (each id's `vector_entry_point`), B copies stepped together as arrays by
  `tasks.batched.BatchedEnv`, with Gymnasium's default autoreset (`AutoresetMode.NEXT_STEP`:
  the step after an episode's end resets that copy, ignores its action and returns its
  first observation with reward 0), `reset(seed=s)` seeding copy i with s + i as Gymnasium's
  `SyncVectorEnv` does, and the infos of `SyncVectorEnv` over `SuiteEnv` (its transitions
  are the single environments', to the bit: tested). It does not render.
- **make() kwargs**: the task's and plant's options (`time_limit`, `track_limit`,
  `integrator`, `equations`, and `params={name: value}`, the physical parameters of
  `Domain.parameters`) and the sensor and actuator options (`observation_noise`,
  `action_delay`, `action_noise`; `tasks.disturbances`, whose noise `reset(seed=s)` seeds
  as `tasks.load(seed=s)` does) as in `tasks.load`; unknown ones raise a `ValueError`
  naming the allowed. A variable with observation noise is unbounded in the Box.
  `seed` is not one (use `reset(seed=...)`), and kwargs cannot change the id's domain,
  task, plant or kind of action (`actions`).
"""

try:
    import gymnasium
    from gymnasium import spaces
except ImportError as error:  # pragma: no cover - only without gymnasium
    raise ImportError("lwrl.gym needs gymnasium (pip install 'lwrl[gymnasium]'); "
                      "the rest of the suite does not") from error
import importlib.util
import os
import sys
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from lwrl import models, tasks
from lwrl.tasks.batched import BatchedEnv
from lwrl.viz import scenes
from lwrl.viz.drawing import Painter
from lwrl.tasks.spaces import Discrete
from lwrl.tasks.task_definition import check_finite_state

NAMESPACE = "lwrl"
"""The ids' namespace: `lwrl/...`."""
VERSION = 0
"""The ids' version: `...-v0`."""
ENTRY_POINT = "lwrl.gym:SuiteEnv"
"""What Gymnasium makes for an id (`gymnasium.make`)."""
VECTOR_ENTRY_POINT = "lwrl.gym:SuiteVectorEnv"
"""What Gymnasium makes for an id's vector environment (`gymnasium.make_vec`)."""
RENDER_MODES = ("human", "rgb_array")
"""The render modes of `SuiteEnv`: a window, or frames returned by `render`."""
NO_OPENGL = ("disable", "disabled", "off", "false", "0")
"""`MUJOCO_GL` values under which MuJoCo draws nothing (lwrl.tasks sets `disable` where
there is no display and the variable is unset)."""


def env_id(domain: str, task: str, plant: str | None, actions: str = "discrete") -> str:
    """The Gymnasium id of `domain.task` on `plant`, e.g. `lwrl/cartpole-balance-mujoco-v0`;
    with continuous actions `lwrl/cartpole-balance-mujoco-continuous-v0`; with no plant
    (None) the id of the domain's default plant, `lwrl/cartpole-balance-v0`."""
    kind = "" if actions == "discrete" else f"-{actions}"
    plant_part = "" if plant is None else f"-{plant}"
    return f"{NAMESPACE}/{domain}-{task}{plant_part}{kind}-v{VERSION}"


def _environments(actions: str) -> dict:
    """`{id: (domain, task, plant)}` of every task on every plant of a dm_env environment,
    with `actions`."""
    return {env_id(domain, task, plant, actions): (domain, task, plant)
            for domain, task in tasks.ALL_TASKS for plant in tasks.ENVIRONMENT_PLANTS[domain]}


ENVIRONMENTS = _environments("discrete")
"""`(domain, task, plant)` of each registered id of discrete actions."""
ENV_IDS = tuple(ENVIRONMENTS)
"""The registered ids of discrete actions, every task on every plant of a dm_env
environment."""
CONTINUOUS_ENVIRONMENTS = _environments("continuous")
"""`(domain, task, plant)` of each registered id of continuous actions."""
CONTINUOUS_ENV_IDS = tuple(CONTINUOUS_ENVIRONMENTS)
"""The registered ids of continuous actions, one beside each of `ENV_IDS`."""
DEFAULT_ENVIRONMENTS = {env_id(domain, task, None, actions): (domain, task,
                                                               tasks.ENVIRONMENT_PLANTS[domain][0],
                                                               actions)
                        for actions in ("discrete", "continuous") for domain, task in tasks.ALL_TASKS}
"""`(domain, task, plant, actions)` of each id without a plant, `lwrl/{domain}-{task}-v0` and
`lwrl/{domain}-{task}-continuous-v0`: the task on its domain's default plant (MuJoCo where
there is a model), as `tasks.load` takes it."""
DEFAULT_ENV_IDS = tuple(DEFAULT_ENVIRONMENTS)
"""The ids without a plant (`DEFAULT_ENVIRONMENTS`)."""
_REGISTERED = {**{id_: (*names, "discrete") for id_, names in ENVIRONMENTS.items()},
               **{id_: (*names, "continuous") for id_, names in CONTINUOUS_ENVIRONMENTS.items()},
               **DEFAULT_ENVIRONMENTS}
"""`(domain, task, plant, actions)` of every registered id."""


def gymnasium_space(space) -> spaces.Space:
    """The Gymnasium space of a task's space (`tasks.spaces`): `Discrete(n)`, or a float64
    `Box` (the plants' type, so that an action reaches the plant unrounded)."""
    if isinstance(space, Discrete):
        return spaces.Discrete(space.n)
    return spaces.Box(np.array(space.low), np.array(space.high), dtype=np.float64)


def _describe(domain: str, task: str, plant: str, actions: str) -> str:
    """E.g. `cartpole.balance on the mujoco plant`, `... with continuous actions`."""
    kind = "" if actions == "discrete" else f" with {actions} actions"
    return f"{domain}.{task} on the {plant} plant{kind}"


def _options(domain: str, task: str, plant: str) -> list:
    """The make() kwargs that `domain.task` on `plant` takes (those `tasks.resolve` allows,
    less `plant` and `seed`, which the id and `reset` set)."""
    return (tasks.task_options(domain, task) + tasks.plant_option_names(domain, plant)
            + list(tasks.disturbances.OPTIONS))


class SuiteEnv(gymnasium.Env):
    """One task of the suite on one plant, as a Gymnasium environment (see the module).

    `SuiteEnv(domain, task, plant=None, render_mode=None, actions="discrete", **options)`
    takes the arguments of `tasks.load` except `seed` (seed with `reset(seed=...)`).
    `dm_env` is the wrapped dm_env environment, `definition` the task's `TaskDefinition`,
    `task_spec` its `tasks.spaces.TaskSpec` (the spaces come from it), `actions` its kind of action (`discrete` or `continuous`), `step_limit` its truncation
    step (`inf` for none).
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": None}
    """Gymnasium's: the render modes (an instance's: those its domain draws) and frames per
    second (an instance's: one per control step)."""

    def __init__(self, domain: str, task: str, plant=None, render_mode=None,
                 actions: str = "discrete", **options):
        if render_mode not in (None, *RENDER_MODES):
            raise ValueError(f"render_mode must be None, {' or '.join(map(repr, RENDER_MODES))}; "
                             f"got {render_mode!r}")
        _, plant, _ = tasks.resolve(domain, task, plant)  # checks the names
        allowed = _options(domain, task, plant)
        unknown = sorted(set(options) - set(allowed))
        if unknown:
            hint = "; seed the environment with reset(seed=...)" if "seed" in unknown else ""
            raise ValueError(f"unknown option {unknown[0]!r} for {domain}.{task} on the {plant} "
                             f"plant; allowed: {', '.join(allowed) or 'none'}{hint}")
        definition, plant, _, _ = tasks.resolve_environment(domain, task, plant, actions=actions,
                                                            **options)  # checks
        self.domain, self.task_name, self.plant = domain, task, plant
        self.actions = definition.actions
        """The kind of action: `discrete` (an index) or `continuous` (the control itself)."""
        self.options = dict(options)
        """The task's options given (`tasks.load`'s keyword arguments)."""
        self.dm_env = tasks.load(domain, task, plant=plant, actions=actions, **options)
        """The wrapped dm_env environment."""
        self.definition = definition
        """The task's `TaskDefinition`, its options applied."""
        self.step_limit = definition.step_limit
        """The step at which an episode is truncated (`inf` for none)."""
        self.observation_names = tuple(definition.state_names)
        """The names of an observation's variables, in order."""
        self.render_mode = render_mode
        """None, `human` or `rgb_array` (`RENDER_MODES`)."""
        self.metadata = {**self.metadata, "render_modes": render_modes(domain),
                         "render_fps": 1.0 / definition.control_timestep}
        """The render modes this domain draws, and one frame per control step."""
        self._painter = painter(domain, render_mode)
        self._window = _Window(f"lwrl {domain}.{task} ({plant})", self.metadata["render_fps"]) \
            if render_mode == "human" else None
        self.task_spec = tasks.spec_of(definition)
        """The task's `tasks.spaces.TaskSpec`, which the spaces come from."""
        self.action_space = gymnasium_space(self.task_spec.action)
        """`Discrete(n)`, or with continuous actions the control's `Box`."""
        noisy = self.suite_task.disturbances.sigma_observation[0] > 0
        self.observation_space = gymnasium_space(self.task_spec.observation.unbounded_where(noisy))
        """The task's observation `Box`, unbounded in the variables its sensors add noise to."""
        self._spec = None
        self._episode_over = True
        self._started = False

    @property
    def spec(self):
        """The `EnvSpec` that `gymnasium.make` sets; an lwrl id must match the env's
        domain, task, plant and kind of action (make() kwargs cannot change them)."""
        return self._spec

    @spec.setter
    def spec(self, value):
        expected = _REGISTERED.get(getattr(value, "id", None))
        actual = (self.domain, self.task_name, self.plant, self.actions)
        if expected is not None and expected != actual:
            raise ValueError(f"{value.id} is {_describe(*expected)}; make() kwargs asked for "
                             f"{_describe(*actual)}: use {env_id(*actual)} instead")
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
        """Start an episode: `(observation, info)`. `seed` seeds the starts and the
        disturbances; `options={"state": s}` starts from the state `s` instead (one line
        where it is terminal or observes outside the observation space)."""
        super().reset(seed=seed)
        self._episode_over = True  # until this reset succeeds
        options = {} if options is None else dict(options)
        unknown = sorted(set(options) - {"state"})
        if unknown:
            raise ValueError(f"unknown reset option {unknown[0]!r}; allowed: state")
        self.suite_task.random = self.np_random
        if seed is not None:
            self.suite_task.seed_disturbances(seed)
        observation = self._observation(self.dm_env.reset().observation)
        if "state" in options:
            observation = self._start_in(options["state"])
        self._episode_over = False
        self._started = True
        self._show()
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
        """Take `action`: `(observation, reward, terminated, truncated, info)`, `info` with
        the episode's `steps`, `uptime_s` (None where the task has none) and `plant`."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if self._episode_over:
            raise RuntimeError("the episode has ended (terminated or truncated); call reset()")
        time_step = self.dm_env.step(self._command(action))
        terminated = bool(time_step.last() and time_step.discount == 0.0)
        truncated = bool(time_step.last() and not terminated)
        self._episode_over = terminated or truncated
        self._show()
        return (self._observation(time_step.observation), float(time_step.reward), terminated,
                truncated, self._info())

    def _command(self, action):
        """What the dm_env environment takes for `action`: an action index as an int
        (a one-line ValueError outside `action_space`), or a continuous action as it is
        (the task checks it and clips it to the actuator's range)."""
        if self.definition.continuous:
            return action
        if not self.action_space.contains(action):
            raise ValueError(f"action must be an integer in 0..{self.action_space.n - 1}; "
                             f"got {action!r}")
        return int(action)

    def _frame(self) -> np.ndarray:
        assert self._painter is not None, "a render mode draws frames"
        return self._painter(self.dm_env.physics.state_vector())

    def _show(self) -> None:
        if self._window is not None:
            self._window.show(self._frame())

    def render(self):
        """The current state as a `(240, 320, 3)` uint8 frame (`render_mode="rgb_array"`);
        None otherwise (`"human"` shows every state as it is reached)."""
        if self.render_mode != "rgb_array":
            return None
        if not self._started:
            raise RuntimeError("call reset() before render()")
        return self._frame()

    def close(self):
        """Close the window, the painter and the dm_env environment."""
        for part in (self._window, self._painter):
            if part is not None:
                part.close()
        self._window = self._painter = None
        self.dm_env.close()


def _opengl() -> bool:
    return os.environ.get("MUJOCO_GL", "").lower() not in NO_OPENGL


def _display() -> bool:
    return not sys.platform.startswith("linux") or bool(os.environ.get("DISPLAY")
                                                        or os.environ.get("WAYLAND_DISPLAY"))


def render_modes(domain: str) -> list:
    """The render modes this process can draw `domain` in: `rgb_array` unless the domain's
    model needs OpenGL and there is none; `human` too where a display and pygame are."""
    if tasks.domain(domain).model is not None and not _opengl():
        return []
    window = _display() and importlib.util.find_spec("pygame") is not None
    return list(RENDER_MODES) if window else ["rgb_array"]


def painter(domain: str, render_mode) -> Painter | None:
    """The frames of `render_mode` for `domain` (None: no rendering), or a one-line error
    where this process cannot draw them."""
    if render_mode is None:
        return None
    model = tasks.domain(domain).model
    if model is not None and not _opengl():
        raise ValueError(f"render_mode={render_mode!r} draws {domain}'s MuJoCo model with OpenGL, "
                         "which this process has not: set MUJOCO_GL=egl (headless; Debian's "
                         "libegl1 libegl-mesa0) before importing lwrl, or run where a display is")
    return Painter(None if model is None else models.read(model),
                   scenes.drawing_of(domain) if model is None else None)


class _Window:
    """`render_mode="human"`: frames shown in a window at `fps` (pygame, a display)."""

    def __init__(self, title: str, fps: float):
        if not _display():
            raise ValueError("render_mode='human' needs a display (DISPLAY or WAYLAND_DISPLAY is "
                             "not set); use render_mode='rgb_array' to get the frames")
        try:
            import pygame
        except ImportError:
            raise ValueError("render_mode='human' shows frames with pygame: pip install pygame") from None
        self._pygame, self._title, self._fps = pygame, title, fps
        self._screen: Any = None
        self._clock: Any = None

    def show(self, frame: np.ndarray) -> None:
        pygame = self._pygame
        if self._screen is None:
            pygame.init()
            pygame.display.set_caption(self._title)
            self._screen = pygame.display.set_mode(frame.shape[1::-1])
            self._clock = pygame.time.Clock()
        self._screen.blit(pygame.surfarray.make_surface(frame.swapaxes(0, 1)), (0, 0))
        pygame.event.pump()
        pygame.display.flip()
        self._clock.tick(self._fps)

    def close(self) -> None:
        if self._screen is not None:
            self._pygame.display.quit()
            self._pygame.quit()
            self._screen = None


class SuiteVectorEnv(VectorEnv):
    """`num_envs` copies of one task on one plant, stepped together (see the module):
    `gymnasium.make_vec(id, num_envs=B)`. Takes `SuiteEnv`'s arguments and `num_envs`;
    with continuous actions, `step` takes them `(B, 1)` (the batched Box) or `(B,)`;
    `autoreset_mode` can only be Gymnasium's default, `NEXT_STEP`, which `BatchedEnv`
    implements; `max_episode_steps` (the id's, which `make_vec` passes) truncates the copies'
    episodes where it comes before the task's own limit, as that limit does."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}
    """Gymnasium's: the autoreset mode, no render modes, and (an instance's) frames per
    second, one per control step."""

    def __init__(self, domain: str, task: str, plant=None, num_envs: int = 1,
                 autoreset_mode=AutoresetMode.NEXT_STEP, render_mode=None,
                 actions: str = "discrete", max_episode_steps=None, **options):
        if render_mode is not None:
            raise ValueError(f"the vector environment does not render (render_mode must be None, "
                             f"got {render_mode!r}); gymnasium.make gives one environment that does")
        if AutoresetMode(autoreset_mode) != AutoresetMode.NEXT_STEP:
            raise ValueError(f"autoreset_mode must be {AutoresetMode.NEXT_STEP} (Gymnasium's "
                             f"default); got {autoreset_mode!r}")
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer; got {num_envs!r}")
        single = SuiteEnv(domain, task, plant, actions=actions, **options)  # checks them
        if max_episode_steps is not None:
            if (isinstance(max_episode_steps, bool) or not isinstance(max_episode_steps, (int, np.integer))
                    or max_episode_steps < 1):
                raise ValueError(f"max_episode_steps must be a positive integer or None; got "
                                 f"{max_episode_steps!r}")
            if max_episode_steps < single.step_limit:  # the earlier limit, as the task's own
                single.close()
                options = {**options, "time_limit": int(max_episode_steps)
                           * single.definition.control_timestep}
                single = SuiteEnv(domain, task, plant, actions=actions, **options)
        self.domain, self.task_name, self.plant = single.domain, single.task_name, single.plant
        self.actions = single.actions
        """The kind of action, `SuiteEnv.actions`."""
        self.options, self.definition = single.options, single.definition
        self.task_spec = single.task_spec
        """The task's `tasks.spaces.TaskSpec`, `SuiteEnv.task_spec`."""
        self.single_action_space = single.action_space
        """One copy's action space, `SuiteEnv.action_space`."""
        self.single_observation_space = single.observation_space
        """One copy's observation space, `SuiteEnv.observation_space`."""
        single.close()
        self.num_envs = int(num_envs)
        """The copies stepped together, B."""
        self.render_mode = None
        """Always None: the vector environment does not render."""
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        """The copies' action spaces, batched (`MultiDiscrete`, or a `(B, 1)` Box)."""
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        """The copies' observation spaces, batched: a `(B, d)` Box."""
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.definition.control_timestep}
        """`metadata` with one frame per control step."""
        self._batched: BatchedEnv | None = None
        self._plants = np.full(self.num_envs, self.plant, dtype=object)

    def _seeds(self, seed) -> list:
        """Each copy's seed, as `SyncVectorEnv` seeds its environments."""
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            return [int(seed) + i for i in range(self.num_envs)]
        seeds = list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(f"seed must be an integer or {self.num_envs} seeds, one per "
                             f"environment; got {seed!r}")
        return seeds

    def reset(self, *, seed=None, options=None):
        """Start every copy's episode: `(observations (B, d), infos)`. An integer `seed`
        seeds copy i with `seed + i`, a list one seed per copy (as `SyncVectorEnv`); no
        reset options."""
        if options:
            raise ValueError(f"the vector environment takes no reset options; got {options!r}")
        super().reset(seed=seed if isinstance(seed, (int, np.integer)) else None)
        if seed is not None or self._batched is None:  # new streams for the starts
            self._batched = BatchedEnv(self.domain, self.task_name, self.plant,
                                       seeds=self._seeds(seed), actions=self.actions,
                                       **self.options)
        time_step = self._batched.reset()
        return np.array(time_step.observation, dtype=np.float64), self._infos(self._batched)

    def step(self, actions):
        """Step every copy: `(observations, rewards, terminated, truncated, infos)`, each
        batched; a copy whose episode ended resets on its next step (`NEXT_STEP`)."""
        if self._batched is None:
            raise RuntimeError("call reset() before step()")
        time_step = self._batched.step(actions)  # checks the actions
        last = time_step.last()
        terminated = last & (time_step.discount == 0.0)
        return (np.array(time_step.observation, dtype=np.float64),
                np.asarray(time_step.reward, dtype=np.float64), terminated, last & ~terminated,
                self._infos(self._batched))

    def _infos(self, batched: BatchedEnv) -> dict:
        """`SuiteEnv`'s info of every copy, batched as `VectorEnv._add_info` batches them."""
        every = np.ones(self.num_envs, dtype=bool)
        uptime = (np.array(batched.uptime, dtype=np.float64) if self.definition.has_uptime
                  else np.full(self.num_envs, None, dtype=object))
        return {"uptime_s": uptime, "_uptime_s": every.copy(),
                "steps": np.array(batched.steps, dtype=np.int64), "_steps": every.copy(),
                "plant": self._plants.copy(), "_plant": every.copy()}

    def close_extras(self, **kwargs):
        """Drop the batched environment (`VectorEnv.close` calls this)."""
        self._batched = None


def max_episode_steps(domain: str, task: str) -> int:
    """The steps of the task's own time limit at its default options, every id's
    `max_episode_steps` (`tasks.spaces.TaskSpec.step_limit`): 10 000 for Mountain-Car and the
    acrobot, 3 000 for the pendulum (60 s), 12 000 for the cart-pole (240 s)."""
    return int(tasks.spec(f"{domain}.{task}").step_limit)


def register_envs() -> tuple:
    """Register every id of `ENV_IDS`, `CONTINUOUS_ENV_IDS` and `DEFAULT_ENV_IDS` with
    Gymnasium (those not registered yet), those of continuous actions with
    `actions="continuous"` among their kwargs; return `ENV_IDS`. Calling it again does
    nothing."""
    for id_, (domain, task, plant, actions) in _REGISTERED.items():
        if id_ not in gymnasium.envs.registry:
            kind = {} if actions == "discrete" else {"actions": actions}
            gymnasium.register(id=id_, entry_point=ENTRY_POINT,
                               vector_entry_point=VECTOR_ENTRY_POINT,
                               max_episode_steps=max_episode_steps(domain, task),
                               kwargs={"domain": domain, "task": task, "plant": plant, **kind})
    return ENV_IDS


register_envs()
