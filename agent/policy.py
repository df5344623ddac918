"""Action choice: epsilon-greedy on Q with ties broken uniformly at random (SPEC "Agent")."""

import numpy as np
from numba.extending import register_jitable

from lwrl.agent.streams import uniform


@register_jitable
def epsilon_greedy(q, epsilon, streams, i):
    """An action index for the action values `q` (A,), drawing from stream `i` of `streams`.

    With probability `epsilon` a uniformly random action; otherwise a greedy one, ties broken
    uniformly at random (with all-zero weights every action ties, so this drives the first
    episode). No draw is spent on the epsilon test when `epsilon` is 0, nor on a tie-break
    when one action is best.
    """
    num_actions = q.shape[0]
    if epsilon > 0.0 and uniform(streams, i) < epsilon:
        return min(int(uniform(streams, i) * num_actions), num_actions - 1)
    best = q[0]
    for a in range(num_actions):
        if np.isnan(q[a]):
            return 0  # no action is best
        best = max(best, q[a])
    ties = 0
    for a in range(num_actions):
        ties += q[a] == best
    pick = 0 if ties <= 1 else min(int(uniform(streams, i) * ties), ties - 1)
    for a in range(num_actions):
        if q[a] == best:
            if pick == 0:
                return a
            pick -= 1
    return 0  # not reached: best is one of q's values
