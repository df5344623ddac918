"""`lwrl rollout`: a uniformly random policy on a task, one line per episode."""

import numpy as np

from lwrl import tasks
from lwrl.cli import fields
from lwrl.runners.config import EnvironmentSettings


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
