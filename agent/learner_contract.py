"""The learner contract: what every learner of lwrl gives the rest of the house.

A learner is one module, `agent/<learner>.py`, ending with `LEARNER = Learner(...)` and one
line of `LEARNER_MODULES` (`agent/__init__.py`), as a domain is one module of `tasks/`
ending with its `DOMAIN`; or a module of another installed package, whose entry point of the
group `lwrl.learners` names its `LEARNER` (`agent.outside_learners`). Nothing outside
`agent/` names a learner: the runners, the recordings, the value images, the C export and
the studies look everything up here.

What a learner gives (`Learner`):

- `settings`: a frozen dataclass of its settings (`lwrl.settings`): each field is a flag of
  `lwrl train`, a column of the results tables and, unless its metadata says otherwise, part
  of a run's key; fields marked `per_task` take the task's setting (else their own) when left None;
- `make(settings, task, seeds)`: a batch of B independent agents (`Agents`) on the task
  whose spec is `task` (`lwrl.spaces.TaskSpec`: its spaces, state names, normalisation
  ranges, ...; A, where it needs it, is `task.action.n`), agent b with `settings[b]` and
  its own random stream from `seeds[b]`;
- `step`: its per-agent step, numba-jitable, which the compiled loop binds as it binds a
  domain's `transition` (`runners.compiled`):
  `step(b, first, reward, discount, observation, learn, greedy, arrays) -> action` (an
  index, or a number in [-1, 1] for a learner of continuous actions, `actions`), where
  `first` starts an episode (no update), `reward` and `discount` end the transition into
  `observation` (discount 0: a terminal state, where no action is chosen), `learn=False`
  makes no update and `greedy=True` acts greedily, both without touching the learner's
  settings; `arrays` is the batch's `Agents.arrays`. None for a learner that runs only in
  the stepped loop (its `Agents.step` does the work);
- `actions`: the kind of action space it takes, `discrete` (a `Discrete` space) or
  `continuous` (a `Box`: `Learner.takes`; `tasks.commands`: how the loops turn it into the
  actuator's command);
- `fits(task)`: None, or one line saying why the learner does not fit a task (its
  `TaskSpec`, `lwrl.spaces`: all a learner knows of a task);
- `load(document, arrays)`: agents from a file written by `agent.io.save`;
- `memory(settings, task)`: the bytes one agent needs, before any is made;
- `tuned`: settings tuned for it elsewhere, by the Gymnasium environment they were tuned
  on (rl-baselines3-zoo's, for DQN and PPO), which studies take on the domains tuned as it;
- `population`: its agents train as one jitted JAX program (`runners.population`), the
  third run path beside the compiled and stepped loops, with the same per-episode records.
- `arithmetic(settings, task, steps=None)`: its counted arithmetic (`agent.arithmetic`):
  the multiply-adds and exponentials of one greedy decision and of one agent-step of
  learning, its updates averaged per agent-step over a run of `steps` steps where its cost
  depends on them (PPO's epochs per rollout, DQN's updates after its warm-up); None for a
  learner without counts, `agent.arithmetic.NotCounted` for settings it does not count.

What a batch of agents gives (`Agents`): `step` over the batch (the stepped loop), `arrays`
(a namedtuple whose fields `delta` `(B,)`, `diverged` `(B,)` and `weights` `(B, ...)` the
loops read for recordings: the latest TD error or NaN, the divergence flag, and what the
learner has learned), the `action_space` its agents act in, action values and state values
over states where the learner has them, its
greedy controller as C where it has one, itself as C that learns on a device where it can,
what `agent.io` saves, and `take_over`: becoming kept agents as they ended, for a run that
goes on with them.

Action values are a capability, not a duty: a learner that keeps its action values (or the
preferences it acts greedily on) at the latest observation has the field `q` `(B, A)` in its
arrays, one per action of its `Discrete(A)` action space; a learner without them (an actor's
mean, a population trained as one JAX program, the learner on a device) has no `q` at all.
A consumer asks `Agents.latest_values`, which says in one line (`NoValues`) where there are
none, as `action_values` does for values over states.
"""

import dataclasses
from typing import Any, Callable, Mapping

import numpy as np

from lwrl.agent.threads import run_in_chunks
from lwrl.kernels import kernel
from lwrl.settings import check_choices
from lwrl.spaces import Box, Discrete, Space, TaskSpec

