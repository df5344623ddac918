"""The learner on an emulated Cortex-M4 (lwrl.export.device) learns as its host build does,
and the host build of the device program learns as lwrl's Python learner does.

- The device program's host build in double (Mountain-Car's plant and the learner in C,
  starts from the program's own SplitMix64 stream) takes exactly the steps per episode of
  lwrl's Python learner on the Python plant from the same starts: the C plant and the C
  learner are lwrl's, not merely alike.
- On the emulated Cortex-M4 (qemu-system-arm, mps2-an386), the paper's best Mountain-Car
  agent learns in a short run (8 episodes, float, as CI runs it): the steps per episode
  equal the host build's, it learns (the last episodes are far shorter than the first), and
  the weights agree to float round-off (newlib's and glibc's expf and cos differ in the last
  bit for some arguments).
- The costs are measured: the learner object's RAM is the computed RAM, and a learning step
  costs more instructions than a decision, on both machines.

The tests that need the cross compiler, QEMU or valgrind are skipped where they are
missing, naming the Debian packages.
"""

import pathlib
import shutil
import subprocess

import numpy as np
import pytest

from lwrl import tasks
from lwrl.tasks import mountain_car
from lwrl.agent.streams import uniform
from lwrl.export import device, learner
from lwrl.cli.main import main
from lwrl.runners.config import RunConfig
from lwrl.runners.run import make_agents

MOUNTAIN_CAR = "mountain_car.cost_to_go"
needs_host_compiler = pytest.mark.skipif(
    not (shutil.which("cc") or shutil.which("gcc")), reason="no C compiler (Debian package gcc)")
needs_cross_tools = pytest.mark.skipif(
    bool(device.missing_tools()), reason=f"missing {', '.join(device.missing_tools())}")
needs_valgrind = pytest.mark.skipif(
    not shutil.which("valgrind"), reason="missing valgrind (Debian package valgrind)")


def python_run(task, seed, episodes, **options):
    """lwrl's Python learner on the Python plant (the task's `transition`, with its
    `options`) from the device program's starts: the SplitMix64 stream at the agent's seed
    + 2^63, two draws per start."""
    definition = tasks.definition(*tasks.split_name(task), **options)
    low = np.array([mountain_car.MIN_POSITION, -mountain_car.MAX_SPEED])  # SPEC.md Task 1's starts
    high = np.array([mountain_car.GOAL_POSITION, mountain_car.MAX_SPEED])
    agent = make_agents(RunConfig(task=task, agents=1, seed=seed))
    starts = np.array([seed + 2 ** 63], dtype=np.uint64)
    controls = np.asarray(definition.controls, dtype=np.float64)
    arguments = definition.loop_arguments()
    steps = []
    for _ in range(episodes):
        with np.errstate(over="ignore"):  # SplitMix64 wraps modulo 2^64
            state = low + (high - low) * np.array([uniform(starts, 0), uniform(starts, 0)])
        action = agent.step([True], [0.0], [1.0], state[None])[0]
        n, terminal = 0, False
        while not terminal and n < definition.step_limit:
            next_state, observation = np.empty(2), np.empty(2)
            reward, terminal, _ = definition.transition(state, controls[action], next_state,
                                                        observation, 1.0, True, False, arguments)
            n += 1
            state = next_state
            action = agent.step([False], [reward], [0.0 if terminal else 1.0], observation[None])[0]
        steps.append(n)
    return steps, agent.arrays.weights[0]


@needs_host_compiler
@pytest.mark.parametrize("options", [{}, {"params": {"thrust": 0.0015, "gravity": 0.003}}],
                         ids=["paper", "other_parameters"])
def test_host_build_in_double_is_the_python_learner_on_the_python_plant(tmp_path, options):
    device.write_program(tmp_path, learner.from_task(MOUNTAIN_CAR, seed=3), "double", "run.c",
                         episodes=20, seed=3)
    (tmp_path / "lwrl_plant.h").write_text(device.plant_header(MOUNTAIN_CAR, **options))
    text = subprocess.run([device.build_host(tmp_path)], capture_output=True, text=True,
                          check=True).stdout
    c_run = device.parse_run(text, "double")
    python_steps, python_weights = python_run(MOUNTAIN_CAR, 3, 20, **options)
    assert c_run["steps"] == python_steps
    np.testing.assert_array_equal(c_run["weights"].reshape(python_weights.shape), python_weights)


