"""The pictures of the README and the documentation site, made again by the commands they
show: the front page's learning curve and the Rerun page's viewer (docs/guide/rerun.md).

    python docs/pictures/make.py [learning_curve] [viewer]    (both by default)

- `learning_curve.png`: `lwrl train mountain_car.cost_to_go --out DIR` (the README's first
  command: the paper's best Mountain-Car agent, 30 agents x 40 episodes), steps per episode
  of every agent and their mean with one standard error, beside the paper's level.
- `viewer.png`: `lwrl train pendulum.swingup --plant mujoco --agents 1 --episodes 20
  --log-episodes 1,10,20 --rrd REC`, opened by its path in a headless Rerun viewer as a user
  opens it, then paused at step 2400 of the last logged episode.

Each command runs in a temporary directory; only the PNGs are kept, in this folder. Needs
the 'paper' extra (pandas, matplotlib) and, for the viewer, a Vulkan driver (Mesa's
lavapipe: apt-get install mesa-vulkan-drivers). About a minute on two cores.
"""

import argparse
import os
import sys
import tempfile
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from lwrl.cli import main as cli  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
PAPER_STEPS = 60
"""Främling (2008), Fig. 3: the best Mountain-Car agent's steps per episode after about 40
episodes."""
VIEWER_RUN = ["train", "pendulum.swingup", "--plant", "mujoco", "--agents", "1",
              "--episodes", "20", "--log-episodes", "1,10,20"]
VIEWER_STEP = 2400
"""The step of the last logged episode the viewer's picture is paused at (the pendulum up)."""


def run(argv: list) -> None:
    print("$ lwrl " + " ".join(argv), flush=True)
    if cli.main(argv) != 0:
        sys.exit(f"lwrl {argv[0]} failed")


def learning_curve(work: str) -> str:
    """Steps per episode of `lwrl train mountain_car.cost_to_go`'s agents."""
    run(["train", "mountain_car.cost_to_go", "--out", os.path.join(work, "run")])
    episodes = pd.read_csv(os.path.join(work, "run", "episodes.csv"))
    steps = episodes.pivot(index="episode", columns="agent", values="steps")
    mean = steps.mean(axis=1)
    error = steps.std(axis=1, ddof=1) / np.sqrt(steps.count(axis=1))
    figure, axes = plt.subplots(figsize=(6.4, 3.6))
    axes.plot(steps.index, steps.to_numpy(), color="tab:blue", alpha=0.12, linewidth=0.8)
    axes.fill_between(steps.index, mean - error, mean + error, color="tab:blue", alpha=0.3,
                      label="± one standard error")
    axes.plot(steps.index, mean, color="tab:blue", linewidth=2,
              label=f"mean of {steps.shape[1]} agents (thin: each agent)")
    axes.axhline(PAPER_STEPS, color="tab:red", linestyle="--", linewidth=1,
                 label="the paper (Fig. 3): about 60 steps")
    axes.set_yscale("log")
    axes.set_xlabel("episode")
    axes.set_ylabel("steps to the goal (log scale)")
    axes.set_title("lwrl train mountain_car.cost_to_go", family="monospace", fontsize=11)
    axes.legend(fontsize=8)
    axes.grid(alpha=0.3, which="both")
    path = os.path.join(HERE, "learning_curve.png")
    figure.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(figure)
    return path


def viewer(work: str) -> str:
    """The Rerun viewer on a recording, opened by its path in a headless viewer."""
    from lwrl.viz import rerun as viz

    recording = os.path.join(work, "pendulum.rrd")
    run([*VIEWER_RUN, "--rrd", recording])
    path = os.path.join(HERE, "viewer.png")
    with viz.headless_viewer("1280x800") as client:
        client.open(recording)
        time.sleep(5)  # the viewer loads the file's chunks after `open` returns
        client.set_time("step", sequence=VIEWER_STEP, play_state="paused")
        time.sleep(2)
        with open(path, "wb") as file:
            file.write(client.take_screenshot())
    return path


PICTURES = {"learning_curve": learning_curve, "viewer": viewer}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", choices=[*PICTURES, []], metavar="NAME",
                        help=f"pictures to make: {', '.join(PICTURES)} (default: all)")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    written = []
    with tempfile.TemporaryDirectory() as work:
        for name in args.names or PICTURES:
            written.append(os.path.relpath(PICTURES[name](work)))
    print(f"done in {time.perf_counter() - started:.0f} s: wrote {', '.join(written)}")


if __name__ == "__main__":
    main()