CONTINUOUS_ACTIONS = Box((-1.0,), (1.0,))
"""The action space of a learner of continuous actions: one number in [-1, 1], which the
loops scale to the actuator's range (`tasks.commands`)."""


class NoValues(ValueError):
    """A learner has no action values (or no state values) to show."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class LearnerSettings:
    """Base of the learners' settings dataclasses."""

    def __post_init__(self):
        check_choices(self)

    def check(self, task: TaskSpec) -> None:
        """A one-line ValueError for the first setting out of its range on `task`, once the
        task's defaults are in."""

    def label(self) -> str:
        """A few words for file and directory names (e.g. `nrbf-replacing-a3.9-l0.9`)."""
        raise NotImplementedError

    def describe(self, dim: int) -> str:
        """One line for a run's header, for a task of `dim` state variables."""
        raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class Learner:
    """Everything lwrl knows about a learner (see the module's docstring)."""

    name: str
    """Its name on the command line (`--learner NAME`) and in the registry."""
    title: str
    """What it is, in a few words."""
    source: str
    """The publication (or code) it follows."""
    settings: type
    """Its frozen settings dataclass (a `LearnerSettings`)."""
    make: Callable
    """`make(settings, task, seeds)`: B agents, `settings` one per agent, on the task whose
    spec is `task` (`TaskSpec`)."""
    load: Callable
    """`load(document, arrays)`: agents from a saved file's document and arrays."""
    memory: Callable
    """`memory(settings, task)`: bytes one agent with `settings` needs on `task` (its
    arrays), for the check that a batch fits the machine before it is made."""
    step: Callable | None = None
    """The numba-jitable per-agent step of the compiled loop; None: stepped loop only."""
    fits: Callable = lambda task: None
    """`fits(task)`: None, or one line saying why the learner does not fit the task (its
    kind of action, its sizes): what the learner is, whatever is installed."""
    unavailable: Callable = lambda: None
    """`unavailable()`: None where the libraries it needs are installed; else one line
    naming those missing and the extra that installs them. Apart from `fits`: a run of it is
    named, planned and reported without them (`lwrl bench report`); agents are made with
    them only (`check_installed`)."""
    tuned: Mapping = dataclasses.field(default_factory=dict)
    """`{Gymnasium environment id: {setting: value}}`: settings tuned for the learner
    elsewhere (rl-baselines3-zoo's), which a study takes on the domains tuned as that
    environment (`agent.zoo.TUNED_AS`); empty: the task's defaults are its own."""

    checked: Mapping = dataclasses.field(default_factory=dict)
    """`{setting: value}` the contract's checks (`lwrl.testing.contract_config`) run it with
    in place of its defaults, where those would spend the checks' seconds on sizes the checks
    do not look at and leave paths unrun in their 120 steps: small networks and batches, and
    updates that start within the run. Empty: its defaults."""

    actions: str = "discrete"
    """The kind of action its step returns (`tasks.commands`): `discrete`, an index into
    the task's controls; `continuous`, a number in [-1, 1] that the loops scale to the
    actuator's range. It runs the tasks made with that kind (`actions=`)."""
    population: bool = False
    """True: its agents train as one jitted JAX program over the suite's JAX tasks
    (`runners.population`; `agent.jax_population.PopulationAgents`), not step by step."""
    shared: Callable = lambda settings: ()
    """`shared(settings)`: what a population learner's per-agent `settings` (one per agent)
    give that shapes its program (a minibatch's size, the gradient steps of a training
    call), which the agents of one batch must therefore share: the values, or a one-line
    ValueError where they differ (`agent.jax_population.batch_value`). () where nothing
    does; `runners.sweep.batch_key` batches only runs that agree on it."""
    arithmetic: Callable | None = None
    """`arithmetic(settings, task, steps=None) -> agent.arithmetic.Counts`: the multiply-adds
    and exponentials of one greedy decision and of one agent-step of learning with
    `settings` on `task` (`TaskSpec`), its updates averaged per agent-step over a run of
    `steps` steps of learning, or of a long run where None (the same for a learner whose
    every step costs the same); `agent.arithmetic.NotCounted` for settings it does not
    count. None: a learner without counts."""

    @property
    def takes(self) -> type:
        """The action space it takes (`lwrl.spaces`): `Discrete`, or `Box` for a learner of
        continuous actions."""
        return Box if self.actions == "continuous" else Discrete

    @property
    def compiles(self) -> bool:
        """True where the compiled loop can run this learner."""
        return self.step is not None

    def check_installed(self) -> None:
        """A one-line ValueError where the libraries it needs are not installed
        (`unavailable`)."""
        reason = self.unavailable()
        if reason is not None:
            raise ValueError(reason)


