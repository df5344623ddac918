"""Smoke tests of the speed benchmarks (they measure; they assert no speed)."""

import os

import pytest

from benchmarks import agent_speed


def test_agent_speed_quick_prints_its_table(capsys):
    agent_speed.main(["--quick"])
    out = capsys.readouterr().out
    assert "| mountain_car.cost_to_go |" in out and "| cartpole.balance |" in out
    assert out.count("(x") == 4 and "Runs measured:" in out
    assert out.count(" %) |") == 4 and out.count("bound ") == 2  # beside each lwrl rate


def test_the_arithmetic_model_counts_from_the_feature_sizes():
    """The model's counts per agent-step follow from d, n and A (Mountain-Car's 8 x 8 grid,
    3 actions: 16 exponentials; the outer product's 8 + 64 multiply-adds and 10 passes of 64,
    for Q(s', .), Q(s, a), the decay and the update; 5 A N + 5 N doubles) and are taken from
    each task's paper agent."""
    from benchmarks import arithmetic_bound

    counts = arithmetic_bound.step_counts(dim=2, n=8, actions=3)
    assert (counts.exponentials, counts.multiply_adds, counts.bytes) == (16, 8 + 64 + 10 * 64,
                                                                         8 * (15 * 64 + 5 * 64))
    assert arithmetic_bound.task_counts("mountain_car.cost_to_go") == counts
    assert arithmetic_bound.task_counts("cartpole.balance") == arithmetic_bound.step_counts(4, 6, 2)


def test_logging_overhead_is_never_negative():
    """A difference of medians within the repeats' spread, or below zero, is noise."""
    from benchmarks.rerun_logging import overhead

    assert overhead(10.0, 10.5, 0.1) == "5.0 %"
    assert overhead(10.0, 10.05, 0.1) == "within noise (spread 1.0 %)"
    assert overhead(10.0, 8.65, 0.3) == "within noise (spread 3.0 %)"


def test_jax_peer_quick_prints_its_tables(capsys, monkeypatch):
    """The JAX peer's benchmark in its smoke mode (skipped where JAX is not installed). Its
    `main` sets `XLA_FLAGS`; the test's processes after this one get theirs back."""
    pytest.importorskip("jax", reason="the JAX peer needs JAX (the jax extra)")
    from benchmarks import jax_peer

    monkeypatch.setenv("XLA_FLAGS", os.environ.get("XLA_FLAGS", ""))

    jax_peer.main(["--quick", "--cached"])
    out = capsys.readouterr().out
    for task in ("mountain_car.cost_to_go", "cartpole.balance"):
        assert out.count(f"| {task} |") == len(jax_peer.QUICK_AGENTS)
    assert "| JAX peer |" in out and "| lwrl |" in out and "Compile times" in out


def test_mujoco_plant_quick_prints_its_tables(capsys):
    """The MuJoCo plant's benchmark in its smoke mode: the stepped path gives the compiled
    loop's results (it checks them), and it prints its tables."""
    from benchmarks import mujoco_plant

    mujoco_plant.main(["--quick"])
    out = capsys.readouterr().out
    assert "Ratio 2 / 1" in out and "| `mujoco.rollout` call |" in out and "| whole |" in out


def test_mjx_plant_quick_prints_its_table(capsys):
    """The mjx plant's benchmark in its smoke mode (skipped where MJX is not installed)."""
    pytest.importorskip("mujoco.mjx", reason="the mjx plant needs MJX: pip install 'lwrl[mjx]'")
    from benchmarks import mjx_plant

    mjx_plant.main(["--quick"])
    out = capsys.readouterr().out
    assert "| 4. learning run, plant mjx, stepped path |" in out and "Compiling MJX's step" in out


MEASURED = ("ppo", "dqn", "sac", "td3", "ppo_jax", "dqn_jax", "sac_jax", "td3_jax", "ars",
            "sarsa")
"""The learners the smoke test of `benchmarks.deep_speed` measures: the pairs, a JAX
population and a compiled loop outside them (each JAX learner compiles its programs, seconds
each); every learner's arithmetic is counted all the same."""


