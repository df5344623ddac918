"""The `lwrl` command line.

    lwrl tasks                                     list the suite's tasks and plants
    lwrl rollout DOMAIN.TASK [--plant P] [--steps N] [--seed S]
                                                   run a uniformly random policy
    lwrl train DOMAIN.TASK [--trace T] [--alpha A] [--lambda L] [--episodes K] ...
                                                   train NRBF Sarsa(lambda) agents
    lwrl train dmc:DOMAIN.TASK|gym:ID [--obs-range LOW,HIGH ...] [--actions V,V,...] ...
                                                   ... on dm_control's or Gymnasium's
    lwrl eval PATH [--episodes K] [--seed S]       run saved agents greedily
    lwrl reproduce {fig2,fig3,fig5,fig6,fig8,table1,all}... [--plant P] [--quick] [--out DIR]
                                                   the paper's figures and table, and a report
    lwrl compare DOMAIN.TASK [--seeds N] [--episodes K] [--out DIR] [--rrd PATH] [--quick]
                                                   the analytic and MuJoCo plants compared
    lwrl export PATH --c OUT_DIR [--agent I]       a saved agent as a C99 controller
    lwrl view PATH [--web]                         open a Rerun recording of lwrl train --rrd

Bad input ends with one line on standard error and exit status 2.
"""

import argparse
import dataclasses
import os
import re
import sys

import numpy as np
import tqdm

from lwrl import tasks
from lwrl.tasks.integrators import INTEGRATORS
from lwrl.tasks.plants import EQUATIONS
from lwrl.agent import io as agent_io
from lwrl.agent.traces import TRACES
from lwrl.export import c as export_c
from lwrl.adapters import external
from lwrl.cli import rerun_options as logging_rerun
from lwrl.runners import summary
from lwrl.runners.config import PAPER, RunConfig
from lwrl.runners.run import make_agent, run, run_batched


def _split_name(name: str):
    domain, dot, task = name.partition(".")
    if not dot or not task:
        raise ValueError(f"task must be written DOMAIN.TASK, one of: "
                         f"{', '.join(f'{d}.{t}' for d, t in tasks.ALL_TASKS)}; got {name!r}")
    return domain, task


def _integer_at_least(minimum: int, meaning: str):
    """An argparse type for integers >= `minimum`, named `meaning` in its error."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be a {meaning} integer; got {text!r}")
        return value
    return parse


_positive_int = _integer_at_least(1, "positive")
_non_negative_int = _integer_at_least(0, "non-negative")


def _reading(text: str) -> tuple:
    """`NAME=VALUE` of `--set`: VALUE `none`, a number, numbers separated by commas (a tuple)
    or a word."""
    name, equals, value = text.partition("=")
    if not equals or not name or not value:
        raise argparse.ArgumentTypeError(f"must be NAME=VALUE (e.g. r2=0.05, epsilon=0, "
                                         f"track_limit=none, centroids=edges); got {text!r}")
    if value.lower() == "none":
        return name, None
    try:
        numbers = tuple(float(part) for part in value.split(","))
    except ValueError:
        return name, value
    return name, numbers if len(numbers) > 1 else numbers[0]


def _train_task(name: str) -> str:
    """An argparse type for `lwrl train`'s task: one of the suite's or another suite's."""
    if name in PAPER or external.is_external(name):
        return name
    raise argparse.ArgumentTypeError(f"invalid choice: {name!r} (choose from {', '.join(PAPER)}, "
                                     "or dmc:DOMAIN.TASK, gym:ID)")


