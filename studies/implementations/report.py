"""`lwrl implementations`' report (`report.md`): per task and pair the translation of the
settings, the learning curves of both implementations with 95 % bootstrap intervals, each
implementation's measure with its interval, the probability that the population learner
does better with its interval, a verdict, the costs; per pair what differs.

Statistics (`lwrl.analysis.statistics`): an agent's measure is its mean over its episodes
(the unit resampled is the agent: its episodes are not independent, agents are); intervals
are 95 % percentile bootstrap intervals over agents; P(twin better) is the probability of
improvement (Agarwal et al. 2021) of the twin's agents over the reference's, ties counting
half, each implementation's agents resampled within it (stratified).
"""

import dataclasses
import datetime
import importlib.metadata
import math
import os
import platform
import sys

import matplotlib.pyplot as plt
import numpy as np

from lwrl import agent as learners
from lwrl import outputs
from lwrl.agent.stable_baselines import ZOO
from lwrl.analysis import statistics as st
from lwrl.analysis.plots import plot_learning_curve, save_figure
from lwrl.runners.config import tuned_settings
from lwrl.studies.implementations import costs as costs_module
from lwrl.studies.implementations import plan

LIBRARIES = ("jax", "optax", "torch", "stable-baselines3", "numpy", "mujoco")
"""The libraries whose versions the report states (the numbers depend on them)."""


@dataclasses.dataclass
class Comparison:
    """One cell's results: per implementation its agents x episodes table of the measure,
    each agent's mean, its estimate; the probability of improvement and the verdict."""

    cell: plan.Cell
    tables: dict
    """`{learner: DataFrame}` seeds x episodes of the measure's column."""
    values: dict
    """`{learner: (agents,) array}`: each agent's mean over its episodes (NaN: none ran)."""
    estimates: dict
    """`{learner: Estimate}` of the mean over agents."""
    diverged: dict
    """`{learner: agents that diverged}`."""
    improvement: st.Estimate
    """P(an agent of the twin does better than one of the reference), with its interval."""

    @property
    def outcome(self) -> int:
        """+1 the twin does better, -1 the reference does, 0 no difference found."""
        return st.outcome(self.improvement)

    @property
    def agents(self) -> dict:
        return {name: int(np.isfinite(values).sum()) for name, values in self.values.items()}


def per_agent(results, configs, column: str) -> tuple:
    """`(each agent's mean of column over its episodes, seeds x episodes table)` of the
    runs `configs` in `results` (NaN episodes, after a divergence, left out)."""
    rows = results[results["run"].isin([config.key for config in configs])]
    if rows.empty:
        return np.array([]), None
    table = rows.pivot_table(index="seed", columns="episode", values=column, dropna=False)
    return table.mean(axis=1).to_numpy(dtype=float), table


def compare_values(reference, twin, higher_is_better: bool) -> st.Estimate:
    """P(an agent of `twin` does better than one of `reference`) with its interval."""
    return st.improvement_interval(twin, reference, higher_is_better)


def compare(cell: plan.Cell, results) -> Comparison:
    """The cell's comparison from the results of its finished runs."""
    measure = cell.measure
    tables, values, estimates, diverged = {}, {}, {}, {}
    for name in cell.pair.names:
        configs = cell.configs(name)
        values[name], tables[name] = per_agent(results, configs, measure.column)
        estimates[name] = st.mean_interval(values[name])
        rows = results[results["run"].isin([config.key for config in configs])]
        diverged[name] = int(rows.groupby("seed")["diverged"].any().sum()) \
            if "diverged" in rows and not rows.empty else 0
    improvement = compare_values(values[cell.pair.reference], values[cell.pair.twin],
                                 measure.higher_is_better)
    return Comparison(cell, tables, values, estimates, diverged, improvement)


