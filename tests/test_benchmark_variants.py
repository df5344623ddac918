"""The third benchmark's candidate variants (studies/paper/benchmark/variants.py): each is
the suite's option it names, within the accepted ranges; a bad one is one line; and on a
variant the classical controller meets what the variant does to it (observation noise
lowers its pendulum up-time, which the nominal task's reference rows do not show)."""

import numpy as np
import pytest

from lwrl import tasks
from lwrl.analysis import statistics
from lwrl.studies.paper.benchmark import evaluation, variants


def test_candidates_are_the_suites_options():
    definition = evaluation.task_definition("cartpole.balance")
    noise = variants.environment("cartpole.balance", "noise")["observation_noise"]
    span = np.subtract(definition.ranges[1], definition.ranges[0])
    assert list(noise) == list(definition.state_names)
    assert np.allclose(list(noise.values()), variants.NOISE * span)
    assert variants.environment("cartpole.balance", "delay") == {"action_delay": variants.DELAY}
    assert variants.environment("cartpole.balance", "nominal") == {}
    ranges = variants.environment("acrobot.swingup", "physics")["randomise"]
    domain = tasks.domain("acrobot")
    assert set(ranges) == set(variants.RANDOMISED["acrobot"]) == {"link_mass_2", "torque"}
    for parameter in domain.parameters.items:
        if parameter.name in ranges:
            low, high = ranges[parameter.name]
            assert parameter.low <= low < parameter.nominal < high <= parameter.high


def test_unknown_variant_is_one_line():
    with pytest.raises(ValueError) as error:
        variants.environment("pendulum.swingup", "wind")
    assert "allowed: nominal, noise, delay, physics" in str(error.value)
    assert "\n" not in str(error.value)


def test_classical_controller_meets_the_variant():
    def classical(candidate):
        tables = evaluation.run_references("pendulum.swingup", agents=2, episodes=1,
                                           environment=variants.environment("pendulum.swingup",
                                                                            candidate))
        return evaluation.measure(tables["classical"], "pendulum.swingup")
    nominal, noisy = classical("nominal"), classical("noise")
    assert np.all(nominal > 55.0)  # the pendulum's 60-s episode, up nearly all of it
    assert np.mean(noisy) < np.mean(nominal) - 3.0


def measured(task, candidate, saturated, low, agents=20):
    return variants.Measured(task, candidate, 0.0, 1.0, statistics.Estimate(low + 0.1, low, low + 0.2),
                             saturated, agents)


def test_choice():
    table = [measured("a", "nominal", 15, 0.9), measured("a", "noise", 3, 0.2),
             measured("a", "delay", 3, 0.4), measured("a", "physics", 0, -0.1),
             measured("b", "nominal", 9, 0.5), measured("b", "noise", 0, 0.2),
             measured("c", "nominal", 10, 0.9), measured("c", "delay", 0, -0.2)]
    # a: the fewest at the level among the learnt (physics is not), the tie to the higher
    # lower end; b: fewer than half at the level nominally, no variant; c: none learnt
    assert variants.choose(table) == {"a": "delay"}
