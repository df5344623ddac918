"""Scalar series: an episode's signals per step, and learning curves across episodes.

Each series is sent whole with one `rr.send_columns` call per entity (per-step `rr.log` costs
about 0.1 ms a call). An episode's series live under `signals/<quantity>/<run>` with `run`
naming the agent and episode, so several logged episodes are separate series that overlay on
the `step` axis instead of interleaving. Learning curves are one series per agent plus the
mean over agents, on the `episode` timeline.
"""

import warnings

import numpy as np
import rerun as rr

from lwrl.tasks.commands import commands
from lwrl.viz import names
from lwrl.viz.columns import episode_indexes, log_static, send


def _style(rec, path: str, label, width: float | None = None) -> None:
    """The series' legend names (and width), static."""
    kwargs = {"names": label}
    if width is not None:
        kwargs["widths"] = width
    log_static(rec, path, rr.SeriesLines(**kwargs))


def _send_scalars(rec, path: str, indexes, values) -> None:
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return
    columns = rr.Scalars.columns(scalars=values.ravel())
    if values.ndim == 2:
        columns = columns.partition(np.full(len(values), values.shape[1]))
    send(rec, path, indexes, columns)


def action_labels(controls) -> list[str]:
    """`u=-10` for each action's control."""
    return [f"u={float(u):+g}" for u in controls]


def signal_paths(recording) -> dict[str, str]:
    """`{quantity: entity path}` of the series `log_signals` sends for a recording (the state
    variables as `state/<name>`; `q` only where the learner has action values,
    `runners.recording.recorded_values`; `td_error` and `uptime` only where they hold
    numbers)."""
    run = names.run_name(recording.agent, recording.episode)
    paths = {f"state/{name}": names.state_path(name, run) for name in recording.state_names}
    paths.update(action=f"{names.ACTION}/{run}", control=f"{names.CONTROL}/{run}",
                 reward=f"{names.REWARD}/{run}", **{"return": f"{names.RETURN}/{run}"})
    if np.shape(recording.q_values)[1]:
        paths["q"] = f"{names.Q}/{run}"
    if np.any(np.isfinite(recording.td_errors)):
        paths["td_error"] = f"{names.TD_ERROR}/{run}"
    if np.any(np.isfinite(recording.uptime)):
        paths["uptime"] = f"{names.UPTIME}/{run}"
    return paths


def log_signals(rec: rr.RecordingStream, recording) -> dict[str, str]:
    """Send an `EpisodeRecording`'s scalars: states and Q (where the learner has action
    values) at steps 0..T; action and control at 0..T-1 (the action taken in state t,
    and the force, torque or thrust it commands); reward, return, TD error and up-time at
    1..T. Returns
    `signal_paths(recording)`. Only Q gets a static style (its series' names): each other
    series takes its entity's name, and the blueprint draws action and control as steps."""
    paths = signal_paths(recording)
    run = names.run_name(recording.agent, recording.episode)
    steps = recording.steps
    # The time columns of the three row sets, built once and shared by the series.
    states_at, actions_at, after = (episode_indexes(at, recording.timestep, recording.episode)
                                    for at in (np.arange(steps + 1), np.arange(steps),
                                               np.arange(1, steps + 1)))
    for j, name in enumerate(recording.state_names):
        _send_scalars(rec, paths[f"state/{name}"], states_at, recording.states[:, j])
    if recording.continuous:  # an action in [-1, 1], its command in the actuator's range
        actions = np.asarray(recording.actions, dtype=np.float64)
        controls = commands(np.broadcast_to(recording.controls, (steps, 2)), actions)
    else:
        actions = np.asarray(recording.actions, dtype=np.int64)
        controls = np.asarray(recording.controls)[actions]
    _send_scalars(rec, paths["action"], actions_at, actions)
    _send_scalars(rec, paths["control"], actions_at, controls)
    _send_scalars(rec, paths["reward"], after, recording.rewards)
    _send_scalars(rec, paths["return"], after, recording.returns)
    # The series are named by their entity's leaf (agent<b>_ep<k>); Q's one per action.
    if "q" in paths:
        _style(rec, paths["q"], [f"Q(s, {a}) {run}" for a in action_labels(recording.controls)])
        _send_scalars(rec, paths["q"], states_at, np.asarray(recording.q_values, dtype=np.float64))
    if "td_error" in paths:
        _send_scalars(rec, paths["td_error"], after, recording.td_errors)
    if "uptime" in paths:
        _send_scalars(rec, paths["uptime"], after, recording.uptime)
    return paths


CURVE_KINDS = {"steps": names.CURVE_STEPS, "returns": names.CURVE_RETURNS, "uptime": names.CURVE_UPTIME}
"""EpisodeResults field -> the entity under which its curves go."""


def _send_curve(rec, path: str, episodes, values) -> bool:
    keep = np.isfinite(values)
    if not keep.any():
        return False
    indexes = [rr.TimeColumn(names.EPISODE, sequence=np.asarray(episodes, dtype=np.int64)[keep])]
    send(rec, path, indexes, rr.Scalars.columns(scalars=np.asarray(values, dtype=np.float64)[keep]))
    return True


def log_learning_curves(rec: rr.RecordingStream, results, seeds=None, first: int = 0) -> list[str]:
    """Send the learning curves of an `EpisodeResults` (arrays `(B, K)`): steps, returns and
    up-time per episode, one series per agent (`curves/<kind>/agent<b>`, named with its seed)
    and the mean over the agents that ran the episode (`curves/<kind>/mean`), on the
    `episode` timeline. Episodes not run (NaN) are left out. `first` skips the episodes
    before it, for sending a growing run piece by piece. Returns the paths sent."""
    sent = []
    for field, kind in CURVE_KINDS.items():
        values = np.asarray(getattr(results, field), dtype=np.float64)
        if values.ndim != 2:
            raise ValueError(f"results.{field} must have shape (B, K); got {values.shape}")
        agents, episodes = values.shape
        if seeds is not None and len(seeds) != agents:
            raise ValueError(f"{len(seeds)} seeds for {agents} agents")
        index = np.arange(first, episodes)
        values = values[:, first:]
        for b in range(agents):
            path = names.agent_curve(kind, b)
            seed = f" (seed {seeds[b]})" if seeds is not None else ""
            if _send_curve(rec, path, index, values[b]):
                _style(rec, path, f"agent {b}{seed}", width=1.0)
                sent.append(path)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # episodes no agent ran
            mean = np.nanmean(values, axis=0) if values.size else values
        path = f"{kind}/{names.MEAN}"
        if _send_curve(rec, path, index, mean):
            _style(rec, path, f"mean of {agents} agents", width=3.0)
            sent.append(path)
    return sent
