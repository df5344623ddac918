"""Table 1: the episode by which most cart-pole agents have learned to balance the pole
(section 4.3). It reads Fig. 8's runs."""

import math

import numpy as np

from lwrl.analysis import statistics as st
from lwrl.analysis.plots import Evidence
from lwrl.studies.paper.judging import (CELL, Section, at, at_cells, choose, confirmation_text,
                                        episode_text, matrix, merge_confirmation, per_agent)

CARTPOLE_FULL_S = 0.999 * 240.0
"""Cart-pole: an episode balanced for the whole 240 s (up to the last step's rounding)."""
LEARNED_WINDOW = 10
"""Table 1: an agent has learned to balance once it balances the whole 240 s in this many
consecutive episodes (the paper's agents may un-learn later: its section 4.3)."""


def _choice(results):
    return choose(per_agent(results, "uptime_s"), "uptime_s", False, ("features", "trace"),
                  ("lam", "alpha"))


def confirm(configs, results, agents):
    """Fresh agents at each trace's best (lambda, alpha), chosen on the first half."""
    return at_cells(configs, _choice(results).cells, agents)


def _most(episodes, axis=-1):
    """The episode by which most (more than half) of the agents got there: the
    (n // 2 + 1)-th smallest of their episodes."""
    episodes = np.sort(episodes, axis=axis)
    return np.take(episodes, episodes.shape[axis] // 2, axis=axis)


def _learned(uptime):
    """The episode by which most agents have learned to balance: each agent's first run of
    `LEARNED_WINDOW` consecutive episodes balanced for the whole 240 s."""
    return _most(st.first_run_of(uptime >= CARTPOLE_FULL_S, LEARNED_WINDOW))


def _stay_learned(uptime):
    return _most(st.first_from_which(uptime >= CARTPOLE_FULL_S))


def _touched(uptime):
    return _most(st.first_run_of(uptime >= CARTPOLE_FULL_S, 1))


def longest_run(condition) -> int:
    """The longest run of consecutive episodes where `condition` (agents x episodes) holds,
    over all agents."""
    longest = 0
    for row in np.asarray(condition, dtype=bool):
        edges = np.diff(np.concatenate([[0], row.astype(int), [0]]))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        longest = max(longest, int((ends - starts).max()) if len(starts) else 0)
    return longest


def judge(results, cells):
    rows, best, evidence = [], math.inf, []
    for _, cell in cells.iterrows():
        runs = at(results, cell)
        uptime = matrix(runs, "uptime_s")
        agents, episodes = uptime.shape
        full = uptime >= CARTPOLE_FULL_S
        learned = st.matrix_interval(_learned, uptime)
        learners = int((st.first_run_of(uptime >= CARTPOLE_FULL_S, LEARNED_WINDOW) <= episodes).sum())
        best = min(best, learned.value)
        name = f"{cell['trace']} (best: λ {cell['lam']:g}, α {cell['alpha']:g})"
        evidence.append(Evidence("Table 1: the episode by which most agents have learned to "
                                 f"balance (240 s in {LEARNED_WINDOW} episodes in a row)", name,
                                 learned, (50, 200), paper=100, never=episodes))
        rows += [(f"{name}: episode by which most agents have learned to balance (the whole "
                  f"240 s in each of {LEARNED_WINDOW} consecutive episodes)",
                  f"{episode_text(learned, episodes)} ({learners} of {agents} agents learn)",
                  "about 100"),
                 (f"{name}: the same, balancing in every episode from then to the end",
                  episode_text(st.matrix_interval(_stay_learned, uptime), episodes), "—"),
                 (f"{name}: the same, balancing the whole 240 s once (touching once, as the earlier rule did)",
                  f"{episode_text(st.matrix_interval(_touched, uptime), episodes)} (longest "
                  f"{uptime.max():.0f} s)", "—"),
                 (f"{name}: fraction of episodes balanced the whole 240 s, episodes "
                  f"{episodes // 2 + 1} to {episodes}, mean over agents; the longest run of "
                  "such episodes of any agent",
                  f"{st.mean_interval(full[:, episodes // 2:].mean(axis=1)).text(2)}; "
                  f"{longest_run(full)}", "—"),
                 (f"{name}: mean up-time over agents and all episodes (s)",
                  st.mean_interval(uptime.mean(axis=1)).text(), "—")]
    episodes = int(results["episode"].max())
    verdict = "yes" if 50 <= best <= 200 else "partly" if best <= episodes else "no"
    rule = (f"most agents of the better trace's best configuration have learned to balance "
            f"(240 s in each of {LEARNED_WINDOW} consecutive episodes) by episode "
            f"{'never' if best > episodes else f'{best:g}'}; yes if by 50 to 200 (the paper's "
            "about 100; the literature's 20 to 200), partly if most learn but outside that "
            "range, no if most never do")
    return rows, verdict, rule, evidence


def analyse(results, figure_dir, confirmation=None):
    del figure_dir
    choice = _choice(results)
    measured = results.merge(choice.measured[list(CELL) + ["seed"]], on=list(CELL) + ["seed"])
    rows, verdict, rule, evidence = judge(measured, choice.cells)
    section = Section(rows, verdict, rule, [], [], evidence=evidence,
                      claim="“Table 1 indicates approximate numbers for how many episodes were "
                            "required before most agents have successfully learned to balance "
                            "the pole.” (section 4.3; Table 1: this paper, 100)",
                      measure="per agent, the first episode of a run of "
                              f"{LEARNED_WINDOW} consecutive episodes balanced for the whole "
                              "240 s; the episode by which more than half of the agents got "
                              "there, at each trace's best λ and α (by mean up-time): "
                              f"{choice.how}")
    if confirmation is not None:
        merge_confirmation(section, judge(confirmation, choice.cells),
               confirmation_text(confirmation))
    return section
