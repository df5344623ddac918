"""The pictures of the README and the documentation site, made again by the commands they
show: the front page's learning curve and the Rerun page's viewer (docs/guide/rerun.md).

    python docs/pictures/make.py [learning_curve] [viewer]    (both by default)

- `learning_curve.png`: `lwrl train mountain_car.cost_to_go --out DIR` (the README's first
  command: the paper's best Mountain-Car agent, 30 agents x 40 episodes), then `lwrl plot
  DIR --log --out learning_curve.png`: steps per episode, the mean over the agents with its
  95 % interval.
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

from lwrl.cli import main as cli

HERE = os.path.dirname(os.path.abspath(__file__))
VIEWER_RUN = ["train", "pendulum.swingup", "--plant", "mujoco", "--agents", "1",
              "--episodes", "20", "--log-episodes", "1,10,20"]
VIEWER_STEP = 2400
"""The step of the last logged episode the viewer's picture is paused at (the pendulum up)."""


def run(argv: list) -> None:
    print("$ lwrl " + " ".join(argv), flush=True)
    if cli.main(argv) != 0:
        sys.exit(f"lwrl {argv[0]} failed")


def learning_curve(work: str) -> str:
    """`lwrl plot` of `lwrl train mountain_car.cost_to_go`'s agents."""
    path = os.path.join(HERE, "learning_curve.png")
    run(["train", "mountain_car.cost_to_go", "--out", os.path.join(work, "mountain_car")])
    run(["plot", os.path.join(work, "mountain_car"), "--log", "--out", path])
    os.remove(path[:-len(".png")] + ".svg")  # the README shows the PNG
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
