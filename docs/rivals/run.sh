#!/usr/bin/env bash
# First results of today's light-weight rivals beside the paper's agent (docs/guide/learners.md,
# "First results"): 20 agents of each learner on each task, the second benchmark's budget of
# environment steps (`--budget`, each learner's horizon `--timesteps` the same), every learner
# with its own defaults (the authors' for the streaming learners, the paper's for its agent,
# ARS's V2 with 8 directions), on the analytic plant; then one figure per task of the
# training episodes' measure against the environment steps (`lwrl plot --by-steps`).
#
#     bash docs/rivals/run.sh           (LWRL=path/to/lwrl to use another command)
#
# A run whose directory exists is not run again: the script resumes where it stopped. The
# runs' directories stay out of git (.gitignore); the figures are kept.
set -euo pipefail
cd "$(dirname "$0")"
LWRL=${LWRL:-lwrl}

train() {  # DIR TASK BUDGET ARGS...: one run of 20 agents, unless its directory exists
    local dir=$1 task=$2 budget=$3
    shift 3
    [ -d "runs/$dir" ] || "$LWRL" train "$task" --plant analytic --agents 20 --seed 0 \
        --budget "$budget" --episodes $((budget / 10)) --out "runs/$dir" "$@"
}

for spec in "mountain_car.cost_to_go 100000" "pendulum.swingup 90000" \
            "cartpole.balance 250000" "acrobot.swingup 100000"; do
    set -- $spec
    task=$1 budget=$2
    train "$task-paper" "$task" "$budget"
    train "$task-ars" "$task" "$budget" --learner ars --timesteps "$budget"
    train "$task-stream_q" "$task" "$budget" --learner stream_q --timesteps "$budget"
    train "$task-stream_ac" "$task" "$budget" --learner stream_ac_discrete --timesteps "$budget"
    "$LWRL" plot "runs/$task-paper" "runs/$task-ars" "runs/$task-stream_q" \
        "runs/$task-stream_ac" --by-steps --out "$task.png"
done
task=pendulum.swingup budget=90000
train "$task-continuous-actor_critic" "$task" "$budget" --learner actor_critic \
    --action-kind continuous
train "$task-continuous-ars" "$task" "$budget" --learner ars_continuous --timesteps "$budget" \
    --action-kind continuous
train "$task-continuous-stream_ac" "$task" "$budget" --learner stream_ac --timesteps "$budget" \
    --action-kind continuous
"$LWRL" plot "runs/$task-continuous-actor_critic" "runs/$task-continuous-ars" \
    "runs/$task-continuous-stream_ac" --by-steps --out "$task-continuous.png"
