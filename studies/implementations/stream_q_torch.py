"""The authors' stream-Q(lambda) (Elsayed, Vasan & Mahmood 2024, arXiv:2410.14606;
`mohmdelsayed/streaming-drl` at commit 407dca7, PyTorch) on one of lwrl's tasks through its
Gymnasium face (`lwrl.gym`), one agent per seed, one after another: the reference the JAX
population `stream_q` (`agent.stream_q`) is compared with (`stream_q_report`).

    python -m lwrl.studies.implementations.stream_q_torch --authors PATH/streaming-drl \\
        --env-id lwrl/mountain_car-cost_to_go-analytic-v0 --timesteps 100000 --seeds 0-9 \\
        --out docs/implementations/stream_q/torch.json.gz

The authors' code is licensed CC BY-NC 4.0, which lwrl's Apache-2.0 cannot take in: it is not
copied here but imported from a checkout (`--authors`, a clone at 407dca7), and run as it is:
its `StreamQ` (ObGD, sparse initialisation, layer normalisation without learned parameters,
the epsilon schedule, Watkins' trace reset) and its wrappers (`NormalizeObservation`,
`ScaleReward`). Only the glue of its script's `main` is written here, as `main` does it --
`torch.manual_seed(seed)`, `np.random.seed(seed)`, the environment made and wrapped
(`FlattenObservation`, `RecordEpisodeStatistics`, `ScaleReward`, `NormalizeObservation`),
then `StreamQ`, `reset(seed=seed)`, and per step `sample_action`, `env.step`,
`update_params(s, a, r, s', terminated or truncated, is_nongreedy)` -- with two departures,
both to give it lwrl's task as lwrl's `stream_q` sees it:

- the environment keeps the task's own time limit (`gymnasium.make(env_id)`), where `main`
  sets `max_episode_steps=10_000` (the same on Mountain-Car and the acrobot);
- no `AddTimeInfo`: the observation is the task's, without the elapsed-time feature, as
  lwrl's `stream_q` has it (and Gymnasium 1.x wrappers no longer forward `num_envs`, which
  `AddTimeInfo` reads).

PyTorch runs on one thread (`torch.set_num_threads(1)`): the networks are 32 x 32, and the
machine's other cores are the other agents'. Per agent the record is its episodes' lengths and end steps, and their returns in the task's
own rewards (`RecordEpisodeStatistics` sits below the reward scaling, as in `main`).
"""

import argparse
import gzip
import importlib
import importlib.util
import json
import os
import platform
import sys
import time

AUTHORS_COMMIT = "407dca7a8b584c1c20bc649053557f66e270b1e6"
"""The commit of `mohmdelsayed/streaming-drl` the runs used."""

SETTINGS = {"learning_rate": 1.0, "gamma": 0.99, "lam": 0.8, "kappa": 2.0,
            "exploration_initial_eps": 1.0, "exploration_final_eps": 0.01,
            "exploration_fraction": 0.05, "net_arch": "32,32", "sparsity": 0.9}
"""The authors' defaults (their `stream_q.py`'s arguments; the network's widths and sparsity
fixed in its `StreamQ`), by the names of lwrl's `StreamQSettings`."""
ARGUMENTS = {"learning_rate": "lr", "gamma": "gamma", "lam": "lamda", "kappa": "kappa_value",
             "exploration_initial_eps": "epsilon_start",
             "exploration_final_eps": "epsilon_target",
             "exploration_fraction": "exploration_fraction"}
"""The settings `StreamQ` takes as arguments: lwrl's name to theirs."""


AUTHORS_SCRIPT = "stream_q.py"
"""The authors' file of `StreamQ` and its main (beside it `optim.py`, `sparse_init.py`,
`normalization_wrappers.py`, which it imports by bare name)."""


def authors_modules(path: str):
    """The authors' script and `normalization_wrappers` module, imported from the checkout
    at `path` (its directory put first on `sys.path`, as running the script there would)."""
    sys.path.insert(0, os.path.abspath(path))
    wrappers = importlib.import_module("normalization_wrappers")
    spec = importlib.util.spec_from_file_location("streaming_drl_script",
                                                  os.path.join(path, AUTHORS_SCRIPT))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module, wrappers


