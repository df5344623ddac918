"""What the items that sweep lambda share: the paper's lambdas and traces, a grid of runs
over them, and the plot of a mean against lambda."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from lwrl.runners.config import RunConfig  # noqa: E402

LAMBDAS = (0.0, 0.4, 0.7, 0.8, 0.9, 0.95, 0.99)
"""The lambdas of Fig. 2 (Singh and Sutton's), used for every lambda sweep."""
TRACES = ("replacing", "accumulating")
SAME_AT_LAMBDA_0 = ("At λ = 0 the traces are one algorithm (with nothing carried over, eq. 2, "
                    "5 and 6 all make the trace the current gradient), so both traces' agents "
                    "are the same agents: a tie by construction.")


def grid(task, plant, integrator, traces, lambdas, alphas, agents, episodes, **fields):
    """RunConfigs over traces x lambdas x alphas, each with agents seeded 0..agents-1."""
    return [RunConfig(task=task, plant=plant, integrator=integrator, trace=trace, alpha=alpha,
                      lam=lam, agents=agents, episodes=episodes, **fields)
            for trace in traces for lam in lambdas for alpha in alphas]


def plot_against_lambda(lines: pd.DataFrame, ylabel: str, title: str, log: bool = False):
    """Mean at the chosen alpha against lambda, one line per (features, trace) and per data
    set (`label`: the paper-sized run's second half, the confirmation run), with 95 %
    bootstrap intervals; `log` for a logarithmic y axis."""
    figure, axes = plt.subplots(figsize=(6.5, 4.2))
    if log:
        axes.set_yscale("log")
    labels = list(dict.fromkeys(lines["label"]))
    for (label, features, trace), line in lines.groupby(["label", "features", "trace"], sort=False):
        style = "-" if label == labels[-1] else ":"
        error = [line["mean"] - line["low"], line["high"] - line["mean"]]
        axes.errorbar(line["lam"], line["mean"], yerr=error, marker="o", capsize=3,
                      linestyle=style, label=f"{features.upper()} {trace}, {label}")
    axes.set_xlabel("λ")
    axes.set_ylabel(ylabel)
    axes.set_title(title)
    axes.legend(fontsize=7)
    axes.grid(alpha=0.3)
    return figure