def _numbers(text: str) -> tuple:
    """An argparse type for comma-separated numbers."""
    try:
        values = tuple(float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be comma-separated numbers; got {text!r}") from None
    if not all(map(np.isfinite, values)):
        raise argparse.ArgumentTypeError(f"must be finite numbers; got {text!r}")
    return values


def _range(text: str) -> tuple:
    """An argparse type for one observation range `LOW,HIGH` with LOW < HIGH."""
    values = _numbers(text)
    if len(values) != 2 or values[0] >= values[1]:
        raise argparse.ArgumentTypeError(f"must be LOW,HIGH with LOW < HIGH; got {text!r}")
    return values


def cmd_tasks(args) -> None:
    """Print every task with its plants, the default first."""
    del args
    for domain, task in tasks.ALL_TASKS:
        print(f"{domain}.{task:<12} plants: {', '.join(tasks.PLANTS[domain])}")


def cmd_rollout(args) -> None:
    """Run a uniformly random policy and print one line per episode and a summary."""
    domain, task = _split_name(args.task)
    options = {name: getattr(args, name) for name in ("integrator", "equations")
               if getattr(args, name)}
    env = tasks.load(domain, task, plant=args.plant, seed=args.seed, **options)
    rng = np.random.default_rng(args.seed)
    num_actions = env.action_spec().num_values
    plant = args.plant or tasks.PLANTS[domain][0]
    print(f"{args.task} on the {plant} plant, random policy, {args.steps} steps, seed {args.seed}")
    print(f"{'episode':>7} {'steps':>6} {'return':>10} {'uptime_s':>9}  end")
    episodes, ts, total_return = [], env.reset(), 0.0
    for _ in range(args.steps):
        ts = env.step(int(rng.integers(num_actions)))
        total_return += ts.reward
        if ts.last():
            end = "terminal" if ts.discount == 0.0 else "truncated"
            episodes.append((env.task.steps, total_return, env.task.uptime, end))
            print(f"{len(episodes):>7} {env.task.steps:>6} {total_return:>10.3f} "
                  f"{env.task.uptime:>9.2f}  {end}")
            total_return = 0.0
            ts = env.reset()
    if not ts.first():
        print(f"{len(episodes) + 1:>7} {env.task.steps:>6} {total_return:>10.3f} "
              f"{env.task.uptime:>9.2f}  unfinished")
    if episodes:
        steps = np.array([e[0] for e in episodes])
        returns = np.array([e[1] for e in episodes])
        print(f"{len(episodes)} finished episodes: mean steps {steps.mean():.1f}, "
              f"mean return {returns.mean():.3f}")
    else:
        print("no episode finished within the step budget")


def _report(results, seeds, title: str, with_uptime: bool) -> None:
    """Print a run's block table, its divergences and any interruption."""
    if title:
        print(title)
    print(summary.format_rows(summary.block_rows(results), with_uptime))
    print(f"means ± standard errors over agents (seeds {seeds[0]}..{seeds[-1]})")
    print(summary.divergence_note(results, seeds))
    truncated, run_episodes = int(results.truncated.sum()), int(np.isfinite(results.steps).sum())
    if truncated:
        print(f"{truncated} of {run_episodes} episodes ended at the time limit (truncated)")
    if results.interrupted:
        print("interrupted: episodes not run are left empty", file=sys.stderr)


def _progress_bar(total: int, description: str):
    bar = tqdm.tqdm(total=total, desc=description, unit="episode", file=sys.stderr,
                    disable=None, leave=False)
    return bar, bar.update


def _write_run(out: str, config, results) -> None:
    """`--out DIR`: the run's config.json and episodes.csv."""
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "config.json"), "w") as file:
        file.write(config.to_json() + "\n")
    summary.write_csv(os.path.join(out, "episodes.csv"), results, config.seeds)
    print(f"wrote {out}/config.json and {out}/episodes.csv")


