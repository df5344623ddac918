"""`lwrl eval`: saved agents run greedily (no exploration, no learning)."""

import time

import numpy as np

from lwrl import tasks
from lwrl.agent import io as agent_io
from lwrl.cli import fields, output
from lwrl.runners.config import RunConfig, as_written_now
from lwrl.runners.run import run
from lwrl.runners.summary import plural


def add_parser(commands) -> None:
    evaluate = commands.add_parser("eval", help="run saved agents greedily")
    evaluate.add_argument("path", metavar="PATH", help="a file written by lwrl train --save")
    evaluate.add_argument("--episodes", type=fields.positive_int, default=10,
                          help="episodes per agent (default 10)")
    evaluate.add_argument("--seed", type=fields.non_negative_int, default=1_000_000,
                          help="seed of the first agent's environment (default 1000000, "
                               "away from training seeds)")
    evaluate.add_argument("--plant", help="evaluate on another plant than the one trained on")
    evaluate.set_defaults(run=evaluate_agents)


def evaluate_agents(args) -> int:
    """Run saved agents greedily and print the same summary as training."""
    started = time.perf_counter()
    agent, metadata = agent_io.load(args.path)
    try:
        settings = dict(as_written_now(metadata["config"]))
        settings.update(episodes=args.episodes, agents=agent.batch_size, seed=args.seed)
        if args.plant:
            settings["plant"] = args.plant
        config = RunConfig(**settings)
    except (KeyError, TypeError) as error:
        raise ValueError(f"{args.path}: no usable run configuration in the file ({error})") from None
    if config.learner != agent.learner.name:
        raise ValueError(f"{args.path} holds {agent.learner.name} agents but names a run of "
                         f"{config.learner}")
    tasks.definition(config.domain, config.task_name, **config.task_options,
                     actions=config.actions).check_fits(agent.dim, agent.action_space, args.path)
    frozen = np.flatnonzero(agent.diverged)
    bar, update = output.progress_bar(config.agents * config.episodes, "evaluating")
    with bar:
        _, results = run(config, agents=agent, learn=False, greedy=True, progress=update)
    output.print_results(results, config.seeds,
                         f"{config.task} on the {config.plant_name} plant: "
                         f"{plural(config.agents, 'saved agent')}, greedy, "
                         f"{plural(config.episodes, 'episode')} each",
                         tasks.definition(config.domain, config.task_name).has_uptime)
    if len(frozen):
        print(f"{len(frozen)} of {plural(agent.batch_size, 'agent')} had diverged in training "
              f"(their weights are not finite or frozen) and were not run: "
              f"{', '.join(map(str, frozen))}")
    output.done(started, interrupted=results.interrupted)
    return 130 if results.interrupted else 0
