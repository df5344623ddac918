"""`lwrl bench`'s report (`README.md` in its output directory): per task a table of every
learner with 95 % bootstrap intervals and the probability of improvement of the paper's
agent against each, its costs (`bench_costs`), the verdict of the light-weight claim by
docs/FINDINGS.md's rule, Pareto figures and learning curves."""

import datetime
import math
import os

import matplotlib.pyplot as plt
import numpy as np

from lwrl import outputs
from lwrl.agent.stable_baselines import ZOO
from lwrl.analysis import statistics as st
from lwrl.analysis.plots import plot_learning_curve, save_figure
from lwrl.studies.paper import bench_protocol as protocol
from lwrl.studies.paper import bench_search

RIVALS = ("dqn", "ppo")
COMPUTE_FRACTION = 1 / 100
"""docs/FINDINGS.md's rule: at most this fraction of a baseline's CPU per learning step."""


def per_agent(results, config, column) -> np.ndarray:
    """Each agent's mean of `column` over its episodes (NaN: a diverged agent)."""
    rows = results[results["run"] == config.key]
    table = rows.pivot_table(index="seed", columns="episode", values=column)
    return table.mean(axis=1).to_numpy(), table


def verdict(outcomes: dict) -> str:
    """FINDINGS' rule: yes against both baselines (better and at most 1/100 of the CPU), no
    where better against neither, partly otherwise."""
    if not outcomes:
        return "not judged (no baseline ran)"
    both = all(better and cheap for better, cheap in outcomes.values())
    if both and len(outcomes) == len(RIVALS):
        return "yes"
    if not any(better for better, _ in outcomes.values()):
        return "no"
    return "partly"


def _number(x, digits=1) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _bytes(x) -> str:
    return "—" if x is None else f"{x:,}".replace(",", " ")


