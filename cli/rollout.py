"""`lwrl rollout`: a uniformly random policy on a task, one line per episode."""

import numpy as np

from lwrl import tasks
from lwrl.cli import fields
from lwrl.runners.config import EnvironmentSettings
from lwrl.runners.summary import plural


def add_parser(commands) -> None:
    rollout = commands.add_parser("rollout", help="run a random policy on a task")
    rollout.add_argument("task", metavar="DOMAIN.TASK", help="one of: " + ", ".join(tasks.TASK_NAMES))
    fields.add_fields(rollout, EnvironmentSettings)
    rollout.add_argument("--steps", type=fields.positive_int, default=1000,
                         help="agent steps (default 1000)")
    rollout.add_argument("--seed", type=fields.non_negative_int, default=0,
                         help="seeds the starts and the policy")
    rollout.set_defaults(run=run)


def run(args) -> None:
    """Run a uniformly random policy and print one line per episode and a summary."""
    domain, task = tasks.split_name(args.task)
    settings = fields.given(args, EnvironmentSettings)
    plant = settings.pop("plant", None)
    env = tasks.load(domain, task, plant=plant, seed=args.seed, **settings)
    rng = np.random.default_rng(args.seed)
    num_actions = env.action_spec().num_values
    plant = tasks.resolve(domain, task, plant)[1]
    print(f"{args.task} on the {plant} plant, random policy, {plural(args.steps, 'step')}, "
          f"seed {args.seed}")
    with_uptime = tasks.definition(domain, task).has_uptime  # else NaN: no column

    def line(number, steps, total, uptime, end) -> str:
        cells = f"{number:>7} {steps:>6} {total:>10}" + (f" {uptime:>11}" if with_uptime else "")
        return f"{cells}  {end}"

    print(line("episode", "steps", "return", "up-time (s)", "end"))
    episodes, ts, total_return = [], env.reset(), 0.0
    for _ in range(args.steps):
        ts = env.step(int(rng.integers(num_actions)))
        total_return += ts.reward
        if ts.last():
            end = "terminal" if ts.discount == 0.0 else "truncated"
            episodes.append((env.task.steps, total_return, env.task.uptime, end))
            print(line(len(episodes), env.task.steps, f"{total_return:.3f}",
                       f"{env.task.uptime:.2f}", end))
            total_return = 0.0
            ts = env.reset()
    if not ts.first():
        print(line(len(episodes) + 1, env.task.steps, f"{total_return:.3f}",
                   f"{env.task.uptime:.2f}", "unfinished"))
    if episodes:
        steps = np.array([e[0] for e in episodes])
        returns = np.array([e[1] for e in episodes])
        print(f"{plural(len(episodes), 'finished episode')}: mean steps {steps.mean():.1f}, "
              f"mean return {returns.mean():.3f}")
    else:
        print("no episode finished within the step budget")
