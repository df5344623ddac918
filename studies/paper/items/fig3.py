"""Fig. 3: the best Mountain-Car agent's learning curve, and the episode from which it stays
converged (section 4.1)."""

import math

import numpy as np

from lwrl.analysis import statistics as st
from lwrl.analysis.plots import Evidence, plot_learning_curve, save_figure
from lwrl.runners.config import RunConfig
from lwrl.studies.paper.judging import Section, episode_text, matrix, score_verdict, seeds_text

SETTLE_WINDOW = 5
"""Fig. 3: the curve is judged through its mean over this many episodes."""
SAME_AT_LAMBDA_0 = ("At λ = 0 the traces are one algorithm (with nothing carried over, eq. 2, "
                    "5 and 6 all make the trace the current gradient), so both traces' agents "
                    "are the same agents: a tie by construction.")


def configs(plant, quick, integrator):
    del plant, integrator
    return [RunConfig(task="mountain_car.cost_to_go", plant="analytic", trace="replacing",
                      alpha=3.9, lam=0.9, agents=3 if quick else 30, episodes=10 if quick else 100)]


def _level(steps, axis=-2):
    """The converged level: the mean over agents of the last 20 episodes (or fewer)."""
    return steps[..., -min(20, steps.shape[-1]):].mean(axis=(-2, -1))


def _settled(steps, stays: bool = True):
    """The first episode from which (`stays`) or at which (not `stays`) the mean over agents,
    averaged over `SETTLE_WINDOW` episodes, is within 10 % of the converged level."""
    curve = steps.mean(axis=-2)
    window = st.rolling_mean(curve, SETTLE_WINDOW)
    within = window <= 1.1 * _level(steps)[..., None]
    if stays:
        return st.first_from_which(within)
    return np.where(within.any(axis=-1), np.argmax(within, axis=-1) + 1, within.shape[-1] + 1)


def analyse(results, figure_dir, confirmation=None):
    del confirmation
    figure, _ = plot_learning_curve(results, "steps", "steps per episode",
                                    "Fig. 3: Mountain-Car, replacing, α 3.9, λ 0.9", interval=True)
    figures = save_figure(figure, figure_dir, "fig3")
    steps = matrix(results, "steps")
    episodes = steps.shape[1]
    level = st.matrix_interval(_level, steps)
    settled = st.matrix_interval(_settled, steps)
    touched = st.matrix_interval(lambda m: _settled(m, stays=False), steps)
    middle = (st.mean_interval(steps[:, 30:40].mean(axis=1)) if episodes >= 40
              else st.Estimate(math.nan, math.nan, math.nan))
    rows = [(f"mean steps over agents, last {min(20, episodes)} episodes: the converged level",
             level.text(), "about 60"),
            (f"first episode from which the {SETTLE_WINDOW}-episode mean stays within 10 % "
             "of that level to the end", episode_text(settled, episodes), "about 40"),
            ("mean steps, episodes 31 to 40", middle.text(), "about 60"),
            (f"first episode whose {SETTLE_WINDOW}-episode mean is within 10 % of that level "
             "(touched once; the earlier rule)", episode_text(touched, episodes), "—")]
    score = int(50 <= level.value <= 75) + int(20 <= settled.value <= 60)  # numpy bools would add as "or"
    rule = (f"yes if the converged level ({level.value:.1f}) is within 50 to 75 steps and the "
            f"curve settles there to stay within 20 to 60 episodes ({settled.value:g}); "
            "partly if one holds")
    agents = f"mean over {len(steps)} agents"
    evidence = [Evidence("Fig. 3: the converged level (steps per episode)", agents, level,
                         (50, 75), paper=60),
                Evidence("Fig. 3: the episode from which the curve stays converged", agents,
                         settled, (20, 60), paper=40, never=episodes)]
    return Section(rows, score_verdict(score, yes=2, partly=1), rule, [], figures, evidence=evidence,
                   claim="“Convergence to an average of 60 steps per episode is achieved after "
                         "about 40 episodes.” (section 4.1, Fig. 3: replacing, α 3.9, λ 0.9)",
                   measure="the mean over agents of the steps per episode (the curve of Fig. 3); "
                           f"converged: its {SETTLE_WINDOW}-episode mean stays within 10 % of "
                           f"the level of the last 20 episodes to the end ({seeds_text(results)})")