def verdict(improvement: st.Estimate, reference: str, twin: str, agents: dict) -> str:
    """One sentence: which implementation does better, or that no difference was found."""
    counts = f"{agents.get(reference, 0)} and {agents.get(twin, 0)} agents"
    if math.isnan(improvement.value):
        return f"Not judged: no results of {reference if not agents.get(reference) else twin} yet."
    if math.isnan(improvement.low):
        return (f"Not judged: an interval needs two agents of each implementation ({counts}); "
                f"P({twin} better) = {improvement.value:.2f}.")
    side = st.outcome(improvement)
    if side == 0:
        return (f"No difference found at this sample size ({counts}): the 95 % interval of "
                f"P({twin} better), {improvement.text(2)}, holds 0.5.")
    better = twin if side > 0 else reference
    return (f"{better} does better ({counts}): P({twin} better) = {improvement.text(2)}, its "
            f"95 % interval {'above' if side > 0 else 'below'} 0.5.")


def _number(x, digits: int = 1) -> str:
    return "—" if x is None or not isinstance(x, (int, float)) or not math.isfinite(x) \
        else f"{x:,.{digits}f}".replace(",", " ")


def _duration(seconds) -> str:
    if seconds is None or not math.isfinite(seconds):
        return "—"
    if seconds < 60:
        return f"{seconds:.1f} s"
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.2f} h"


def _value(value) -> str:
    return f"`{value!r}`" if isinstance(value, str) else f"`{value}`"


def translation_lines(cell: plan.Cell) -> list:
    """The settings table: every field of both implementations' settings."""
    reference, twin = cell.pair.names
    rows = plan.translation(cell)
    lines = [f"| setting | {reference} | {twin} | same | from | meaning |",
             "|---|---|---|---|---|---|"]
    for row in rows:
        lines.append(f"| `{row.name}` | {_value(row.reference)} | {_value(row.twin)} | "
                     f"{'yes' if row.same else '**no**'} | {row.source} | {row.help} |")
    different = [row.name for row in rows if not row.same]
    lines += ["", ("Every setting is the same for both implementations." if not different else
                   f"**The settings differ in {', '.join(different)}.**"), ""]
    return lines


def study_steps(comparison: Comparison, results, name: str) -> float:
    """The agent-steps the finished agents of `name` took in the study."""
    keys = [config.key for config in comparison.cell.configs(name)]
    return float(np.nansum(results.loc[results["run"].isin(keys), "steps"]))


