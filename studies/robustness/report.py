"""The robustness study written down: one map figure per task and the report's sections.

A figure has a row per learner: the measure over the parameter grid of the agents trained on
the paper's plant and of those trained with randomisation (two maps, one colour scale), then
the measure against observation noise and against delay, both trainings. The report gives
every cell's 95 % interval, the controllers' scores over the grid compared by the
probability of improvement (Agarwal et al. 2021), and the C controllers (one per kind of
action, `study.C_LEARNERS`) beside the Python agents they were exported from.
"""

import numpy as np

from lwrl.agent import LEARNERS
from lwrl.analysis.plots import save_figure
from lwrl.analysis.statistics import mean_interval
from lwrl.studies.robustness import plan
from lwrl.studies.robustness.study import measures, returns_tolerance


def _grid(result, learner, training, measure) -> np.ndarray:
    """The cells' means over the grid as an array, one axis per robustness parameter."""
    cells = result.grid_cells()
    size = round(len(cells) ** (1 / len(result.axes)))
    values = np.array([result.estimate(learner, training, cell, measure).value for cell in cells])
    return values.reshape((size,) * len(result.axes)) if len(result.axes) == 2 else values[None, :]


def _factors(result) -> list:
    return sorted({cell.factors[0] for cell in result.grid_cells()})


def axis_label(measure) -> str:
    """`label (unit)`, or the label of a measure without a unit."""
    return measure.label + (f" ({measure.unit})" if measure.unit else "")


def figure(result, figure_dir: str) -> list:
    """The task's map figure; returns the files written (`analysis.plots.save_figure`)."""
    import matplotlib.pyplot as plt
    measure = measures(result.task)[0]
    learner_names = list(dict.fromkeys(learner for learner, _ in result.trainings))
    fig, axes = plt.subplots(len(learner_names), 4, figsize=(15, 3.4 * len(learner_names)),
                             squeeze=False)
    grids = {(l, t): _grid(result, l, t, measure) for l, t in result.trainings}
    finite = [g for g in grids.values() if np.isfinite(g).any()]
    low = min(np.nanmin(g) for g in finite) if finite else 0.0
    high = max(np.nanmax(g) for g in finite) if finite else 1.0
    factors = _factors(result)
    labels = [f"x{factor:g}" for factor in factors]
    nominal = (1.0,) * len(result.axes)
    for row, learner in enumerate(learner_names):
        for column, training in enumerate(plan.TRAININGS):
            ax = axes[row, column]
            image = ax.imshow(grids[learner, training], origin="lower", cmap="viridis",
                              vmin=low, vmax=high, aspect="auto")
            ax.set_xticks(range(len(factors)), labels)
            ax.set_xlabel(result.axes[-1])
            if len(result.axes) == 2:
                ax.set_yticks(range(len(factors)), labels)
                ax.set_ylabel(result.axes[0])
            else:
                ax.set_yticks([])
            for (i, j), value in np.ndenumerate(grids[learner, training]):
                ax.text(j, i, "—" if np.isnan(value) else f"{value:.{measure.digits}f}",
                        ha="center", va="center", fontsize=7, color="white")
            ax.set_title(f"{learner}, trained {training}", fontsize=9)
            fig.colorbar(image, ax=ax, label=axis_label(measure))
        for column, kind in ((2, "noise"), (3, "delay")):
            ax = axes[row, column]
            for training in plan.TRAININGS:
                cells = [cell for cell in result.cells if cell.kind == kind or
                         (cell.kind == "parameters" and cell.factors == nominal)]
                xs = [cell.noise if kind == "noise" else cell.delay for cell in cells]
                estimates = [result.estimate(learner, training, cell, measure) for cell in cells]
                means = np.array([e.value for e in estimates])
                ax.plot(xs, means, marker="o", label=f"trained {training}")
                ax.fill_between(xs, [e.low for e in estimates], [e.high for e in estimates],
                                alpha=0.2)
            ax.set_xlabel("observation noise (fraction of each variable's span)" if kind == "noise"
                          else "actuation delay (control steps)")
            ax.set_ylabel(axis_label(measure))
            ax.set_title(f"{learner}: {kind}", fontsize=9)
            ax.legend(fontsize=7)
    fig.suptitle(f"{result.task} on the {result.plant} plant: greedy {measure.label}, means over "
                 "agents (bands: 95 % bootstrap intervals)")
    fig.tight_layout()
    return save_figure(fig, figure_dir, result.task.replace(".", "_"))