def cmd_train(args) -> int:
    """Train agents and print per-block means with standard errors; write and save on
    request (also after Ctrl-C, with what was complete)."""
    if external.is_external(args.task):
        return _train_external(args)
    if args.obs_range or args.actions:
        raise ValueError("--obs-range and --actions apply to dmc: and gym: environments only; "
                         f"{args.task} has its own")
    config = RunConfig(task=args.task, plant=args.plant, integrator=args.integrator,
                       equations=args.equations, trace=args.trace, alpha=args.alpha,
                       lam=args.lam, epsilon=args.epsilon,
                       features=args.features, n=args.n, episodes=args.episodes,
                       agents=args.agents, seed=args.seed,
                       **({} if args.gamma is None else {"gamma": args.gamma}))
    config.plant = tasks.resolve(config.domain, config.task_name, config.plant)[1]
    agent = make_agent(config)  # checks the hyper-parameters before anything runs
    logging = bool(args.rrd or args.rerun)
    record, logged_agents, best = (), [], False
    if logging:
        logged_agents = logging_rerun.parse_agents(args.log_agents, config.agents)
        logged = logging_rerun.episodes_to_log(args.log_episodes, config.episodes)
        best = logged == "best"
        record = [] if best else [(b, episode) for b in logged_agents for episode in logged]
    print(f"{config.task} on the {config.plant} plant: {config.agents} agents, {config.trace} "
          f"traces, alpha {config.alpha:g}, lambda {config.lam:g}, epsilon {config.epsilon:g}, "
          f"{config.features} {config.n}^{len(config.feature_map().low)}, "
          f"{config.episodes} episodes")
    bar, update = _progress_bar(config.agents * config.episodes, "training")
    with bar:
        agent, results = run(config, agent=agent, progress=update, record=record)
    if best:  # runs are deterministic: run again to record each logged agent's best episode
        _, results = run(config, record=logging_rerun.best_episodes(results, logged_agents))
    _report(results, config.seeds, "", tasks.definition(config.domain, config.task_name).has_uptime)
    if logging:
        logging_rerun.send_run(config, results, rrd_path=args.rrd, spawn=args.rerun)
        where = f"saved the recording to {args.rrd}" if args.rrd else "sent the recording"
        print(f"{where}: {len(results.recordings)} episodes of agents "
              f"{', '.join(map(str, logged_agents))}")
    if args.out:
        _write_run(args.out, config, results)
    if args.save:
        agent_io.save(args.save, agent, {"config": dataclasses.asdict(config)})
        print(f"saved the agents to {args.save}")
    return 130 if results.interrupted else 0


def _train_external(args) -> int:
    """`lwrl train` on a dm_control or Gymnasium environment (`lwrl.adapters.external`)."""
    for flag, given in (("--plant", args.plant), ("--features cmac", args.features != "nrbf"),
                        ("--save", args.save), ("--rerun", args.rerun), ("--rrd", args.rrd)):
        if given:
            raise ValueError(f"{flag} applies to lwrl's own tasks only, not to {args.task}")
    low, high = zip(*args.obs_range) if args.obs_range else (None, None)
    config = external.ExternalConfig(
        env=args.task, low=low, high=high, actions=args.actions, n=args.n, trace=args.trace,
        alpha=args.alpha, lam=args.lam, epsilon=args.epsilon, gamma=args.gamma,
        episodes=args.episodes, agents=args.agents, seed=args.seed)
    config, agent, envs = external.prepare(config)
    actions = (", ".join(f"{value:g}" for value in config.actions) if config.actions
               else f"{agent.num_actions} discrete")
    print(f"{config.env}: {config.agents} agents, {config.trace} traces, alpha {config.alpha:g}, "
          f"lambda {config.lam:g}, epsilon {config.epsilon:g}, gamma {config.gamma:g}, "
          f"nrbf {config.n}^{len(config.low)}, actions {actions}, {config.episodes} episodes")
    bar, update = _progress_bar(config.agents * config.episodes, "training")
    with bar:
        results = run_batched(envs, agent, config.episodes, progress=update)
    _report(results, config.seeds, "", with_uptime=False)
    if args.out:
        _write_run(args.out, config, results)
    return 130 if results.interrupted else 0


def cmd_eval(args) -> int:
    """Run saved agents greedily (epsilon 0, no learning) and print the same summary."""
    agent, metadata = agent_io.load(args.path)
    try:
        fields = dict(metadata["config"])
        fields.update(episodes=args.episodes, agents=agent.batch_size, seed=args.seed)
        if args.plant:
            fields["plant"] = args.plant
        config = RunConfig(**fields)
    except (KeyError, TypeError) as error:
        raise ValueError(f"{args.path}: no usable run configuration in the file ({error})") from None
    agent.hyper.epsilon[:] = 0.0
    bar, update = _progress_bar(config.agents * config.episodes, "evaluating")
    with bar:
        _, results = run(config, agent=agent, learn=False, progress=update)
    _report(results, config.seeds,
            f"{config.task} on the {config.plant} plant: {config.agents} saved agents, greedy",
            tasks.definition(config.domain, config.task_name).has_uptime)
    return 130 if results.interrupted else 0


