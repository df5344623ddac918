"""Which training episodes go to Rerun, and sending a run there (`lwrl train --rrd/--rerun`).

`--log-episodes` says which episodes of the logged agents are recorded: `every:K` (the
first and every K-th after it, and the last), `last`, `best` (the highest return; found by
running once, then running again, identically, to record it), `all`, or a comma list of
episode numbers (from 1). `--log-agents` is a comma list of agent indices (default 0).
"""

import numpy as np

from lwrl.agent.learner_contract import NoValues


DEFAULT_EPISODES = "every:20"
"""What `--log-episodes` logs by default: it keeps logging under a tenth of a paper run's
training time (`python -m benchmarks.rerun_logging`)."""


def parse_agents(text: str, agents: int) -> list:
    """Agent indices from `0,3,5`, each below `agents`."""
    try:
        chosen = sorted({int(part) for part in text.split(",")})
    except ValueError:
        chosen = []
    if not chosen or chosen[0] < 0 or chosen[-1] >= agents:
        raise ValueError(f"--log-agents must be agent indices from 0 to {agents - 1}, "
                         f"separated by commas; got {text!r}")
    return chosen


def episodes_to_log(spec: str, episodes: int) -> list | str:
    """Episode indices (from 0) for `spec`, or `"best"` (decided after a first run)."""
    if spec == "best":
        return "best"
    if spec == "last":
        return [episodes - 1]
    if spec == "all":
        return list(range(episodes))
    if spec.startswith("every:"):
        try:
            step = int(spec[len("every:"):])
        except ValueError:
            step = 0
        if step >= 1:
            return sorted(set(range(0, episodes, step)) | {episodes - 1})
    else:
        try:
            chosen = sorted({int(part) - 1 for part in spec.split(",")})
        except ValueError:
            chosen = []
        if chosen and chosen[0] >= 0 and chosen[-1] < episodes:
            return chosen
    raise ValueError(f"--log-episodes must be every:K (K >= 1), last, best, all or episode "
                     f"numbers from 1 to {episodes} separated by commas; got {spec!r}")


def best_episodes(results, agents: list) -> list:
    """`(agent, episode)` of each agent's highest-return episode."""
    return [(agent, int(np.nanargmax(results.returns[agent]))) for agent in agents]


def check_viewer() -> None:
    """`--rerun` needs a viewer that can start here: a one-line error before any work if not."""
    from lwrl.viz import rerun as viz

    if not viz.has_display():
        raise ValueError("--rerun needs a display for the viewer: record with --rrd PATH and "
                         "open it where there is one (lwrl view PATH, or lwrl view --web)")
    try:
        viz.rerun_binary()
    except viz.ViewerUnavailable as error:
        raise ValueError(f"--rerun: {error}") from None


def send_run(config, results, agents, rrd_path=None, spawn: bool = False) -> None:
    """The run's recorded episodes, value functions (through the learner contract, from the
    run's `agents`) and learning curves to Rerun; one line says so where the learner has no
    values to show.

    Episodes go in training order (by episode, then agent), so that where several have a
    step the viewer shows the latest; the recording opens replaying the one logged last."""
    from lwrl.viz import rerun as viz  # Rerun is imported only by the runs that log
    from lwrl.viz import scene

    logged = sorted(results.recordings, key=lambda recording: (recording.episode, recording.agent))
    rec = viz.open_recording("lwrl", rrd_path=rrd_path, spawn=spawn)
    viz.send_blueprint(rec, config.task, replay_steps=logged[-1].steps if logged else None)
    viz.log_task_scene(rec, config.task)
    model = viz.load_model(config.task) if scene.has_model(config.task) else None
    box, with_values = agents.value_box(), True
    if logged and not logged[0].q_values.shape[1]:
        try:
            agents.latest_values()
        except NoValues as error:
            print(f"{error}: the recording has no Q plot")
    for recording in logged:
        viz.log_episode(rec, recording, model=model, value_ranges=box)
        if not with_values:
            continue
        try:
            viz.log_value_function(rec, config.task, agents, recording.weights, recording.episode)
        except NoValues as error:
            print(f"{error}: the recording has no value images")
            with_values = False
    viz.log_learning_curves(rec, results, config.seeds)
    viz.close_recording(rec)