def cost_lines(comparison: Comparison, results, costs: dict, timings: dict) -> list:
    """Each implementation's measure with its interval, and its costs."""
    cell = comparison.cell
    measure = cell.measure
    unit = f" {measure.unit}" if measure.unit else ""
    lines = [f"| implementation | agents | {measure.label}{unit} ({measure.better}), 95 % interval | "
             "agents diverged | CPU µs per agent-step | wall µs per agent-step | the study's "
             "agent-steps | CPU time of the study's agents (estimated) | wall time |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name in cell.pair.names:
        cost = costs.get(cell.key, {}).get(name, {})
        steps = study_steps(comparison, results, name)
        cpu, wall = cost.get("cpu_us_per_agent_step"), cost.get("wall_us_per_agent_step")
        population = cost.get("compile_wall_s") is not None
        if wall is not None:
            wall_text = (f"{_duration(wall * steps / 1e6)} estimated "
                         + ("(the population at once" + (
                             f", + {_duration(cost['compile_wall_s'])} compiling)"
                             if cost.get("compile_wall_s") else ")")
                            if population else "(one agent after the other)"))
        else:
            wall_text = "—"
        lines.append(
            f"| {name} | {comparison.agents[name]} | {comparison.estimates[name].text(1)} | "
            f"{comparison.diverged[name]} | {_number(cpu)} | {_number(wall)} | "
            f"{_number(steps, 0)} | {_duration(cpu * steps / 1e6) if cpu is not None else '—'} | "
            f"{wall_text} |")
    return lines + [""]


def initialisation_lines(cell: plan.Cell, summary: dict) -> list:
    """The untrained agents of both implementations compared."""
    reference, twin = cell.pair.names
    rows = (("parameters", "parameters", 0), ("weight_std", "standard deviation of the parameters", 4),
            ("weight_abs_max", "largest |parameter|", 4),
            ("zero_fraction", "fraction of parameters exactly 0 (biases set to 0)", 3),
            ("output_mean", "mean output over states and agents", 4),
            ("output_std_over_agents", "spread of the outputs across agents (std)", 4),
            ("action_spread", "mean |output - its mean over actions| (what ranks the actions)", 4))
    lines = [f"| untrained agents ({summary[reference]['agents']} each, seeds 0 on; outputs at "
             f"256 states drawn across the task's ranges) | {reference} | {twin} |", "|---|---|---|"]
    for key, label, digits in rows:
        lines.append(f"| {label} | {_number(summary[reference][key], digits)} | "
                     f"{_number(summary[twin][key], digits)} |")
    return lines + [""]


def figure(comparison: Comparison, results, figure_dir: str) -> str:
    """The learning curves of both implementations on one panel (95 % intervals over
    agents), each agent's measure on the other; return the PNG's name."""
    cell, measure = comparison.cell, comparison.cell.measure
    unit = f" ({measure.unit})" if measure.unit else ""
    fig, (curves, agents) = plt.subplots(1, 2, figsize=(11, 4.3), width_ratios=(2.2, 1))
    for index, name in enumerate(cell.pair.names):
        keys = [config.key for config in cell.configs(name)]
        rows = results[results["run"].isin(keys)]
        if rows.empty:
            continue
        plot_learning_curve(rows, measure.column, measure.label + unit,
                            f"{cell.task}: {cell.pair.reference} and {cell.pair.twin}",
                            axes=curves, interval=True,
                            label=f"{name} ({comparison.agents[name]} agents)")
        values = comparison.values[name]
        jitter = np.random.default_rng(index).uniform(-0.12, 0.12, len(values))
        agents.plot(index + jitter, values, "o", alpha=0.6, color=f"C{index}")
        estimate = comparison.estimates[name]
        if not math.isnan(estimate.low):
            agents.errorbar([index], [estimate.value], yerr=[[estimate.value - estimate.low],
                                                              [estimate.high - estimate.value]],
                            fmt="s", color="black", capsize=4)
    handles, labels = curves.get_legend_handles_labels()
    keep = [i for i, text in enumerate(labels) if "interval" not in text]
    curves.legend([handles[i] for i in keep], [labels[i] for i in keep], fontsize=8)
    if not measure.higher_is_better and np.nanmin([np.nanmin(v) if len(v) else np.nan
                                                   for v in comparison.values.values()]) > 0:
        curves.set_yscale("log")
    agents.set_xticks(range(2), cell.pair.names)
    agents.set_xlim(-0.5, 1.5)
    agents.set_ylabel(f"each agent's {measure.label}{unit}")
    agents.set_title(f"P({cell.pair.twin} better) = {comparison.improvement.text(2)}", fontsize=9)
    agents.grid(alpha=0.3)
    name = f"{cell.task}-{cell.pair.slug}"
    save_figure(fig, figure_dir, name)
    plt.close(fig)
    return f"figures/{name}.png"


def versions() -> str:
    found = []
    for library in LIBRARIES:
        try:
            found.append(f"{library} {importlib.metadata.version(library)}")
        except importlib.metadata.PackageNotFoundError:
            pass
    return ", ".join(found)


def host() -> str:
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    busy = f", load average {load[0]:.1f} at the end" if load else ""
    return (f"{platform.node()} ({os.cpu_count()} cores, {platform.system()} {platform.release()}, "
            f"Python {sys.version.split()[0]}{busy})")


def write(cells, results, costs: dict, timings: dict, initialisations: dict, out_dir: str,
          command: str, seconds: float, total_seconds: float, computed: int, runs: int,
          finished: int, notes: str = "") -> str:
    """Write `report.md` and its figures; return the report's path. `initialisations`:
    `{cell key: plan.initialisation(cell)}`; `notes`: the hand-written investigation
    notes (`notes.md`), included as they are."""
    figure_dir = os.path.join(out_dir, "figures")
    comparisons = [compare(cell, results) for cell in cells]
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    agents = cells[0].agents
    lines = [
        "# The JAX population learners against the Stable-Baselines3 learners they re-implement", "",
        f"Written by `{command}` on {stamp}, on {host()}. This call took {_duration(seconds)} of "
        f"wall time and computed {computed} of the {runs} runs ({finished} finished; the others "
        f"were kept from earlier calls of the same command, which resumes); the calls that "
        f"finished took {_duration(total_seconds)} together (an interrupted call's time is not "
        "counted).", "",
        f"Libraries: {versions()}.", "",
        "| task | pair | measure | " + "reference (95 % interval) | twin (95 % interval) | "
        "P(twin better) | verdict |", "|---|---|---|---|---|---|---|"]
    for comparison in comparisons:
        cell = comparison.cell
        reference, twin = cell.pair.names
        lines.append(
            f"| {cell.task} | {reference} / {twin} | {cell.measure.label} ({cell.measure.better}) | "
            f"{reference}: {comparison.estimates[reference].text(1)} | "
            f"{twin}: {comparison.estimates[twin].text(1)} | {comparison.improvement.text(2)} | "
            f"{verdict(comparison.improvement, reference, twin, comparison.agents)} |")
    lines += ["", "## Protocol", "",
              "- The pairs come from the registry: each population learner (trained as a whole "
              "population in one JAX program, `runners.population`) and the learner whose "
              "settings class its own subclasses (Stable-Baselines3's, one model per agent "
              "stepped by lwrl's loop): "
              + "; ".join(f"`{p.twin}` and `{p.reference}`" for p in dict.fromkeys(c.pair for c in cells))
              + ".",
              f"- {agents} agents per implementation, task and pair, seeds 0 to {agents - 1}: "
              "the same seeds, hence the same episode starts (`runners.episodes.episode_starts`), "
              "for both; each implementation draws its own random numbers from them (JAX's "
              "streams, PyTorch's and NumPy's), so agent b of one is not agent b of the other, "
              "only drawn from the same distribution. The comparison is between the two sets "
              "of agents, not agent by agent.",
              f"- The {plan.PLANT} plant for both (the population learners run on its JAX port "
              "only). Episodes per task: "
              + "; ".join(f"{task} {count}" + (" (" + ", ".join(
                  f"{name} {value:g}" if isinstance(value, float) else f"{name} {value}"
                  for name, value in options) + ")" if options else "")
                          for task, count, options in dict.fromkeys(
                              (c.task, c.episodes, tuple(sorted(c.task_options.items()))) for c in cells))
              + ".", *actions_lines(cells),
              f"- Settings: rl-baselines3-zoo's tuned set for the environment each domain is "
              f"tuned as (`agent.zoo.TUNED_AS`; {ZOO}), the same for both implementations "
              "(`runners.config.tuned_settings` of the reference learner), each task's section "
              "lists them field by field; the fields the zoo does not set keep the learners' "
              "defaults, SB3's." + untuned(cells),
              "- Measure: the paper's, per agent its mean over its episodes: the steps per "
              "episode where the task ends at a goal (fewer is better), the up-time per "
              "episode where it keeps one (more is better). Intervals: 95 % percentile "
              "bootstrap over agents; P(twin better): the probability that an agent of the "
              "twin does better than one of the reference (Agarwal et al. 2021), ties counting "
              "half; no difference found where its 95 % interval holds 0.5.",
              f"- Costs: `studies/implementations/costs.py`: each implementation timed on this "
              f"machine over the cell's configuration for {costs_module.COST_EPISODES} episodes "
              f"of at most {costs_module.COST_STEPS // costs_module.COST_EPISODES} steps (the "
              "reference one agent, the twin its whole population), wall clock "
              "and the process's CPU time (all its threads); multiplied by the agent-steps the "
              "study's agents took. The machine is shared with other work: wall times are "
              "upper bounds.",
              "- The sweep's calls (`timings.json`; one per seed, the populations in the first): "
              + (", ".join(f"seed {r['seed']} {_duration(r['wall_s'])} ({r['runs']} runs, "
                           f"{r['backend']})" for r in timings.get("rounds", []) if r["runs"])
                 or "none computed anything yet") + ".", ""]
    for comparison in comparisons:
        cell = comparison.cell
        reference, twin = cell.pair.names
        image = figure(comparison, results, figure_dir)
        lines += [f"## {cell.task}: {reference} and {twin}", "",
                  f"- {reference}: {plan.title(reference)}", f"- {twin}: {plan.title(twin)}", "",
                  f"**{verdict(comparison.improvement, reference, twin, comparison.agents)}**", "",
                  "### The settings of both (the translation)", ""]
        lines += translation_lines(cell)
        lines += ["### Results", "", f"![learning curves]({image})", "",
                  f"Left: the mean over agents per episode with its 95 % bootstrap interval; right: "
                  f"each agent's {cell.measure.label} and the mean's 95 % interval.", ""]
        lines += cost_lines(comparison, results, costs, timings)
        lines += [f"P({twin} better) = {comparison.improvement.text(2)}.", ""]
        if cell.key in initialisations:
            lines += ["### At initialisation", ""]
            lines += initialisation_lines(cell, initialisations[cell.key])
    lines += differences(cells, comparisons)
    lines += ["## Investigation notes", "",
              notes.strip() if notes.strip() else "None written yet (`notes.md` beside this report).", ""]
    path = os.path.join(out_dir, "report.md")
    with outputs.atomic_write(path, encoding="utf-8") as file:
        file.write("\n".join(lines))
    return path


def actions_lines(cells) -> list:
    """The protocol's line on the kind of action where it is not the paper's (discrete)."""
    kinds = [kind for kind in dict.fromkeys(cell.actions for cell in cells) if kind != "discrete"]
    return [f"- Actions: {', '.join(kinds)}: each task made with them (`actions`, `lwrl train "
            "--action-kind`), the control itself in the actuator's range, as both learners "
            "take it."] if kinds else []


def untuned(cells) -> str:
    """The sentences on the references the zoo has no tuned set for on a task's domain: both
    implementations take the reference's defaults, which its settings class states."""
    bare = {}
    for cell in cells:
        if not tuned_settings(cell.task, cell.pair.reference):
            bare.setdefault(cell.pair.reference, []).append(cell.task)
    sentences = []
    for name, found in bare.items():
        settings = learners.learner(name).settings
        stated = " ".join((settings.__doc__ or "").split()).rstrip(".")
        sentences.append(f" `{name}` has no tuned set for {', '.join(found)}: both take its "
                         f"defaults (`{settings.__name__}`: {stated}).")
    return "".join(sentences)


def differences(cells, comparisons) -> list:
    """Per pair, what differs between the implementations: what the population learner's
    module says, and the cells where the results differ."""
    lines = []
    for pair in dict.fromkeys(cell.pair for cell in cells):
        lines += [f"## What differs: {pair.reference} and {pair.twin}", ""]
        module, stated = plan.known_differences(pair.twin)
        lines += [f"From `{pair.twin}`'s own description (the docstring of `{module}`):"
                  if module else f"From `{pair.twin}`'s own description:", "",
                  "> " + (stated or "(it states none)"), ""]
        mine = [c for c in comparisons if c.cell.pair == pair]
        apart = [c for c in mine if c.outcome != 0]
        same = all(row.same for c in mine for row in plan.translation(c.cell))
        lines += [f"- Settings: {'the same, field by field, in every cell' if same else 'they differ (see the tables)'}.",
                  "- Random streams: see above; the comparison is distributional.",
                  "- Initialisation, optimiser and target updates: the tables \"At "
                  "initialisation\" compare the untrained networks; the investigation notes "
                  "below what was checked of the optimisers and the target updates."]
        if apart:
            lines.append("- **The results differ** in " + "; ".join(
                f"{c.cell.task} ({verdict(c.improvement, pair.reference, pair.twin, c.agents)})"
                for c in apart) + ": see the investigation notes.")
        else:
            lines.append("- The results: no difference found in any cell at this sample size.")
        lines.append("")
    return lines