def _paper_extra_missing(command: str, error: ImportError) -> ValueError:
    """The one-line error of a command whose 'paper' extra (pandas, matplotlib) is missing."""
    return ValueError(f"lwrl {command} needs the 'paper' extra ({error.name} is missing): "
                      "pip install -e '.[paper]'")


def cmd_reproduce(args) -> int:
    """Run the paper's protocols (resuming whatever an earlier run finished) and report."""
    try:
        from lwrl.studies.paper.reproduce import reproduce
    except ImportError as error:
        raise _paper_extra_missing("reproduce", error) from None
    path = reproduce(args.item, args.out, plant=args.plant, quick=args.quick,
                     integrator=args.integrator, backend=args.backend, workers=args.workers,
                     address=args.address, readings=dict(args.readings), alphas=args.alphas)
    print(f"wrote {path}, the figures in {os.path.join(args.out, 'figures')} and each item's "
          f"results under {args.out}")
    return 0


def cmd_compare(args) -> int:
    """Compare the plants of a task open loop, closed loop and in transfer; write a report."""
    try:
        from lwrl.studies.compare import closed_loop
        from lwrl.studies.compare import comparison as compare
    except ImportError as error:
        raise _paper_extra_missing("compare", error) from None
    compare.check_task(args.task)
    episodes = compare.QUICK["episodes"] if args.quick else args.episodes
    total = closed_loop.total_episodes(args.task, args.seeds, episodes,
                                       compare.QUICK["eval_episodes"] if args.quick else None)
    print(f"comparing the plants of {args.task} with seeds 0..{args.seeds - 1}"
          f"{' (quick)' if args.quick else ''}")
    bar, update = _progress_bar(total, "closed loop")
    with bar:
        result = compare.compare(args.task, seeds=args.seeds, episodes=args.episodes,
                                 out_dir=args.out, rrd_path=args.rrd, quick=args.quick,
                                 progress=update)
    print(f"wrote {result.report_path}, the tables and figures under {args.out}"
          + (f" and the recording {args.rrd}" if args.rrd else ""))
    print("wall time: " + ", ".join(f"{part} {seconds:.0f} s" for part, seconds in result.timings.items()))
    return 0


def cmd_view(args) -> int:
    """Open a saved Rerun recording in the viewer, or serve the web viewer on 127.0.0.1."""
    from lwrl.viz import rerun as viz

    try:
        return viz.view(args.path, web=args.web, web_port=args.port)
    except FileNotFoundError as error:
        raise ValueError(str(error)) from None
    except viz.ViewerUnavailable as error:
        raise ValueError(str(error)) from None


