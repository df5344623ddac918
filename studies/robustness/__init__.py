"""How far from the modelled plant a learned controller still works (`lwrl robustness`).

Agents of every learner that fits a task (a learner of continuous actions on the task made
with them) are trained on the paper's plant and, apart, with their domain's robustness
parameters drawn anew for each episode (domain randomisation), then run greedily, without
learning, over a grid of those parameters, over observation noise and over actuation delays
(`plan`). The exported C controller of one trained NRBF agent of each kind of action runs on
the same grid through ctypes (`controller`). Both phases go through the sweep
runner (`runners.sweep.run_sweep`: resumable, claimed batches), the training keeping its
agents for the evaluation; `study` measures each cell with the task's own measure and 95 %
bootstrap intervals and writes the map figures and the report (`report`).
"""