class Agents:
    """A batch of B independent agents of one learner. Subclasses set `learner` and
    `arrays` and implement `step`; the others have defaults a learner may override."""

    learner: Learner
    """The learner whose agents these are (its `LEARNER`)."""
    arrays: Any
    """A namedtuple of arrays with a leading axis B, with at least `delta`, `diverged` and
    `weights`, and `q` where the learner has action values (see the module's docstring)."""
    settings: tuple
    """Each agent's settings."""
    dim: int
    """State variables of the observations it takes."""

    @property
    def batch_size(self) -> int:
        """B, the agents."""
        return len(self.arrays.diverged)

    @property
    def action_space(self) -> Space:
        """The actions its agents take (`lwrl.spaces`): `Discrete(A)`, indices into the
        task's A controls, or `Box([-1], [1])`, a number the loops scale to the actuator's
        range (`Learner.actions`). The default reads A off `arrays.q`; a learner of
        discrete actions without action values says A itself."""
        if self.continuous:
            return CONTINUOUS_ACTIONS
        return Discrete(self.latest_values().shape[1])

    def latest_values(self) -> np.ndarray:
        """`(B, A)` each agent's action values (or the preferences it acts greedily on) at
        its latest observation, before its update there: `arrays.q`; `NoValues` where the
        learner keeps none (see the module's docstring)."""
        values = getattr(self.arrays, "q", None)
        if values is None:
            name = getattr(getattr(self, "learner", None), "name", "these agents")
            raise NoValues(f"{name} keeps no action values at its observations")
        return values

    @property
    def continuous(self) -> bool:
        """True where its actions are numbers in [-1, 1] (`Learner.actions`); False for
        agents of no learner, which act by index unless they say otherwise (a benchmark's
        reference rows on a task made with continuous actions)."""
        learner = getattr(self, "learner", None)
        return learner is not None and learner.actions == "continuous"

    @property
    def diverged(self) -> np.ndarray:
        """`(B,)` True for agents whose learning went NaN or infinite (frozen since)."""
        return self.arrays.diverged

    def check_observation(self, observation) -> np.ndarray:
        """`observation` as float64 `(B, d)`, or a one-line error."""
        observation = np.ascontiguousarray(observation, dtype=np.float64)
        if observation.shape != (self.batch_size, self.dim):
            raise ValueError(f"observation must have shape ({self.batch_size}, {self.dim}); "
                             f"got {observation.shape}")
        return observation

    def step(self, first, reward, discount, observation, active=None, learn=True,
             greedy=False) -> np.ndarray:
        """Feed each agent its time step (arrays with a leading axis B); return the actions.

        `first`: the observation starts an episode; `reward`, `discount`: of the transition
        into the observation (ignored where `first`); `observation` `(B, d)`. Agents where
        `active` is False are left untouched (their action is 0). A compiled learner runs
        its own jitted `step` over the batch, so both loops compute the same numbers."""
        observation = self.check_observation(observation)
        batch = self.batch_size
        active = np.ones(batch, dtype=bool) if active is None else np.asarray(active, dtype=bool)
        actions = np.zeros(batch, dtype=np.float64 if self.continuous else np.int64)
        run_in_chunks(batch_step(self.learner), batch, np.asarray(first, dtype=bool),
                      np.asarray(reward, dtype=np.float64),
                      np.asarray(discount, dtype=np.float64), observation, active, bool(learn),
                      bool(greedy), self.arrays, actions)
        return actions

    def action_values(self, states, weights=None) -> np.ndarray:
        """`(B, ..., A)` every agent's values of the task's A discrete actions (or the
        preferences it acts greedily on) at states `(..., d)` in task units; with `weights`
        (one agent's `arrays.weights[b]`, e.g. a recording's), `(..., A)` for those.
        `NoValues` where it has none: a learner of continuous actions has no values over a
        set of actions (its greedy action is `greedy_actions`)."""
        raise NoValues(f"{self.learner.name} has no action values")

    def greedy_actions(self, states, weights=None) -> np.ndarray:
        """`(B, ...)` the action in [-1, 1] each agent of a learner of continuous actions
        takes greedily at states `(..., d)` in task units (its policy's, as `greedy=True`
        acts); with `weights` (one agent's), `(...)` for those. `NoValues` for a learner of
        discrete actions, whose greedy action is the best of its `action_values`."""
        raise NoValues(f"{self.learner.name} gives no greedy action in [-1, 1] over states")

    def state_values(self, states, weights=None) -> np.ndarray:
        """As `action_values`, the value of each state: max over the actions unless the
        learner has a value of its own (a critic)."""
        return self.action_values(states, weights).max(axis=-1)

    def action_values_on_grid(self, axes, weights) -> np.ndarray:
        """`(len(axes[0]), ..., len(axes[d-1]), A)` the action values of one agent's
        `weights` over the grid of states whose variable j takes the values `axes[j]` (1-D
        arrays). The default evaluates the states in blocks; a learner may factorise."""
        return _on_grid(axes, lambda states: self.action_values(states, weights))

    def state_values_on_grid(self, axes, weights) -> np.ndarray:
        """As `action_values_on_grid`, the state values."""
        return _on_grid(axes, lambda states: self.state_values(states, weights), actions=False)

    def value_box(self) -> tuple:
        """`(low, high)` per state variable: the box the learner's representation spans
        (the value images' extent)."""
        raise NotImplementedError

    def feature_points(self) -> np.ndarray | None:
        """`(K, d)` states (task units) where the learner's features are centred, for the
        value images (an NRBF's centroids), or None."""
        return None

    def controller(self, b: int):
        """Agent b's greedy controller as C (`export.c`): a `ControllerForm`, or a one-line
        ValueError saying why there is none."""
        raise ValueError(f"{self.learner.name} agents have no C controller")

    def learner_form(self, b: int) -> "LearnerForm":
        """Agent b as C that goes on learning on a device (`export.learner`): a
        `LearnerForm`, or a one-line ValueError saying why there is none."""
        raise ValueError(f"{self.learner.name} agents cannot learn in C")

    def saved(self) -> tuple[dict, dict]:
        """`(document, arrays)`: what `agent.io.save` writes (JSON and NumPy arrays); the
        learner's `load` reads them back."""
        raise NotImplementedError

    def copies_of(self, kept: "Agents") -> int:
        """How many times these agents hold the kept ones (`take_over`), or a one-line error
        where B is not a whole multiple of K."""
        copies, rest = divmod(self.batch_size, kept.batch_size)
        if rest or not copies:
            raise ValueError(f"{self.batch_size} agents cannot take over {kept.batch_size} kept "
                             "ones: they must be a whole multiple of them")
        return copies

    def take_weights(self, weights) -> None:
        """Become agents that learned `weights` `(B, ...)`, in `arrays.weights`' layout (a
        device's C learner sends its weights so, `lwrl_weights`). The default writes them
        into `arrays.weights`, where a learner that learns in C reads its own; a learner
        that keeps them elsewhere (a JAX population's state) overrides it."""
        self.arrays.weights[:] = weights

    def take_over(self, kept: "Agents") -> None:
        """Become the agents `kept` (of this learner) as they ended, in turn: agent b is kept
        agent b mod K (K kept agents, B a multiple of K), with everything `agent.io` saves
        of it (what it learned, its random stream, its divergence), keeping these agents'
        settings. A run that goes on with a kept run's agents starts so
        (`runners.sweep.trained_agents`: an evaluation in several cells at once).

        The default copies the arrays of `saved`, which must be these agents' own with a
        leading axis B; a learner whose agents hold more overrides it."""
        copies = self.copies_of(kept)
        _, target = self.saved()
        for name, values in kept.saved()[1].items():
            target[name][:] = np.concatenate([values] * copies)
        if not all(np.array_equal(target[name], self.saved()[1][name], equal_nan=True)
                   for name in target):
            raise ValueError(f"{self.learner.name}'s saved arrays are not its own: its agents "
                             "cannot take over kept ones")


