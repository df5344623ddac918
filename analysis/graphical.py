"""The graphical approach to sequentially rejective multiple test procedures (Bretz, Maurer,
Brannath & Posch 2009, "A graphical approach to sequentially rejective multiple test
procedures", Stat. Med. 28:586-604), with the third benchmark's graph of its margin tests.

A procedure is a graph: m hypotheses H_i with initial weights w_i >= 0 (sum w_i <= 1; H_i is
first tested at level alpha w_i) and a transition matrix G = (g_ij), g_ij >= 0, g_ii = 0,
sum_j g_ij <= 1 (the share of H_i's level that passes to H_j once H_i is rejected). Their
Algorithm 1, over the open set I = {1, ..., m}:

1. select a j in I with p_j <= alpha w_j; stop where there is none;
2. reject H_j, I <- I \\ {j}, and update the graph, for l, k in I, l != k:
   w_l <- w_l + w_j g_jl,
   g_lk <- (g_lk + g_lj g_jk) / (1 - g_lj g_jl) where g_lj g_jl < 1, else 0;
3. go to 1 while I is not empty.

Which j is selected in step 1 does not change what is rejected (their Theorem 1); the graph
is a shortcut of a closed test with weighted Bonferroni tests of the intersections, so the
family-wise error rate is alpha however the tests depend on each other. Their Algorithm 2
gives the adjusted p-values: take j = argmin_{i in I} p_i / w_i, set q_j = max(p_j / w_j,
q_max) and q_max = q_j, update the graph as above, until I is empty; H_j is rejected at
alpha iff min(q_j, 1) <= alpha.

Holm's procedure is the graph with w_i = 1/m and g_ij = 1/(m - 1) (Bretz et al. 2009,
Sec. 3): a rejected hypothesis passes its level to the others still open in equal parts.
"""

import numpy as np

from lwrl.analysis import power

NOT_WORSE, WORSE, BETTER = "not worse", "worse", "better"
HYPOTHESES = (NOT_WORSE, WORSE, BETTER)
"""A comparison's three hypotheses in the rule's family (docs/FINDINGS.md, the third
benchmark's rule), in the order `margin_graph` numbers them: "not worse" (H0: d <= -margin),
"worse" (H0: d >= 0) and "better" (H0: d <= 0), d = mean(light) - mean(rival)."""


def check_graph(weights, transitions) -> tuple:
    """`(w, G)` as float arrays, or a one-line ValueError naming what is wrong: w a vector of
    m weights >= 0 summing to at most 1, G an m x m matrix of weights >= 0 with a zero
    diagonal and rows summing to at most 1 (Bretz et al. 2009, Sec. 2)."""
    w, g = np.asarray(weights, dtype=float), np.asarray(transitions, dtype=float)
    tolerance = 1e-12
    if w.ndim != 1 or len(w) == 0 or not np.all(np.isfinite(w)) or np.any(w < 0) or (
            w.sum() > 1 + tolerance):
        raise ValueError("a graph's weights must be a non-empty vector of numbers >= 0 whose "
                         f"sum is at most 1; got {w.tolist()}")
    if g.shape != (len(w), len(w)) or not np.all(np.isfinite(g)) or np.any(g < 0) or np.any(
            np.diag(g) != 0) or np.any(g.sum(axis=1) > 1 + tolerance):
        raise ValueError(f"a graph's transitions must be a {len(w)} x {len(w)} matrix of "
                         "numbers >= 0 with a zero diagonal and rows summing to at most 1")
    return w, g


def _check_p_values(p, m: int):
    """The p-values as a float vector of `m` values in [0, 1], or a one-line ValueError."""
    p = np.asarray(p, dtype=float)
    if p.shape != (m,) or not np.all((p >= 0) & (p <= 1)):
        raise ValueError(f"the graph needs {m} p-values, each in [0, 1]; got {p.tolist()}")
    return p


def _reject(j: int, w, g, open_):
    """Step 2 of Algorithm 1: H_j rejected, its weight passed along G, G updated among the
    hypotheses still open (`open_` a boolean mask, updated in place; `w`, `g` replaced)."""
    open_[j] = False
    w = np.where(open_, w + w[j] * g[j], 0.0)
    through = np.outer(g[:, j], g[j])  # g_lj g_jk
    denominator = 1.0 - g[:, j] * g[j, :]  # 1 - g_lj g_jl, per l
    with np.errstate(divide="ignore", invalid="ignore"):
        updated = np.where(denominator[:, None] > 0, (g + through) / denominator[:, None], 0.0)
    keep = np.outer(open_, open_)
    np.fill_diagonal(keep, False)
    return w, np.where(keep, updated, 0.0)


