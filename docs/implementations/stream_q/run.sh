#!/usr/bin/env bash
# lwrl's stream-Q(lambda) against the authors' PyTorch code on the cart-pole
# (docs/implementations/stream_q.md): 20 agents of each (seeds 0-19), the authors' defaults,
# 50 000 environment steps per agent, one process after the other; then the report.
#
#     git clone https://github.com/mohmdelsayed/streaming-drl /tmp/streaming-drl
#     git -C /tmp/streaming-drl checkout 407dca7
#     bash docs/implementations/stream_q/run.sh /tmp/streaming-drl
#
# (PYTHON=path/to/python to use another interpreter; it needs lwrl, torch and gymnasium.)
# The authors' runs resume where they stopped; lwrl's run is made again unless its
# directory exists. The runs the report reads are kept here (torch.json.gz, lwrl.json,
# lwrl.csv.gz); lwrl's run directory stays out of git (runs/).
set -euo pipefail
AUTHORS=${1:?give a checkout of mohmdelsayed/streaming-drl at 407dca7}
cd "$(dirname "$0")/../../.."
PYTHON=${PYTHON:-python}
TIMESTEPS=50000
"$PYTHON" -m lwrl.studies.implementations.stream_q_torch --authors "$AUTHORS" \
    --env-id lwrl/cartpole-balance-analytic-v0 --timesteps "$TIMESTEPS" --seeds 0-19 \
    --out docs/implementations/stream_q/torch.json.gz
[ -d runs/stream_q-cartpole-20 ] || "$PYTHON" -m lwrl.cli train cartpole.balance --plant analytic \
    --learner stream_q --agents 20 --seed 0 --budget "$TIMESTEPS" --timesteps "$TIMESTEPS" \
    --episodes $((TIMESTEPS / 10)) --out runs/stream_q-cartpole-20
"$PYTHON" -m lwrl.studies.implementations.stream_q_report --dir docs/implementations/stream_q \
    --lwrl-run runs/stream_q-cartpole-20 --out docs/implementations/stream_q.md