def run_agent(script, wrappers, env_id: str, seed: int, timesteps: int) -> dict:
    """One agent of the authors' stream-Q(lambda) at their defaults for `timesteps` steps
    (the module's glue): its episodes' `lengths`, `ends` (the step each ended at, counted
    from 1) and `returns`, and its `seconds` of wall time."""
    import gymnasium
    import numpy as np
    import torch

    import lwrl.gym  # noqa: F401  (registers the ids)
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    np.random.seed(seed)
    env = gymnasium.make(env_id)
    env = gymnasium.wrappers.FlattenObservation(env)
    env = gymnasium.wrappers.RecordEpisodeStatistics(env)
    env = wrappers.ScaleReward(env, gamma=SETTINGS["gamma"])
    env = wrappers.NormalizeObservation(env)
    arguments = {argument: SETTINGS[name] for name, argument in ARGUMENTS.items()}
    agent = script.StreamQ(n_obs=env.observation_space.shape[0], n_actions=env.action_space.n,
                           total_steps=timesteps, **arguments)
    lengths, ends, returns = [], [], []
    start = time.perf_counter()
    s, _ = env.reset(seed=seed)
    for t in range(1, timesteps + 1):
        a, is_nongreedy = agent.sample_action(s)
        s_prime, r, terminated, truncated, info = env.step(a)
        agent.update_params(s, a, r, s_prime, terminated or truncated, is_nongreedy)
        s = s_prime
        if terminated or truncated:
            lengths.append(int(np.asarray(info["episode"]["l"]).item()))
            returns.append(float(np.asarray(info["episode"]["r"]).item()))
            ends.append(t)
            s, _ = env.reset()
    env.close()
    return {"seed": seed, "lengths": lengths, "ends": ends, "returns": returns,
            "seconds": time.perf_counter() - start}


def seeds_of(text: str) -> list:
    """`0-9` or `0,3,5` as a list of seeds (an `argparse` type)."""
    try:
        if "-" in text:
            first, last = (int(part) for part in text.split("-"))
            seeds = list(range(first, last + 1))
        else:
            seeds = [int(part) for part in text.split(",")]
    except ValueError:
        seeds = []
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"seeds are a range FIRST-LAST or a comma-separated "
                                         f"list of numbers >= 0, not {text!r}")
    return seeds


def load(path: str) -> dict:
    """The document `main` writes (gzipped JSON)."""
    with gzip.open(path, "rt") as file:
        return json.load(file)


def save(path: str, document: dict) -> None:
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with gzip.open(path + ".tmp", "wt") as file:
        json.dump(document, file)
    os.replace(path + ".tmp", path)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--authors", required=True,
                        help="a checkout of mohmdelsayed/streaming-drl at 407dca7")
    parser.add_argument("--env-id", required=True, help="an id of lwrl.gym.ENV_IDS")
    parser.add_argument("--timesteps", type=int, default=100_000)
    parser.add_argument("--seeds", type=seeds_of, default="0-9")
    parser.add_argument("--out", required=True, help="the gzipped JSON to write (resumes it)")
    args = parser.parse_args(argv)
    if args.timesteps < 1:
        parser.error(f"--timesteps must be a positive number of steps, not {args.timesteps}")
    if not os.path.isfile(os.path.join(args.authors, AUTHORS_SCRIPT)):
        parser.error(f"--authors {args.authors!r} holds no {AUTHORS_SCRIPT}: give a checkout "
                     f"of mohmdelsayed/streaming-drl at {AUTHORS_COMMIT[:7]}")
    from lwrl import gym as lwrl_gym
    if args.env_id not in lwrl_gym.ENV_IDS:
        parser.error(f"--env-id {args.env_id!r} is not one of lwrl's ids of discrete actions "
                     f"on a named plant: "
                     f"{', '.join(lwrl_gym.ENV_IDS)}")
    script, wrappers = authors_modules(args.authors)
    import torch
    document = {"env_id": args.env_id, "timesteps": args.timesteps, "settings": SETTINGS,
                "authors": f"mohmdelsayed/streaming-drl at {AUTHORS_COMMIT}",
                "torch": torch.__version__, "python": platform.python_version(), "agents": []}
    if os.path.isfile(args.out):
        kept = load(args.out)
        if (kept["env_id"], kept["timesteps"]) == (args.env_id, args.timesteps):
            document["agents"] = kept["agents"]
    done = {agent["seed"] for agent in document["agents"]}
    for seed in args.seeds:
        if seed in done:
            continue
        agent = run_agent(script, wrappers, args.env_id, seed, args.timesteps)
        document["agents"].append(agent)
        document["agents"].sort(key=lambda a: a["seed"])
        save(args.out, document)
        print(f"seed {seed}: {len(agent['lengths'])} episodes, {agent['seconds']:.0f} s",
              file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