def task_section(task, cells, results, costs, figure_dir) -> tuple[list, str]:
    """The task's lines of the report and its verdict."""
    bench = protocol.TASKS[task]
    measure = bench.measure
    rows = [(label, config) for t, label, config in cells if t == task]
    values = {label: per_agent(results, config, measure.column) for label, config in rows}
    paper = values.get("paper", (None,))[0]
    paper_cost = costs.get(dict(rows)["paper"].key, {}) if "paper" in dict(rows) else {}
    lines = [f"## {task}", "", f"Measure: {measure.label} over the run's {bench.episodes} episodes "
             f"({measure.source}; {'more' if measure.higher_is_better else 'fewer'} is better), one number per "
             f"agent; criterion for the time until it is met: an agent's mean "
             f"{'at least' if measure.higher_is_better else 'at most'} {measure.criterion:g} to the end. "
             f"{bench.cut}", "",
             "| learner | measure (95 % interval) | P(paper's agent better) | episode from which the mean "
             "meets the criterion | CPU µs per learning step | × paper's | CPU µs per greedy decision | "
             "parameter bytes | memory bytes (learner's estimate) | peak RSS MB | CPU s until the criterion | "
             "C bytes (code + data) | C instructions per decision |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    outcomes, points = {}, []
    for label, config in rows:
        agents, table = values[label]
        estimate = st.mean_interval(agents)
        cost = costs.get(config.key, {})
        improvement = (st.improvement_interval(paper, agents, measure.higher_is_better)
                       if label != "paper" and paper is not None else None)
        mean_curve = table.mean(axis=0).to_numpy()
        met = mean_curve >= measure.criterion if measure.higher_is_better else mean_curve <= measure.criterion
        episode = int(st.first_from_which(met)) if len(mean_curve) else None
        step = cost.get("cpu_s_per_learning_step")
        steps_table = results[results["run"] == config.key].pivot_table(index="seed", columns="episode", values="steps")
        until = (float(steps_table.iloc[:, :episode].sum(axis=1).mean() * step)
                 if step is not None and episode is not None and episode <= len(mean_curve) else None)
        ratio = step / paper_cost["cpu_s_per_learning_step"] if step and paper_cost.get("cpu_s_per_learning_step") else None
        c_bytes = (cost["c_code_bytes"] + cost["c_rodata_bytes"]) if "c_code_bytes" in cost else None
        instructions = cost.get("c_instructions_per_decision")
        lines.append(
            f"| {label} | {estimate.text(1)} | {improvement.text(2) if improvement else '—'} | "
            f"{'never' if episode is None or episode > len(mean_curve) else episode} | "
            f"{_number(step * 1e6 if step else None)} | {_number(ratio, 1)} | "
            f"{_number(cost['cpu_s_per_greedy_decision'] * 1e6 if 'cpu_s_per_greedy_decision' in cost else None)} | "
            f"{_bytes(cost.get('parameter_bytes'))} | {_bytes(cost.get('memory_bytes'))} | "
            f"{_number(cost['peak_rss_bytes'] / 2**20 if 'peak_rss_bytes' in cost else None, 0)} | "
            f"{_number(until, 2)} | {_bytes(c_bytes)} | {_number(instructions, 0)} |")
        if label in RIVALS and improvement is not None:
            cheap = (paper_cost.get("cpu_s_per_learning_step") is not None and step is not None
                     and paper_cost["cpu_s_per_learning_step"] <= COMPUTE_FRACTION * step)
            outcomes[label] = (st.outcome(improvement) == 1, cheap)
        points.append((label, estimate, step, cost.get("parameter_bytes")))
    result = verdict(outcomes)
    lines += ["", f"**Light-weight claim on {task}: {result}** — " + "; ".join(
        f"against {label}: {'better' if better else 'not better'} on the measure, "
        f"{'at most' if cheap else 'more than'} 1/100 of its CPU per learning step"
        for label, (better, cheap) in outcomes.items()) + ".", ""]
    lines += _figures(task, rows, results, points, measure, figure_dir)
    lines += ["Settings of each row (written by the learner, `describe`):", ""]
    lines += [f"- {label}: {config.describe()}" for label, config in rows] + [""]
    return lines, result


def _figures(task, rows, results, points, measure, figure_dir) -> list:
    """The learning curves of every learner on one plot, and the two Pareto figures."""
    figure, axes = plt.subplots(figsize=(7, 4.5))
    for label, config in rows:
        plot_learning_curve(results[results["run"] == config.key], measure.column, measure.label,
                            f"{task}: every learner", axes=axes, interval=True, label=label)
    handles, labels = axes.get_legend_handles_labels()
    keep = [i for i, text in enumerate(labels) if "interval" not in text]
    axes.legend([handles[i] for i in keep], [labels[i] for i in keep], fontsize=8)
    save_figure(figure, figure_dir, f"{task}-curves")
    plt.close(figure)
    pareto, panels = plt.subplots(1, 2, figsize=(11, 4.5))
    for panel, (index, xlabel) in zip(panels, ((2, "CPU s per learning step"), (3, "parameter bytes"))):
        for label, estimate, *xs in points:
            x = xs[index - 2]
            if x is None:
                continue
            error = [[estimate.value - estimate.low], [estimate.high - estimate.value]] \
                if not math.isnan(estimate.low) else None
            panel.errorbar([x], [estimate.value], yerr=error, fmt="o", capsize=3, label=label)
            panel.annotate(label, (x, estimate.value), textcoords="offset points", xytext=(4, 4), fontsize=8)
        panel.set_xscale("log")
        if not measure.higher_is_better:
            panel.set_yscale("log")
        panel.set_xlabel(xlabel)
        panel.set_ylabel(measure.label)
        panel.grid(alpha=0.3, which="both")
    panels[0].set_title(f"{task}: measure against compute")
    panels[1].set_title(f"{task}: measure against size")
    save_figure(pareto, figure_dir, f"{task}-pareto")
    plt.close(pareto)
    return [f"![learning curves](figures/{task}-curves.png)", "",
            f"![Pareto figures](figures/{task}-pareto.png)", ""]


def _baseline_speed(costs) -> str:
    """The range of the baselines' CPU per learning step, as words."""
    steps = [cost["cpu_s_per_learning_step"] for cost in costs.values() if cost.get("label") in RIVALS]
    if not steps:
        return "no baseline's cost was measured"
    return (f"a DQN or PPO agent takes {min(steps) * 1e3:.2f} to {max(steps) * 1e3:.2f} ms of CPU per "
            f"learning step here (the tables), so one agent's run of the protocol takes minutes to hours")


JOINING = """## Adding a learner and getting its row

A learner is one module of `agent/` ending with `LEARNER = Learner(...)` (the contract,
`agent/learner_contract.py`; `agent/sarsa.py`, `agent/true_online_sarsa.py`, `agent/ase_ace.py`
and `agent/dqn.py` are examples) and one line of `LEARNER_MODULES` in `agent/__init__.py`; the
contract tests (`tests/test_learners.py`) hold it to the contract without an edit. Its row
here is one more entry of `learners()` in `studies/paper/bench_protocol.py` (a label, the
learner's name and its settings); then

    lwrl bench all --learners paper,LABEL --out DIR

runs it beside the paper's agent under the same protocol (the runs already made are kept)
and writes this page with its row, its costs and its points on the figures."""


def write(cells, results, costs, out_dir: str, command: str, seconds: float,
          total_seconds: float, computed: int, search: tuple) -> str:
    """Write `README.md` and the figures to `out_dir`; return the report's path. `search`:
    the baselines' candidates, the chosen ones and the candidates' results
    (`bench_search`)."""
    figure_dir = os.path.join(out_dir, "figures")
    costs = {config.key: costs[config.key] for _, _, config in cells if config.key in costs}
    tasks = list(dict.fromkeys(task for task, _, _ in cells))
    agents = cells[0][2].agents
    sections, verdicts = [], {}
    for task in tasks:
        lines, verdicts[task] = task_section(task, cells, results, costs, figure_dir)
        sections += lines + bench_search.table(task, *search)
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Benchmark: every learner under the paper's protocol, and what each costs", "",
        f"Written by `{command}` on {stamp}; this call took {seconds / 60:.1f} min of wall "
        f"time and computed {computed} of the {len(cells) + sum(map(len, search[0].values()))} "
        "runs, the search's among them (the others were kept from an "
        f"earlier call of the same command, which resumes); the calls that finished took "
        f"{total_seconds / 60:.1f} min together (an interrupted call's time is not counted).", "",
        "| task | light-weight claim (docs/FINDINGS.md's rule) |", "|---|---|",
        *[f"| {task} | **{verdicts[task]}** |" for task in tasks], "",
        "## Protocol", "",
        f"- {agents} agents per learner and task (seeds 0 to {agents - 1}), the same seeds, "
        "episodes and starts for every learner, on the "
        f"{cells[0][2].plant_name} plant. {agents} agents per cell is what the study affords "
        f"on this {os.cpu_count()}-core machine, shared with other work: {_baseline_speed(costs)}; "
        "the intervals are wide accordingly.",
        "- The paper's agent (`paper`) is NRBF Sarsa(λ) with the task's settings (`lwrl train`'s "
        "defaults); its other trace, true online Sarsa(λ), the CMAC (Mountain-Car) and ASE/ACE "
        "(the cart-pole) stand beside it.",
        f"- DQN and PPO: Stable-Baselines3 2.9.2 on PyTorch 2.13.0 (CPU), with rl-baselines3-zoo's "
        f"tuned sets ({ZOO}; each domain names the environment whose set its tasks take, "
        "`Domain.tuned_as`, and `agent/stable_baselines.py` what does not carry over) as the start, "
        f"then a small search per task (`studies/paper/bench_search.py`): the zoo's set, its "
        f"learning rate {' and '.join(f'{f:g}' for f in bench_search.FACTORS)} times as large, "
        f"and its horizon and warm-up {bench_search.SHORTER} times shorter (the zoo's are for "
        "Gymnasium's budgets of 50 000 steps and more), "
        f"{bench_search.AGENTS} agents each on seeds of their own ({bench_search.SEED} on), "
        "the row taking the best mean; each task's section lists the candidates. Its budget: "
        f"{len(bench_search.FACTORS) + 2} x {bench_search.AGENTS} agents per baseline and task, "
        "about what the row costs.",
        "- Terminal states are kept apart from truncations (DQN: the replay buffer's "
        "`handle_timeout_termination`; PPO: the truncated state's value bootstraps).",
        "- Intervals: 95 % percentile bootstrap over agents; P(paper's agent better): the "
        "probability of improvement (Agarwal et al. 2021), ties counting half "
        "(`lwrl.analysis.statistics`).",
        "- Costs: `studies/paper/bench_costs.py` says how each is measured: one agent, one "
        "thread, each learner's own fast path; CPU per learning step includes the plant. C "
        "controllers: `lwrl.export.c`, compiled with the same flags (`-Os` for the sizes, "
        "`-O2` for the instruction counts, callgrind over 1000 decisions).", "",
        *sections, JOINING, ""]
    path = os.path.join(out_dir, "README.md")
    with outputs.atomic_write(path, encoding="utf-8") as file:
        file.write("\n".join(lines))
    return path