def cmd_export(args) -> int:
    """Write a saved agent as C99 source and header; report its flash size and speed."""
    written = export_c.export_c(args.path, args.c, agent_index=args.agent, dtype=args.real)
    print(f"wrote {written['source']} and {written['header']}: {written['task']}, "
          f"{written['weight_bytes']} bytes of weights and {written['constant_bytes']} of constants")
    try:
        measured = export_c.measure(args.c)
    except ValueError as error:
        print(f"not measured: {error}")
        return 0
    print(f"compiled with {measured['compiler']}: {measured['code_bytes']} bytes of code (-Os), "
          f"{measured['rodata_bytes']} of read-only data; "
          f"{measured['ns_per_decision']:.0f} ns per decision (-O2, this machine)")
    return 0


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line: `lwrl COMMAND: error: ...`."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def _add_train_arguments(train) -> None:
    train.add_argument("task", metavar="DOMAIN.TASK", type=_train_task,
                       help="one of: " + ", ".join(PAPER) + "; or dmc:DOMAIN.TASK (dm_control's "
                            "suite) or gym:ID (Gymnasium), presets for "
                            + ", ".join(external.EXTERNAL_PRESETS))
    train.add_argument("--plant", help="mujoco or analytic (default: the domain's first)")
    train.add_argument("--integrator", choices=INTEGRATORS,
                       default="semi_implicit", help="Euler scheme of the analytic plant")
    train.add_argument("--equations", choices=EQUATIONS, default="paper",
                       help="the analytic plant's equations: the paper's, or kfnnet with the "
                            "author's code's suspected slips")
    train.add_argument("--trace", choices=TRACES, help="trace rule (default: the paper's best)")
    train.add_argument("--alpha", type=float, help="learning rate (default: the paper's best)")
    train.add_argument("--lambda", dest="lam", type=float, help="trace decay (default: the paper's best)")
    train.add_argument("--epsilon", type=float, help="exploration rate (default: SPEC.md's per task)")
    train.add_argument("--features", choices=("nrbf", "cmac"), default="nrbf")
    train.add_argument("--n", "--centroids", dest="n", type=_positive_int,
                       help="NRBF centroids (or CMAC intervals) per dimension")
    train.add_argument("--gamma", type=float, help="discount rate (default: 1, or the "
                       "environment's preset)")
    train.add_argument("--obs-range", action="append", type=_range, metavar="LOW,HIGH",
                       help="dmc:/gym: only: the NRBF range of one observation dimension, given "
                            "once per dimension in order (default: the preset, or the "
                            "observation space's finite bounds)")
    train.add_argument("--actions", type=_numbers, metavar="V,V,...",
                       help="dmc:/gym: only: values a continuous action is discretised into")
    train.add_argument("--episodes", type=_positive_int, help="episodes per agent")
    train.add_argument("--agents", type=_positive_int, help="agents (seeds SEED, SEED+1, ...)")
    train.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the first agent")
    train.add_argument("--out", metavar="DIR", help="write config.json and episodes.csv here")
    train.add_argument("--save", metavar="PATH", help="save the trained agents (.npz)")
    train.add_argument("--rerun", action="store_true",
                       help="stream episodes to a Rerun viewer (spawned; needs a display)")
    train.add_argument("--rrd", metavar="PATH", help="save episodes to a Rerun recording instead")
    train.add_argument("--log-episodes", default=logging_rerun.DEFAULT_EPISODES, metavar="WHICH",
                       help="episodes to log: every:K, last, best, all or numbers like 1,5,20 "
                            f"(default {logging_rerun.DEFAULT_EPISODES})")
    train.add_argument("--log-agents", default="0", metavar="LIST",
                       help="agents to log, by index (default 0)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="lwrl", description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    listing = commands.add_parser("tasks", help="list the suite's tasks and their plants")
    listing.set_defaults(run=cmd_tasks)

    rollout = commands.add_parser("rollout", help="run a random policy on a task")
    rollout.add_argument("task", metavar="DOMAIN.TASK", help="e.g. cartpole.balance")
    rollout.add_argument("--plant", help="mujoco or analytic (default: the domain's first)")
    rollout.add_argument("--integrator", choices=INTEGRATORS,
                         help="Euler scheme of the analytic plant (default semi_implicit)")
    rollout.add_argument("--equations", choices=EQUATIONS,
                         help="the analytic plant's equations (default paper)")
    rollout.add_argument("--steps", type=_positive_int, default=1000, help="agent steps (default 1000)")
    rollout.add_argument("--seed", type=int, default=0, help="seeds the starts and the policy")
    rollout.set_defaults(run=cmd_rollout)

    train = commands.add_parser(
        "train", help="train NRBF Sarsa(lambda) agents on a task",
        description="Train agents with the paper's settings unless told otherwise; print the "
                    "mean and standard error over agents per block of episodes.")
    _add_train_arguments(train)
    # Let "--actions -1,0,1" and "--obs-range -1.2,0.6" read as values, not as options.
    train._negative_number_matcher = re.compile(r"^-\.?\d[\d.eE+-]*(,-?\.?\d[\d.eE+-]*)*$")
    train.set_defaults(run=cmd_train)

    evaluate = commands.add_parser("eval", help="run saved agents greedily")
    evaluate.add_argument("path", metavar="PATH", help="a file written by lwrl train --save")
    evaluate.add_argument("--episodes", type=_positive_int, default=10, help="episodes per agent (default 10)")
    evaluate.add_argument("--seed", type=_non_negative_int, default=1_000_000,
                          help="seed of the first agent's environment (default 1000000, "
                               "away from training seeds)")
    evaluate.add_argument("--plant", help="evaluate on another plant than the one trained on")
    evaluate.set_defaults(run=cmd_eval)

    paper = commands.add_parser(
        "reproduce", help="reproduce the paper's figures and table",
        description="Run the paper's protocols, writing each run as it finishes (the same "
                    "command resumes an interrupted run), then the figures and a report "
                    "beside the paper's numbers.")
    paper.add_argument("item", nargs="+", choices=("fig2", "fig3", "fig5", "fig6", "fig8", "table1", "all"),
                       help="one or more items, or all")
    paper.add_argument("--plant", choices=("analytic", "mujoco"), default="analytic",
                       help="plant of the pendulum and cart-pole (Mountain-Car has only the analytic one)")
    paper.add_argument("--integrator", choices=INTEGRATORS, default="semi_implicit",
                       help="Euler scheme of the analytic plant")
    paper.add_argument("--set", metavar="NAME=VALUE", type=_reading, action="append", default=[],
                       dest="readings",
                       help="a reading of an open point for every run that has it (repeatable): "
                            "r2=0.05, epsilon=0, centroids=edges, low=A,B,.., high=A,B,.., "
                            "equations=kfnnet or a task option such as track_limit=none")
    paper.add_argument("--alphas", metavar="A,A,...", type=_numbers,
                       help="the NRBF runs' alpha grid instead of the items' own (the CMAC "
                            "baseline keeps its grid)")
    paper.add_argument("--quick", action="store_true", help="tiny grids: a smoke test in seconds")
    paper.add_argument("--out", metavar="DIR", default="reproduction", help="output directory (default: reproduction)")
    paper.add_argument("--workers", type=_positive_int, help="threads of the local backend (default: all cores)")
    paper.add_argument("--backend", choices=("local", "ray"), default="local")
    paper.add_argument("--address", help="Ray cluster address (default: start a local Ray instance)")
    paper.set_defaults(run=cmd_reproduce)

    comparison = commands.add_parser(
        "compare", help="compare the analytic and MuJoCo plants of a task",
        description="Open loop (divergence from an RK4 reference, energy drift), closed loop "
                    "(the paper's agent learning on each plant) and transfer (trained on one "
                    "plant, run greedily on the others), written as a report with figures.")
    comparison.add_argument("task", metavar="DOMAIN.TASK",
                            help="a task with a MuJoCo plant: pendulum.swingup or cartpole.balance")
    comparison.add_argument("--seeds", type=_positive_int, default=10,
                            help="open-loop trials and agents per plant, seeds 0..N-1 (default 10)")
    comparison.add_argument("--episodes", type=_positive_int,
                            help="training episodes per agent (default: the paper's)")
    comparison.add_argument("--out", metavar="DIR", default="compare", help="output directory (default: compare)")
    comparison.add_argument("--rrd", metavar="PATH",
                            help="save a Rerun recording of the plants' trajectories from one start")
    comparison.add_argument("--quick", action="store_true", help="short horizons: a smoke test in seconds")
    comparison.set_defaults(run=cmd_compare)

    view = commands.add_parser("view", help="open a saved Rerun recording")
    view.add_argument("path", metavar="PATH", help="an .rrd file (lwrl train --rrd)")
    view.add_argument("--web", action="store_true",
                      help="serve the web viewer on http://127.0.0.1 instead of a native window")
    view.add_argument("--port", type=_positive_int, help="web viewer port (default 9090)")
    view.set_defaults(run=cmd_view)

    export = commands.add_parser("export", help="write a saved agent as a C99 controller")
    export.add_argument("path", metavar="PATH", help="a file written by lwrl train --save")
    export.add_argument("--c", metavar="OUT_DIR", required=True,
                        help="directory for lwrl_policy.c and lwrl_policy.h")
    export.add_argument("--agent", type=_non_negative_int, default=0,
                        help="which agent of the saved batch (default 0)")
    export.add_argument("--real", choices=("float", "double"), default="float",
                        help="C floating-point type of the weights and arithmetic")
    export.set_defaults(run=cmd_export)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.run(args) or 0
    except ValueError as error:
        print(f"lwrl {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"lwrl {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