def rejected(p, weights, transitions, alpha: float = 0.05):
    """Which hypotheses the graphical procedure rejects at family-wise `alpha` (Algorithm 1;
    of several rejectable, the one with the smallest p_j / w_j first)."""
    w, g = check_graph(weights, transitions)
    p = _check_p_values(p, len(w))
    power.level(alpha, 1)  # alpha in (0, 1), or a ValueError
    open_ = np.ones(len(w), dtype=bool)
    while True:
        rejectable = open_ & (w > 0) & (p <= alpha * w)
        if not rejectable.any():
            return ~open_
        ratios = np.where(rejectable, p / np.where(w > 0, w, 1.0), np.inf)
        w, g = _reject(int(np.argmin(ratios)), w, g, open_)


def adjusted_p_values(p, weights, transitions):
    """The adjusted p-values of the graphical procedure (Algorithm 2): H_i is rejected at
    family-wise alpha iff its adjusted p-value is <= alpha. A hypothesis that never gets a
    weight has adjusted p-value 1."""
    w, g = check_graph(weights, transitions)
    p = _check_p_values(p, len(w))
    adjusted, largest = np.ones(len(w)), 0.0
    open_ = np.ones(len(w), dtype=bool)
    while open_.any():
        with np.errstate(divide="ignore"):
            ratios = np.where(open_ & (w > 0), p / np.where(w > 0, w, 1.0), np.inf)
        j = int(np.argmin(ratios))
        if not np.isfinite(ratios[j]):
            break  # the hypotheses still open have no weight: none of them can be rejected
        largest = max(largest, float(ratios[j]))
        adjusted[j] = min(largest, 1.0)
        w, g = _reject(j, w, g, open_)
    return adjusted


def holm_graph(m: int) -> tuple:
    """`(w, G)` of Holm's procedure over m hypotheses: w_i = 1/m, g_ij = 1/(m - 1)."""
    if m < 1:
        raise ValueError(f"a family holds at least 1 hypothesis; got {m}")
    g = np.full((m, m), 1.0 / (m - 1)) if m > 1 else np.zeros((1, 1))
    np.fill_diagonal(g, 0.0)
    return np.full(m, 1.0 / m), g


def margin_graph(comparisons: int) -> tuple:
    """`(w, G)` of the third benchmark's family (docs/FINDINGS.md, the rule's "Tests"): for
    each of `comparisons` comparisons c the hypotheses 3c, 3c + 1, 3c + 2, "not worse",
    "worse" and "better" (`HYPOTHESES`).

    "Not worse" and "worse" start at 1 / (2 C) each (alpha / 78 at alpha 0.05 for C = 39),
    "better" at 0. "Not worse" passes its whole level to its comparison's "better" once it is
    rejected (a fixed sequence: superiority is tested only where non-inferiority is shown);
    "worse" and "better" pass theirs in equal parts to every other "not worse" and "worse"
    hypothesis, 1 / (2 C - 1) each. The update of Algorithm 1 keeps those parts equal among
    the hypotheses still open (with a shown "not worse" replaced by its "better"), as Holm's
    procedure does."""
    if comparisons < 1:
        raise ValueError(f"a family holds at least 1 comparison; got {comparisons}")
    m = 3 * comparisons
    primary = np.zeros(m, dtype=bool)
    primary[0::3] = primary[1::3] = True
    w = np.where(primary, 1.0 / (2 * comparisons), 0.0)
    g = np.zeros((m, m))
    for c in range(comparisons):
        not_worse, worse, better = 3 * c, 3 * c + 1, 3 * c + 2
        g[not_worse, better] = 1.0
        # "worse" to every other primary hypothesis; "better" to every one but its own "not
        # worse" (rejected before "better" has a level): 2 C - 1 targets each
        for source, left_out in ((worse, worse), (better, not_worse)):
            targets = primary.copy()
            targets[left_out] = False
            if targets.any():
                g[source, targets] = 1.0 / targets.sum()
    return w, g
