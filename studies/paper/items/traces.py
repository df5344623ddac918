"""Fig. 6 (pendulum) and Fig. 8 (cart-pole): the mean up-time against lambda at the best
alpha, replacing against accumulating traces (sections 4.2 and 4.3), with the modern answer
to the paper's question of which trace beside them: true online Sarsa(lambda)'s dutch trace
(van Seijen et al. 2016; not in the paper), on the same grid, outside the verdict."""

import numpy as np
import pandas as pd

from lwrl.analysis import statistics as st
from lwrl.analysis.plots import Evidence, save_figure
from lwrl.studies.paper.items.sweep import LAMBDAS, SAME_AT_LAMBDA_0, TRACES, grid, plot_against_lambda
from lwrl.studies.paper.judging import (Section, at, at_cells, choose, confirmation_text,
                                        merge_confirmation, per_agent, trace_verdict)

PENDULUM_ALPHAS = tuple(round(0.1 + 0.2 * i, 1) for i in range(15))
"""0.1 to 2.9 in steps of 0.2 (the paper's best, 1.5, in the middle)."""
CARTPOLE_ALPHAS = tuple(round(0.1 + 0.2 * i, 1) for i in range(8))
"""0.1 to 1.5 in steps of 0.2 (the author's best, 0.5, inside)."""
DUTCH = "dutch"
"""True online Sarsa(lambda)'s trace, as its runs' `trace` column reads."""
TRUE_ONLINE = {"learner": "true_online_sarsa"}
DUTCH_NOTE = ("True online Sarsa(λ) with its dutch trace (van Seijen et al. 2016) is not in the "
              "paper: it is the modern answer to the paper's question of which trace, run here "
              "on the same grid of λ and α, its α chosen the same way; its rows stand beside "
              "the paper's traces and the verdict judges those two only.")


def with_dutch(task, plant, integrator, lambdas, alphas, agents, episodes):
    """The paper's two traces over lambdas x alphas, and true online Sarsa(lambda) on the
    same grid."""
    return (grid(task, plant, integrator, TRACES, lambdas, alphas, agents, episodes)
            + grid(task, plant, integrator, (DUTCH,), lambdas, alphas, agents, episodes,
                   **TRUE_ONLINE))


def fig6_configs(plant, quick, integrator):
    if quick:
        return with_dutch("pendulum.swingup", plant, integrator, (0.4,), (1.5,), 2, 3)
    return with_dutch("pendulum.swingup", plant, integrator, LAMBDAS, PENDULUM_ALPHAS, 10, 200)


def fig8_configs(plant, quick, integrator):
    if quick:
        return with_dutch("cartpole.balance", plant, integrator, (0.7,), (0.5,), 2, 5)
    return with_dutch("cartpole.balance", plant, integrator, LAMBDAS, CARTPOLE_ALPHAS, 10, 200)


def _best_alpha_choice(results):
    return choose(per_agent(results, "uptime_s"), "uptime_s", False,
                  ("features", "trace", "lam"), ("alpha",))


def confirm(configs, results, agents):
    """Fig. 6 and Fig. 8: fresh agents at the best alpha per trace and lambda (chosen on the
    first half of the paper-sized run's seeds)."""
    return at_cells(configs, _best_alpha_choice(results).cells, agents)


def _compare_traces(measured, cells, better, other, label, figure, paper=None):
    """Per lambda, both traces' mean up-time at their chosen alpha on `measured` agents and
    the probability that `better` does better: rows, outcomes, the figure's points and the
    evidence (`figure`: the paper's figure, naming the panel; `paper`: the rows' paper
    column, by default that `better` is slightly better)."""
    rows, outcomes, lines, evidence = [], [], [], []
    for lam in sorted(cells["lam"].unique()):
        parts, samples = [], {}
        for trace in (better, other):
            cell = cells[(cells["trace"] == trace) & np.isclose(cells["lam"], lam)]
            if not len(cell):
                continue
            values = at(measured, cell.iloc[0])["uptime_s"].to_numpy()
            samples[trace] = values
            estimate = st.mean_interval(values)
            lines.append(dict(features=cell.iloc[0]["features"], trace=trace, lam=lam,
                              mean=estimate.value, low=estimate.low, high=estimate.high, label=label))
            parts.append(f"{trace} {estimate.text(unit='s')} (α {cell.iloc[0]['alpha']:g})")
        if len(samples) == 2:
            improvement = st.improvement_interval(samples[better], samples[other])
            outcomes.append(st.outcome(improvement))
            evidence.append(Evidence(f"{figure}: P({better} has the longer up-time than "
                                     f"{other}) at the best α", f"λ {lam:g}", improvement,
                                     (0.5, 1.0)))
            word = {1: f"{better} better", -1: f"{other} better", 0: "a tie not excluded"}
            parts.append(f"P({better} > {other}) {improvement.text(2)}: {word[outcomes[-1]]}")
        rows.append((f"λ = {lam:g}: mean up-time at the best α; probability of improvement"
                     + ("" if paper is None else f" of {better} over {other}"),
                     "; ".join(parts), f"{better} slightly better" if paper is None else paper))
    return rows, outcomes, lines, evidence


