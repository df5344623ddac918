"""The `lwrl` command line.

    lwrl tasks                                     list the suite's tasks and plants
    lwrl rollout DOMAIN.TASK [--plant P] [--steps N] [--seed S]
                                                   run a uniformly random policy

Bad input ends with one line on standard error and exit status 2.
"""

import argparse
import sys

import numpy as np

import tasks


def _split_name(name: str):
    domain, dot, task = name.partition(".")
    if not dot or not task:
        raise ValueError(f"task must be written DOMAIN.TASK, one of: "
                         f"{', '.join(f'{d}.{t}' for d, t in tasks.ALL_TASKS)}; got {name!r}")
    return domain, task


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer; got {text!r}")
    return value


def cmd_tasks(args) -> None:
    """Print every task with its plants, the default first."""
    del args
    for domain, task in tasks.ALL_TASKS:
        print(f"{domain}.{task:<12} plants: {', '.join(tasks.PLANTS[domain])}")


def cmd_rollout(args) -> None:
    """Run a uniformly random policy and print one line per episode and a summary."""
    domain, task = _split_name(args.task)
    options = {"integrator": args.integrator} if args.integrator else {}
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


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line: `lwrl COMMAND: error: ...`."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="lwrl", description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    listing = commands.add_parser("tasks", help="list the suite's tasks and their plants")
    listing.set_defaults(run=cmd_tasks)

    rollout = commands.add_parser("rollout", help="run a random policy on a task")
    rollout.add_argument("task", metavar="DOMAIN.TASK", help="e.g. cartpole.balance")
    rollout.add_argument("--plant", help="mujoco or analytic (default: the domain's first)")
    rollout.add_argument("--integrator", choices=("semi_implicit", "explicit"),
                         help="Euler scheme of the analytic plant (default semi_implicit)")
    rollout.add_argument("--steps", type=_positive_int, default=1000, help="agent steps (default 1000)")
    rollout.add_argument("--seed", type=int, default=0, help="seeds the starts and the policy")
    rollout.set_defaults(run=cmd_rollout)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        args.run(args)
    except ValueError as error:
        print(f"lwrl {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"lwrl {args.command}: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