def _returns_within(learner: str) -> str:
    """How a C controller's returns are compared: the same numbers, or for one of
    continuous actions to round-off (`study.returns_tolerance`)."""
    tolerance = returns_tolerance(LEARNERS[learner].actions)
    if not tolerance:
        return ""
    return (f" (returns within {tolerance:g} of their size: the continuous action is "
            "the Python agent's to an ulp)")


def _cell_label(result, cell) -> str:
    if cell.kind == "noise":
        return f"noise {cell.noise:g}"
    if cell.kind == "delay":
        return f"delay {cell.delay}"
    return ", ".join(f"{name} x{factor:g}" for name, factor in zip(result.axes, cell.factors))


def section(result, figure_path: str) -> str:
    """The report's section on one task."""
    first = measures(result.task)[0]
    pairs = list(result.trainings)
    lines = [f"## {result.task}", "",
             f"{len(pairs)} trained batches ({budgets(result.trainings)}; each "
             f"trained on the paper's plant and with {', '.join(result.axes)} drawn per episode "
             f"between x{plan.TRAINING_FACTORS[0]:g} and x{plan.TRAINING_FACTORS[1]:g}); "
             f"{len(result.cells)} cells, {result.evaluation_episodes} greedy episodes per "
             f"agent and cell; {result.runs} runs, {result.computed} computed by "
             f"this command ({result.seconds:.0f} s); " + took(result.timing) + ".", "",
             f"![{result.task}]({figure_path})", ""]
    lines += ["Over the parameter grid (each agent's mean over every cell of the grid; 95 % "
              "intervals over agents):", "",
              "| learner | trained | " + " | ".join(m.label for m in measures(result.task)) + " |",
              "|---|---|" + "---|" * len(measures(result.task))]
    for learner, training in pairs:
        cells = [mean_text(result.grid_scores(learner, training, m), m) for m in measures(result.task)]
        lines.append(f"| {learner} | {training} | " + " | ".join(cells) + " |")
    lines += ["", "Which controllers hold up better over the grid: the probability that an "
              f"agent of the first does better ({first.label}) than one of the second, with "
              "its 95 % interval (above 0.5: the first is more robust):", ""]
    lines += [f"- {a[0]} ({a[1]}) against {b[0]} ({b[1]}): "
              f"{result.comparison(a, b, first).text(2)} — {verdict(result.comparison(a, b, first))}"
              for a, b in comparisons(pairs)]
    controllers = result.controllers
    lines += ["", f"Every cell ({first.label}" + (f", {first.unit}" if first.unit else "")
              + "; mean over agents [95 % interval]):", "",
              "| cell | " + " | ".join([f"{l} ({t})" for l, t in pairs]
                                      + [f"C {learner}" for learner in controllers]) + " |",
              "|---|" + "---|" * (len(pairs) + len(controllers))]
    for cell in result.cells:
        row = [result.estimate(learner, training, cell, first).text(first.digits)
               for learner, training in pairs]
        row += [f"{c['per_cell'][cell][first.column]:.{first.digits}f}"
                for c in controllers.values()]
        lines.append(f"| {_cell_label(result, cell)} | " + " | ".join(row) + " |")
    for learner, c in controllers.items():
        lines += ["", f"The C controller of {learner} (`lwrl.export.c.export_c` of agent "
                  f"{c['agent']} of its nominal training, double precision, compiled as a shared "
                  f"library and called through ctypes at every step): its episodes equal the "
                  f"Python agent's, step count and return episode by episode{_returns_within(learner)}, "
                  f"in {c['same']} of "
                  f"{c['cells']} cells (its column, C {learner}: that one agent's {first.label})."]
    return "\n".join(lines) + "\n"


def budgets(trainings: dict) -> str:
    """The learners and their training budgets, `sarsa, true_online_sarsa: 30 agents, 200
    episodes each; dqn, ppo: 5 agents, 30 episodes of 60 s each`, the largest first."""
    found = {}
    for (learner, _), config in trainings.items():
        limit = config.task_options.get("time_limit")
        budget = (config.agents, config.episodes, "" if limit is None else f" of {limit:g} s")
        found.setdefault(budget, set()).add(learner)
    return "; ".join(f"{', '.join(sorted(names))}: {agents} agents, {episodes} episodes{length} each"
                     for (agents, episodes, length), names in sorted(found.items(), reverse=True))


