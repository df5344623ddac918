"""`lwrl train`: agents trained on a task of the suite, or of dm_control's suite or Gymnasium.

Every setting of the run is a flag generated from the configuration (`runners.config`:
environment, learner and protocol) and from every learner's settings (`agent.LEARNERS`);
unset ones take the task's defaults.
"""

import argparse
import dataclasses
import re
import time

from lwrl import agent as learners
from lwrl import outputs, tasks
from lwrl.adapters import external
from lwrl.cli import fields, output
from lwrl.cli import rerun_options as logging_rerun
from lwrl.runners.config import EnvironmentSettings, LearnerChoice, ProtocolSettings, RunConfig
from lwrl.runners.run import make_agents, memory_needed, run, run_batched
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
        "train", help="train agents of a learner (default: NRBF Sarsa(lambda)) on a task",
        description="Train agents with the task's settings unless told otherwise; print the "
                    "mean and standard error over agents per block of episodes.")
    train.add_argument("task", metavar="DOMAIN.TASK", type=train_task,
                       help="one of: " + ", ".join(tasks.TASK_NAMES) + "; or dmc:DOMAIN.TASK "
                            "(dm_control's suite) or gym:ID (Gymnasium), presets for "
                            + ", ".join(external.EXTERNAL_PRESETS))
    fields.add_fields(train, EnvironmentSettings, title="the task's plant (lwrl's own tasks)")
    fields.add_fields(train, external.ExternalEnvironment, title="dmc: and gym: environments")
    fields.add_fields(train, LearnerChoice, title="the learner")
    fields.add_learner_fields(train, learners.LEARNERS.values(),
                              title="the learner's settings (default: the task's; in brackets: "
                                    "the learners that take each)")
    fields.add_fields(train, ProtocolSettings, title="the protocol")
    files = train.add_argument_group("outputs")
    files.add_argument("--out", metavar="DIR", help="write config.json and episodes.csv here")
    files.add_argument("--save", metavar="PATH", help="save the trained agents (.npz)")
    files.add_argument("--rerun", action="store_true",
                         help="stream episodes to a Rerun viewer (spawned; needs a display)")
    files.add_argument("--rrd", metavar="PATH", help="save episodes to a Rerun recording instead")
    files.add_argument("--log-episodes", default=logging_rerun.DEFAULT_EPISODES, metavar="WHICH",
                         help="episodes to log: every:K, last, best, all or numbers like 1,5,20 "
                              f"(default {logging_rerun.DEFAULT_EPISODES})")
    files.add_argument("--log-agents", default="0", metavar="LIST",
                         help="agents to log, by index (default 0)")
    files.add_argument("--force", action="store_true",
                         help="replace an existing --save or --rrd file and --out run")
    # Let "--actions -1,0,1" and "--low -1.2,-0.07" read as values, not as options.
    train._negative_number_matcher = re.compile(r"^-\.?\d[\d.eE+-]*(,-?\.?\d[\d.eE+-]*)*$")
    train.set_defaults(run=train_agents)


def check_outputs(args) -> None:
    """Every output asked for can be written, before any work: one line and status 2 if not."""
    output.claim_outputs(args, "out", "save", "rrd")
    if args.out:
        outputs.check_directory(args.out, "--out", args.force, names=output.RUN_FILES)
    for flag in ("save", "rrd"):
        if getattr(args, flag, None):
            outputs.check_file(getattr(args, flag), f"--{flag}", args.force)
    if getattr(args, "rerun", False):
        logging_rerun.check_viewer()