def test_deep_speed_quick_prints_its_tables(capsys):
    """The deep learners' cost benchmark in its smoke mode (tiny networks and episodes, 1 and
    2 agents; JAX programs from lwrl's compilation cache; the JAX learners on one thread
    only, the other condition the same code with other XLA flags): its tables, each pair's
    (SAC's and TD3's with continuous actions among them) measured at 1 and 2 agents, a row of
    counted arithmetic for every learner of the registry, the learners of `MEASURED` timed
    and the others named as not measured, and its JAX part or SB3 part skipped, saying so,
    where the extra is missing."""
    from benchmarks import deep_speed
    from lwrl import agent as learners
    from lwrl.agent.jax_population import missing_jax
    from lwrl.agent.stable_baselines import missing_libraries

    deep_speed.main(["--quick", "--cached", "--conditions", "one", "--learners", *MEASURED])
    out = capsys.readouterr().out
    unlisted = [name for name in learners.LEARNERS if name not in MEASURED]
    assert f"- not measured (not among --learners), counted only: {', '.join(unlisted)}" in out
    timed = [line.split(" on ")[0].removeprefix("- ").split(" x ")[0]
             for line in out.splitlines() if line.startswith("- ") and " agent-steps, median " in line]
    assert set(timed) == {name for name in MEASURED if not deep_speed.skip_reason(name)}
    assert "## CPU per agent-step" in out and "## Aims, at 2 agents" in out
    assert out.count("met**") + out.count(": not measured") == 4  # 2 twins x 2 conditions
    if not (missing_jax() or missing_libraries()):
        assert out.count("not measured (not among --conditions)") == 2  # both cores
    for name in learners.LEARNERS:
        assert f"\n| {name} | " in out  # its counted arithmetic
    assert {"sac": "sac_jax", "td3": "td3_jax"}.items() <= deep_speed.PAIRS.items()
    for sb3, twin in deep_speed.PAIRS.items():
        assert f"- {sb3} and {twin}: " in out  # the settings both take
        header = f"| agents | {sb3} (SB3, one thread) | {twin}, one thread |"
        rows = out.split(header)[1].split("\n\n")[0].splitlines()[2:]
        assert [row.split(" | ")[0] for row in rows] == ["| 1", "| 2"]
        for row in rows:  # SB3's and the twin's one thread measured, where installed
            measured = [cell != "—" for cell in row.split(" | ")[1:3]]
            assert measured == [not missing_libraries(), not missing_jax()], row
        assert (f"- {twin}: skipped:" in out) == missing_jax()
        assert (f"- {sb3}: skipped:" in out) == bool(missing_libraries())
    if not missing_jax():
        assert "## Compile time (JAX)" in out and "XLA thread" in out


def test_deep_speed_counts_what_each_learner_declares():
    """The counted-arithmetic table reads `Learner.arithmetic`: a learner's own counts, and
    "not counted" with the reason for a learner that declares none (None) or settings its
    counts do not cover (CMAC features)."""
    import dataclasses

    from benchmarks import deep_speed
    from lwrl import agent as learners
    from lwrl.runners.config import RunConfig

    config = RunConfig(task="mountain_car.cost_to_go")
    sarsa = learners.learner(config.learner)
    assert deep_speed.counted(sarsa, config.settings, config.task_spec) == sarsa.arithmetic(
        config.settings, config.task_spec)
    assert deep_speed.counted(dataclasses.replace(sarsa, arithmetic=None), config.settings,
                              config.task_spec) == f"not counted ({sarsa.name} declares no counts)"
    cmac = dataclasses.replace(config.settings, features="cmac")
    assert deep_speed.counted(sarsa, cmac, config.task_spec) == "not counted (cmac features)"


def test_search_populations_quick_prints_its_table(capsys):
    """The search's populations benchmark in its smoke mode: ARS's runs alone and as one
    population, their tables the same both ways."""
    from benchmarks import search_populations
    from lwrl.agent.jax_population import missing_jax
    if missing_jax():
        pytest.skip("the population learners need the jax extra: pip install 'lwrl[jax]'")
    search_populations.main(["--quick"])
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| ars |"))
    assert row.startswith("| ars | 2 x 2 | ") and row.endswith(" | yes |")
