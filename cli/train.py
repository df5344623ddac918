"""`lwrl train`: agents trained on a task of the suite, or of dm_control's suite or Gymnasium.

Every setting of the run is a flag generated from the configuration (`runners.config`:
environment, agent and protocol); unset ones take the task's defaults.
"""

import argparse
import dataclasses
import re
import time

from lwrl import tasks
from lwrl.adapters import external
from lwrl.agent import io as agent_io
from lwrl.cli import fields, output
from lwrl.cli import rerun_options as logging_rerun
from lwrl.runners.config import AgentSettings, EnvironmentSettings, ProtocolSettings, RunConfig
from lwrl.runners.run import make_agent, run, run_batched
from lwrl.runners.summary import plural


def train_task(name: str) -> str:
    """An argparse type for `lwrl train`'s task: one of the suite's or another suite's."""
    if name in tasks.TASK_NAMES or external.is_external(name):
        return name
    raise argparse.ArgumentTypeError(
        f"invalid choice: {name!r} (choose from {', '.join(tasks.TASK_NAMES)}, or "
        "dmc:DOMAIN.TASK, gym:ID)")


def add_parser(commands) -> None:
    train = commands.add_parser(
        "train", help="train NRBF Sarsa(lambda) agents on a task",
        description="Train agents with the task's settings unless told otherwise; print the "
                    "mean and standard error over agents per block of episodes.")
    train.add_argument("task", metavar="DOMAIN.TASK", type=train_task,
                       help="one of: " + ", ".join(tasks.TASK_NAMES) + "; or dmc:DOMAIN.TASK "
                            "(dm_control's suite) or gym:ID (Gymnasium), presets for "
                            + ", ".join(external.EXTERNAL_PRESETS))
    fields.add_fields(train, EnvironmentSettings, title="the task's plant (lwrl's own tasks)")
    fields.add_fields(train, external.ExternalEnvironment, title="dmc: and gym: environments")
    fields.add_fields(train, AgentSettings, title="the agent (default: the task's)")
    fields.add_fields(train, ProtocolSettings, title="the protocol")
    outputs = train.add_argument_group("outputs")
    outputs.add_argument("--out", metavar="DIR", help="write config.json and episodes.csv here")
    outputs.add_argument("--save", metavar="PATH", help="save the trained agents (.npz)")
    outputs.add_argument("--rerun", action="store_true",
                         help="stream episodes to a Rerun viewer (spawned; needs a display)")
    outputs.add_argument("--rrd", metavar="PATH", help="save episodes to a Rerun recording instead")
    outputs.add_argument("--log-episodes", default=logging_rerun.DEFAULT_EPISODES, metavar="WHICH",
                         help="episodes to log: every:K, last, best, all or numbers like 1,5,20 "
                              f"(default {logging_rerun.DEFAULT_EPISODES})")
    outputs.add_argument("--log-agents", default="0", metavar="LIST",
                         help="agents to log, by index (default 0)")
    # Let "--actions -1,0,1" and "--low -1.2,-0.07" read as values, not as options.
    train._negative_number_matcher = re.compile(r"^-\.?\d[\d.eE+-]*(,-?\.?\d[\d.eE+-]*)*$")
    train.set_defaults(run=train_agents)


def train_agents(args) -> int:
    """Train agents and print per-block means with standard errors; write and save on
    request (also after Ctrl-C, with what was complete)."""
    if external.is_external(args.task):
        return _train_external(args)
    if args.actions is not None:
        raise ValueError(f"--actions applies to dmc: and gym: environments only; {args.task} "
                         "has its own")
    started = time.perf_counter()
    settings = fields.given(args, EnvironmentSettings, AgentSettings, ProtocolSettings)
    settings["plant"] = tasks.resolve(*tasks.split_name(args.task), settings.get("plant"))[1]
    config = RunConfig(task=args.task, **settings)  # config.json names the plant it ran on
    agent = make_agent(config)  # checks the hyper-parameters before anything runs
    logging = bool(args.rrd or args.rerun)
    record, logged_agents, best = (), [], False
    if logging:
        logged_agents = logging_rerun.parse_agents(args.log_agents, config.agents)
        logged = logging_rerun.episodes_to_log(args.log_episodes, config.episodes)
        best = logged == "best"
        record = [] if best else [(b, episode) for b in logged_agents for episode in logged]
    print(f"{config.task} on the {config.plant_name} plant: {plural(config.agents, 'agent')}, "
          f"{config.describe(len(config.ranges[0]))}, {plural(config.episodes, 'episode')}")
    bar, update = output.progress_bar(config.agents * config.episodes, "training")
    with bar:
        agent, results = run(config, agent=agent, progress=update, record=record)
    if best:  # runs are deterministic: run again to record each logged agent's best episode
        _, results = run(config, record=logging_rerun.best_episodes(results, logged_agents))
    output.print_results(results, config.seeds, "",
                         tasks.definition(config.domain, config.task_name).has_uptime)
    written = []
    if logging:
        logging_rerun.send_run(config, results, rrd_path=args.rrd, spawn=args.rerun)
        episodes = (f"{plural(len(results.recordings), 'episode')} of "
                    f"{'agent' if len(logged_agents) == 1 else 'agents'} "
                    f"{', '.join(map(str, logged_agents))}")
        if args.rrd:
            written.append(f"the recording {args.rrd} ({episodes})")
        else:
            print(f"sent the recording to the viewer: {episodes}")
    if args.out:
        written += output.write_run(args.out, config, results)
    if args.save:
        agent_io.save(args.save, agent, {"config": dataclasses.asdict(config)})
        written.append(f"the agents to {args.save}")
    output.done(started, written, results.interrupted)
    return 130 if results.interrupted else 0


def _train_external(args) -> int:
    """`lwrl train` on a dm_control or Gymnasium environment (`lwrl.adapters.external`)."""
    started = time.perf_counter()
    own = {**fields.given(args, EnvironmentSettings), "save": args.save, "rerun": args.rerun,
           "rrd": args.rrd}
    for name, value in own.items():
        if value:
            raise ValueError(f"--{name} applies to lwrl's own tasks only, not to {args.task}")
    config = external.ExternalConfig(env=args.task, **fields.given(
        args, external.ExternalEnvironment, AgentSettings, ProtocolSettings))
    config, agent, envs = external.prepare(config)
    actions = (", ".join(f"{value:g}" for value in config.actions) if config.actions
               else f"{agent.num_actions} discrete")
    print(f"{config.env}: {plural(config.agents, 'agent')}, {config.describe(len(config.low))}, "
          f"actions {actions}, {plural(config.episodes, 'episode')}")
    bar, update = output.progress_bar(config.agents * config.episodes, "training")
    with bar:
        results = run_batched(envs, agent, config.episodes, progress=update)
    output.print_results(results, config.seeds, "", with_uptime=False)
    output.done(started, output.write_run(args.out, config, results) if args.out else [],
                results.interrupted)
    return 130 if results.interrupted else 0