def train_agents(args) -> int:
    """Train agents and print per-block means with standard errors; write and save on
    request (also after Ctrl-C, with what was complete)."""
    if external.is_external(args.task):
        return _train_external(args)
    if isinstance(args.actions, tuple):  # `--actions`, not `--action-kind` (the same dest)
        raise ValueError(f"--actions applies to dmc: and gym: environments only; {args.task} "
                         "has its own (--action-kind discrete or continuous)")
    started = time.perf_counter()
    settings = {**fields.given(args, EnvironmentSettings, LearnerChoice, ProtocolSettings),
                **fields.given_learner_settings(args, learners.LEARNERS.values())}
    config = RunConfig(task=args.task, **settings)
    config = dataclasses.replace(config, plant=config.plant_name)  # config.json names it
    check_outputs(args)
    logging = bool(args.rrd or args.rerun)
    record, logged_agents, best = (), [], False
    if logging:
        logged_agents = logging_rerun.parse_agents(args.log_agents, config.agents)
        logged = logging_rerun.episodes_to_log(args.log_episodes, config.episodes)
        best = logged == "best"
        record = [] if best else [(b, episode) for b in logged_agents for episode in logged]
    outputs.check_memory(memory_needed(config, len(record) if not best else len(logged_agents)),
                         f"{plural(config.agents, 'agent')} of {config.task}")
    agent = make_agents(config)  # checks the hyper-parameters before anything runs
    print(f"{config.task} on the {config.plant_name} plant: {plural(config.agents, 'agent')}, "
          f"{config.describe()}, {plural(config.episodes, 'episode')}")
    bar, update = output.progress_bar(config.agents * config.episodes, "training")
    with bar:
        agent, results = run(config, agents=agent, progress=update, record=record)
    if best and not results.interrupted:  # deterministic: run again to record the best episodes
        _, results = run(config, record=logging_rerun.best_episodes(results, logged_agents))
    output.print_results(results, config.seeds, "",
                         tasks.definition(config.domain, config.task_name).has_uptime)
    written = output.Outputs("train")
    if logging:
        episodes = (f"{plural(len(results.recordings), 'episode')} of "
                    f"{'agent' if len(logged_agents) == 1 else 'agents'} "
                    f"{', '.join(map(str, logged_agents))}")

        def record_run():
            if not args.rrd:
                logging_rerun.send_run(config, results, agent, spawn=True)
                print(f"sent the recording to the viewer: {episodes}")
                return []
            with outputs.atomic_path(args.rrd) as temporary:
                logging_rerun.send_run(config, results, agent, rrd_path=temporary,
                                       spawn=args.rerun)
            return [f"the recording {args.rrd} ({episodes})"]
        written.write(f"--rrd {args.rrd}" if args.rrd else "--rerun", record_run)
    output.write_out_and_save(written, args, config, results, agent, "the agents")
    output.done(started, written.written, results.interrupted)
    status = written.report()
    return 130 if results.interrupted else status


def _train_external(args) -> int:
    """`lwrl train` on a dm_control or Gymnasium environment (`lwrl.adapters.external`)."""
    started = time.perf_counter()
    own = {**fields.given(args, EnvironmentSettings), "save": args.save, "rerun": args.rerun,
           "rrd": args.rrd}
    kind = own.pop("actions", None)  # `--action-kind` (a word) and `--actions` share a dest
    if isinstance(kind, str):
        own["action-kind"] = kind
    for name, value in own.items():
        if value:
            raise ValueError(f"--{name} applies to lwrl's own tasks only, not to {args.task}")
    config = external.ExternalConfig(env=args.task, **fields.given(
        args, external.ExternalEnvironment, LearnerChoice, ProtocolSettings),
        **fields.given_learner_settings(args, learners.LEARNERS.values()))
    check_outputs(args)
    config, agent, envs = external.prepare(config)
    actions = (", ".join(f"{value:g}" for value in config.actions) if config.actions
               else f"{agent.action_space.n} discrete")
    print(f"{config.env}: {plural(config.agents, 'agent')}, {config.describe()}, "
          f"actions {actions}, {plural(config.episodes, 'episode')}")
    bar, update = output.progress_bar(config.agents * config.episodes, "training")
    with bar:
        results = run_batched(envs, agent, config.episodes, progress=update)
    output.print_results(results, config.seeds, "", with_uptime=False)
    written = output.Outputs("train")
    if args.out:
        written.write(f"--out {args.out}", lambda: output.write_run(args.out, config, results))
    output.done(started, written.written, results.interrupted)
    status = written.report()
    return 130 if results.interrupted else status