@dataclasses.dataclass(frozen=True)
class ControllerForm:
    """A greedy controller as the C export (`export.c`) writes it: a template pair of
    `export/templates` (`{template}.c.in`, `{template}.h.in`, `string.Template`) and the
    values its placeholders take, beside the ones every controller has (task, sizes,
    source file), in the export's floating-point type."""

    template: str
    """Name of the template pair."""
    values: dict
    """`{placeholder: value}`: a 2-D array is written one brace block per row, a 1-D array
    as comma-separated literals, a float as a literal, a str or int as it is. `weights`
    (the learned parameters) is always there."""
    stored: tuple
    """The values the controller keeps in memory: its data bytes (the weights among them)."""
    ranges: tuple
    """`(low, high)` per state variable: the box the controller reads states in."""
    check: Callable
    """`check(real)`: None, or one line saying why the values do not fit the NumPy type
    `real` (`np.float32`, `np.float64`)."""


@dataclasses.dataclass(frozen=True)
class LearnerForm:
    """A learner as C99 that learns on a device, as `export.learner` writes it: a template
    pair below `export/templates` (`{template}.c.in`, `{template}.h.in`) and the values its
    placeholders take, beside the ones every learner has (the task, where the agent came
    from, the RAM, the floating-point type, the random stream's C code), and the parts of
    its static RAM. The C interface is the export's: `lwrl_reset`, `lwrl_begin`,
    `lwrl_learn`, `lwrl_greedy`, `lwrl_weights`, `lwrl_diverged`."""

    template: str
    """Name of the template pair, e.g. `learner/lwrl_learner`."""
    values: Callable
    """`values(real)`: `{placeholder: value}` for a build in the NumPy type `real`
    (`np.float32`, `np.float64`; a constant may depend on it), written as
    `ControllerForm.values` are: floats and 1-D arrays as literals of `real`, a str or int
    as it is (so a constant that stays a double in every build comes as its C literal).
    Always there: `weights`, the learned parameters the C learner starts from (a 2-D array),
    and `seed`, the 64-bit state its random stream starts from."""
    ram: Mapping
    """`{part: (reals, other bytes)}`: each part of its static RAM, as a count of values of
    the build's floating-point type and a count of other bytes (integers), in the order
    they are reported."""
    ranges: tuple
    """`(low, high)` per state variable: the box it reads states in."""
    stream: Any
    """The random stream its C code draws from as lwrl does (`agent.streams.SPLITMIX64`)."""
    check: Callable
    """`check(real)`: None, or one line saying why its constants do not fit `real`."""
    summary: str
    """Its size and settings in one line, e.g. `8 x 8 grid x 3 actions, replacing traces,
    alpha 3.9, ...`."""
    name: str
    """What it is in a refusal for lack of RAM: `the 6 x 6 x 6 x 6 grid's learner`."""
    smaller: str
    """How to make it smaller, in the same refusal: `a coarser grid (--n)`."""


