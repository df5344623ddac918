"""The names a Rerun recording of lwrl uses: timelines and entity paths.

Timelines:

- `step` (sequence): the step within an episode; state `t` and Q(s_t, .) are at step t,
  the action taken in state t at step t, its reward, TD error, return and up-time at t + 1.
- `sim_time` (duration, seconds): simulated time of the step, `step * timestep`
  (Mountain-Car: one second per step, its unit of time).
- `episode` (sequence): the episode index. Every per-step row carries its episode too; the
  learning curves are on this timeline only; the value images and an episode's trajectory
  are at their episode and also at step 0 / sim_time 0, so that the `step` timeline shows
  the most recently logged ones.

Several logged episodes share the `step` and `sim_time` axes: their scalar series are
separate entities (overlaid in the plots), while the scene's bodies and the value images,
at fixed paths, show at each step the most recently logged episode that has that step.

Entity paths (`RUN` is `agent{agent}_ep{episode:04d}`, one per logged episode):

- `scene`: the world frame (z up); `scene/world/<geom>` static geometry of the world body;
  `scene/<body>` the pose of each moving body per step (Transform3D), `scene/<body>/<geom>`
  its geometry (static, in the body's frame). Mountain-Car: `scene/world/hill`, the goal and
  the wall, and `scene/car` with `scene/car/body`.
- `signals/state/<variable>/RUN`, `signals/action/RUN`, `signals/control/RUN`,
  `signals/reward/RUN`, `signals/return/RUN`, `signals/td_error/RUN`, `signals/q/RUN`
  (one series per action), `signals/uptime/RUN`: an episode's scalars on `step`,
  `sim_time` and `episode`.
- `value/max_q` (RGB image), `value/greedy_action` (segmentation image),
  `value/centroids` (NRBF centroids, pixel coordinates), `value/state` (the agent's state
  per step), `value/trajectory` (the episode's path over the image).
- `curves/<steps|returns|uptime>/agent<b>` and `.../mean`: learning curves on `episode`.
- A comparison of plants (`lwrl compare --rrd`): `scene/<plant>/<body>` each plant's copy
  of the moving bodies, `signals/state/<variable>/<plant>`, `signals/energy/<plant>` and
  `signals/error/<variable>/<plant>`, on `step` and `sim_time` (episode 0).
"""

STEP = "step"
"""Timeline: the step within an episode (sequence)."""
SIM_TIME = "sim_time"
"""Timeline: simulated seconds within an episode (duration)."""
EPISODE = "episode"
"""Timeline: the episode index (sequence)."""
TIMELINES = (STEP, SIM_TIME, EPISODE)

SCENE = "scene"
"""Root of the 3-D scene: the world frame, z up."""
WORLD = f"{SCENE}/world"
"""The static geometry of the world body."""

SIGNALS = "signals"
STATE = f"{SIGNALS}/state"
ACTION = f"{SIGNALS}/action"
CONTROL = f"{SIGNALS}/control"
REWARD = f"{SIGNALS}/reward"
RETURN = f"{SIGNALS}/return"
TD_ERROR = f"{SIGNALS}/td_error"
Q = f"{SIGNALS}/q"
UPTIME = f"{SIGNALS}/uptime"
ENERGY = f"{SIGNALS}/energy"
"""A comparison of plants: mechanical energy, one series per plant."""
ERROR = f"{SIGNALS}/error"
"""A comparison of plants: |error| of each variable against the reference, per plant."""

VALUE = "value"
MAX_Q = f"{VALUE}/max_q"
GREEDY_ACTION = f"{VALUE}/greedy_action"
CENTROIDS = f"{VALUE}/centroids"
VALUE_STATE = f"{VALUE}/state"
TRAJECTORY = f"{VALUE}/trajectory"

CURVES = "curves"
CURVE_STEPS = f"{CURVES}/steps"
CURVE_RETURNS = f"{CURVES}/returns"
CURVE_UPTIME = f"{CURVES}/uptime"
MEAN = "mean"
"""Leaf of the mean curve over agents."""


def run_name(agent: int, episode: int) -> str:
    """The leaf naming one agent's episode in the `signals/...` paths."""
    return f"agent{int(agent)}_ep{int(episode):04d}"


def body_path(body: str, root: str = SCENE) -> str:
    """The entity of a MuJoCo body (`world` for the world body); `root` is the scene, or a
    plant's copy of it in a comparison (`plant_root`)."""
    return f"{root}/{body}"


def plant_root(plant: str) -> str:
    """The subtree of one plant's bodies in a recording that compares plants."""
    return f"{SCENE}/{plant}"


def state_path(variable: str, run: str) -> str:
    return f"{STATE}/{variable}/{run}"


def agent_curve(kind: str, agent: int) -> str:
    """A learning curve's entity: `kind` is one of the `CURVE_*` paths."""
    return f"{kind}/agent{int(agent)}"


def domain_of(task: str) -> str:
    """`cartpole` of `cartpole.balance` (a bare domain is returned as it is)."""
    return task.split(".")[0]


def domain(task: str):
    """The suite's `Domain` of `DOMAIN.TASK` or of a bare domain."""
    from lwrl import tasks

    return tasks.domain(domain_of(task))


def task_definition(task: str):
    """The suite's `TaskDefinition` of `DOMAIN.TASK`, or of a bare domain that has one task."""
    from lwrl import tasks  # the suite, for the task's variable names and controls

    matches = [pair for pair in tasks.ALL_TASKS if ".".join(pair) == task or pair[0] == task]
    if len(matches) != 1:
        available = ", ".join(".".join(pair) for pair in tasks.ALL_TASKS)
        raise ValueError(f"unknown task {task!r}; available: {available}")
    return tasks.definition(*matches[0])