def _dutch_beside(measured, cells, better, label, figure):
    """Rows and the figure's points of true online Sarsa(lambda) against the paper's better
    trace, per lambda (no evidence for the paper's claims); none without its runs."""
    if DUTCH not in set(cells["trace"]):
        return [], []
    rows, _, lines, _ = _compare_traces(measured, cells, DUTCH, better, label, figure,
                                        paper="not in the paper")
    return rows, [line for line in lines if line["trace"] == DUTCH]


def _trace_rule(outcomes, better, other):
    verdict, wins, losses, ties = trace_verdict(outcomes)
    n = len(outcomes)
    rule = (f"{better} better (the interval of P({better} > {other}) above 1/2) at {wins}, "
            f"{other} better (below 1/2) at {losses}, a tie not excluded at {ties} of {n} λ; "
            f"yes if {other} is better at no λ and {better} at half of them or more, no if "
            f"{other} is better at more λ than {better}, partly otherwise")
    return verdict, rule


def _uptime_against_lambda(results, figure_dir, name, title, better, sensitive, claim,
                           confirmation=None):
    """Best alpha per (trace, lambda) by mean up-time, chosen on the first half of the seeds
    and judged on the second half and on the confirmation run; `better`: the trace the paper
    finds better; `sensitive`: the trace it finds more sensitive to alpha (None: similar)."""
    agents = per_agent(results, "uptime_s")
    choice = _best_alpha_choice(results)
    other = "accumulating" if better == "replacing" else "replacing"
    figure = title.split(":")[0]
    label = "paper-sized run, second half"
    rows, outcomes, lines, evidence = _compare_traces(choice.measured, choice.cells, better,
                                                      other, label, figure)
    dutch_rows, dutch_lines = _dutch_beside(choice.measured, choice.cells, better, label, figure)
    rows, lines = rows + dutch_rows, lines + dutch_lines
    verdict, rule = _trace_rule(outcomes, better, other)
    spreads = []
    for trace, cells in agents.groupby("trace"):
        runs = [cell["uptime_s"].to_numpy() for _, cell in cells.groupby(["lam", "alpha"])
                if cell["uptime_s"].notna().all()]
        spreads.append(f"{trace}: {st.range_interval(runs).text(unit='s')}")
    rows.append(("range of the mean up-time over α (largest − smallest mean of a cell), all λ, "
                 "every agent", "; ".join(spreads),
                 f"{sensitive} more sensitive to α" if sensitive else "similar sensitivity"))
    notes = [SAME_AT_LAMBDA_0] + ([DUTCH_NOTE] if dutch_rows else [])
    section = Section(rows, verdict, rule, notes, [], claim=claim, evidence=evidence,
                      measure="each agent's mean up-time over its 200 episodes, at the best α "
                              f"per trace and λ: {choice.how}; “better”: the probability that "
                              "an agent of one trace has the longer up-time than one of the "
                              "other, with its interval")
    if confirmation is not None:
        confirmed_agents = per_agent(confirmation, "uptime_s")
        confirmed_rows, confirmed_outcomes, confirmed_lines, confirmed_evidence = _compare_traces(
            confirmed_agents, choice.cells, better, other, "confirmation run", figure)
        confirmed_dutch, confirmed_dutch_lines = _dutch_beside(
            confirmed_agents, choice.cells, better, "confirmation run", figure)
        confirmed_rows += confirmed_dutch
        lines += confirmed_lines + confirmed_dutch_lines
        merge_confirmation(section, (confirmed_rows, *_trace_rule(confirmed_outcomes, better, other),
                         confirmed_evidence), confirmation_text(confirmation))
    section.figures = save_figure(plot_against_lambda(pd.DataFrame(lines), "average up-time (s)",
                                                      title), figure_dir, name)
    return section


def fig6_analyse(results, figure_dir, confirmation=None):
    return _uptime_against_lambda(
        results, figure_dir, "fig6", "Fig. 6: pendulum, best α per λ", better="replacing",
        sensitive="accumulating", confirmation=confirmation,
        claim="“As shown in Figure 6, the replacing trace consistently gives slightly better "
              "performance than the accumulating trace for this task. Learning results are "
              "also much more sensitive to the value of the learning rate for the accumulating "
              "trace than for the replacing trace.” (section 4.2)")


def fig8_analyse(results, figure_dir, confirmation=None):
    return _uptime_against_lambda(
        results, figure_dir, "fig8", "Fig. 8: cart-pole, best α per λ", better="accumulating",
        sensitive=None, confirmation=confirmation,
        claim="“The results shown in Figure 8 differ from those of the previous tasks by the "
              "fact that the accumulating trace performs slightly better than the replacing "
              "trace and that the parameter sensitivity is quite similar for both trace types "
              "in this task.” (section 4.3)")