BLOCK = 1024
"""States evaluated at a time on a grid (bounds the memory of a feature matrix)."""


def _on_grid(axes, values, actions: bool = True) -> np.ndarray:
    """`values(states)` over the grid of `axes`, in blocks of `BLOCK` states."""
    axes = [np.asarray(axis, dtype=np.float64) for axis in axes]
    shape = tuple(len(axis) for axis in axes)
    states = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(axes))
    parts = [values(states[start:start + BLOCK]) for start in range(0, len(states), BLOCK)]
    joined = np.concatenate(parts, axis=0)
    return joined.reshape(shape + joined.shape[1:]) if actions else joined.reshape(shape)


def agent_step(b, first, reward, discount, observation, learn, greedy, arrays):
    """A learner's per-agent step (`Learner.step`), bound by each learner's batch kernel
    and by the compiled loop."""
    raise NotImplementedError("each learner's kernels bind its own step")


def _batch_step(start, stop, first, reward, discount, observation, active, learn, greedy,
                arrays, actions):
    """The learner's `step` for agents `start..stop-1` that are `active`."""
    for b in range(start, stop):
        if active[b]:
            actions[b] = agent_step(b, first[b], reward[b], discount[b], observation[b], learn,
                                    greedy, arrays)


_BATCH_STEPS = {}


def batch_step(learner: Learner):
    """The compiled kernel that runs `learner.step` over a range of a batch."""
    if learner.step is None:
        raise ValueError(f"{learner.name} has no compiled step")
    if learner.name not in _BATCH_STEPS:
        _BATCH_STEPS[learner.name] = kernel(f"{learner.name}_batch_step", _batch_step,
                                            {"agent_step": learner.step})
    return _BATCH_STEPS[learner.name]