def took(timing: dict) -> str:
    """How long the task's runs took, from its `timings.json` entry."""
    if not timing["invocations"]:
        return "the time its runs took was not recorded (they were computed before its record)"
    return (f"all of them took {timing['seconds'] / 60:.1f} minutes of wall time, in "
            f"{timing['invocations']} invocation{'s' if timing['invocations'] > 1 else ''} of "
            "the command")


def mean_text(values, measure) -> str:
    return mean_interval(values).text(measure.digits, measure.unit)


def comparisons(pairs) -> list:
    """The pairs to compare: each learner's two trainings, and the first learner against
    each other one, training by training."""
    learner_names = list(dict.fromkeys(learner for learner, _ in pairs))
    found = [((learner, plan.TRAININGS[1]), (learner, plan.TRAININGS[0])) for learner in learner_names]
    found += [((learner_names[0], training), (other, training)) for other in learner_names[1:]
              for training in plan.TRAININGS]
    return found


def verdict(estimate) -> str:
    side = estimate.side(0.5)
    return "more robust" if side > 0 else "less robust" if side < 0 else "no difference shown"


def studied(results, what: str) -> list:
    """The values the cells of `results` take: `factors` (of the parameter grid), `noise`
    or `delay`, sorted."""
    found = {value for result in results for cell in result.cells
             for value in (cell.factors if what == "factors" else (getattr(cell, what),))}
    return sorted(found)


def document(results, command: str, seconds: float, figure_paths: dict) -> str:
    """The whole report: how it was made, then one section per task."""
    lines = ["# How robust are the learned controllers?", "",
             "Written by `" + command + "`. Its runs took "
             f"{sum(r.timing['seconds'] for r in results) / 60:.1f} minutes of wall time ("
             + ("" if all(r.timing["invocations"] for r in results) else "where recorded; ")
             + "summed over the tasks and over the invocations that computed them: the same "
             "command resumes an interrupted study, reading what an earlier one finished); "
             f"this invocation took {seconds / 60:.1f} minutes.", "",
             "Agents of every learner of the registry that fits the task (a learner of "
             "continuous actions on the task made with them: the force, torque or thrust "
             "itself in the actuator's range), each with the "
             "settings tuned for it elsewhere where it has them (rl-baselines3-zoo's sets for "
             "DQN and PPO and their JAX ports, where the benchmark's search starts), else the "
             "task's defaults, are trained on the paper's plant (*nominal*) and "
             "with the domain's robustness parameters drawn uniformly for every episode "
             f"between x{plan.TRAINING_FACTORS[0]:g} and x{plan.TRAINING_FACTORS[1]:g} their "
             "paper values (*randomised*, domain randomisation). Then they run greedily, "
             "without learning, from starts of their own: over a grid of those parameters "
             "(" + ", ".join(f"x{f:g}" for f in studied(results, "factors")) + " each, clipped to the "
             "accepted ranges), over Gaussian observation noise on every state variable ("
             + ", ".join(f"{f:g}" for f in studied(results, "noise") if f)
             + " of each variable's "
             "normalisation span) and over actuation delays of " + ", ".join(
                 str(d) for d in studied(results, "delay") if d) + " control steps. The "
             "measure is the "
             "task's own: up-time, or for a task without one the success rate (episodes that "
             "reach the goal before the time limit) and the steps per episode (to the goal, or "
             "the time limit where it is not reached); per agent the mean over its evaluation "
             "episodes, then the mean over agents with a 95 % "
             "percentile bootstrap interval (`lwrl.analysis.statistics`). The budget, which "
             "each task's section states: the task's own protocol (agents, training episodes) "
             "unless the command sets them, at most "
             f"{plan.STEPPED_AGENTS} agents for a learner that runs only in the stepped loop "
             "(DQN, PPO: 160 to 710 times the paper's agent's CPU per learning step, "
             "docs/benchmark), trained for the benchmark's episodes unless the command sets "
             "them (each task's section states them; the benchmark's cart-pole episodes last "
             "60 s, as the paper's 200 of 240 s would take such an agent hours), and "
             "evaluated, as every learner, on the task's own episodes; the JAX population "
             "learners (`dqn_jax`, `ppo_jax`: DQN's and PPO's equations, a batch of agents in "
             "one compiled program) trained as DQN and PPO but with the task's count of "
             "agents, their sensors' noise drawn from JAX's random streams (the same "
             "distributions as the other learners', other numbers); the plant "
             "comparison's evaluation episodes (fewer where the start is deterministic) unless "
             "the command sets them.", ""]
    for result in results:
        lines.append(section(result, figure_paths[result.task]))
    return "\n".join(lines)