def test_the_plant_header_is_the_domains_c_plant_at_the_tasks_parameters():
    header = device.plant_header(MOUNTAIN_CAR)
    assert "0.001 * control - 0.0025 * cos(3.0 * state[0])" in header
    assert "#define PLANT_STEP_LIMIT 10000" in header and "#define PLANT_DIM 2" in header
    assert "CONTROLS[] = {-1.0, 0.0, 1.0}" in header and "$" not in header
    assert "parameter values of mountain_car.cost_to_go: thrust 0.001, gravity 0.0025" in header
    other = device.plant_header(MOUNTAIN_CAR, params={"gravity": 0.003})
    assert "0.001 * control - 0.003 * cos(3.0 * state[0])" in other and "gravity 0.003" in other
    with pytest.raises(ValueError, match=r"^no plant in C for the domain 'pendulum' \(the domains "
                                         r"with one: mountain_car\); an installed package adds "
                                         r"one with an entry point 'pendulum = module:attribute' "
                                         r"of the group 'lwrl.c_plants'$"):
        device.plant_header("pendulum.swingup")


@needs_cross_tools
def test_the_emulated_cortex_m4_learns_as_the_host_build(tmp_path):
    """A short run, as CI runs it: 8 episodes of the paper's best agent in float."""
    result = device.run_device(MOUNTAIN_CAR, episodes=8, seed=0, dtype="float", build=tmp_path)
    host, emulated = result["host"], result["device"]
    print(f"\nsteps per episode: host {host['steps']}, emulated M4 {emulated['steps']}; weights "
          f"within {result['weight_ulps']} ulp; firmware {result['sizes']}; "
          f"{result['instructions']} instructions emulated")
    assert emulated["steps"] == host["steps"]
    assert np.mean(emulated["steps"][-4:]) < emulated["steps"][0] / 3  # it learns
    assert not emulated["diverged"]
    scale = np.abs(host["weights"]).max()
    assert np.abs(emulated["weights"] - host["weights"]).max() <= 1e-4 * scale
    assert result["sizes"]["bss"] >= result["ram"]["total"] == 2144
    assert result["instructions"] > 0


@needs_cross_tools
@needs_valgrind
def test_costs_are_measured_on_both_machines():
    result = device.costs(MOUNTAIN_CAR)
    ram = result["ram"]["total"]
    assert ram <= result["object"]["bss"] + result["object"]["data"] <= ram + 8
    assert result["object"]["text"] > 0 and result["stack"] > 0
    for machine in ("host", "m4"):
        assert 0 < result[f"{machine}_decide"] < result[f"{machine}_learn"]
    print(f"\n{MOUNTAIN_CAR}: {result['ram']} B RAM, object {result['object']}, stack "
          f"{result['stack']} B; per learning step {result['host_learn']:.0f} (x86-64) and "
          f"{result['m4_learn']:.0f} (M4) instructions, per decision {result['host_decide']:.0f} "
          f"and {result['m4_decide']:.0f}")


@needs_cross_tools
def test_libm_agreement_is_counted():
    """newlib's and glibc's exp, expf and cos: how often they differ is measured, and it is
    neither never nor always (if it were never, the docs' explanation would be wrong)."""
    agreement = device.libm_agreement(2000)
    for name in ("exp", "expf", "cos"):
        assert 0 <= agreement[name] < agreement["count"] / 2


def test_the_cli_refuses_a_learner_beyond_its_ram(tmp_path, capsys):
    assert main(["learner", "cartpole.balance", "--c", str(tmp_path), "--ram", "16384"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "needs 31228 bytes of RAM in float" in error
    assert main(["learner", MOUNTAIN_CAR, "--c", str(tmp_path), "--ram", "4096"]) == 0
    assert "RAM: 2144 bytes in float" in capsys.readouterr().out
    assert (pathlib.Path(tmp_path) / "lwrl_learner.c").exists()
    assert main(["learner", MOUNTAIN_CAR, "--c", str(tmp_path)]) == 2  # would replace: --force
    assert "--force" in capsys.readouterr().err
