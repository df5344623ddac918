"""Mountain-Car's plant in C for the device programs: `step`, `outcome` and
`initial_states` of `tasks/mountain_car.py`, operation for operation, in double."""

from lwrl.export.c_plants.plant import CPlant
from lwrl.tasks.mountain_car import GOAL_POSITION, MAX_SPEED, MIN_POSITION

C_PLANT = CPlant(
    start="""\
    state[0] = $min_position + ($goal_position - ($min_position)) * unit[0];
    state[1] = -$max_speed + ($max_speed - (-$max_speed)) * unit[1];""",
    step="""\
    /* v' = clip(v + k a - g cos(3x), -vmax, vmax); x' = max(x + v', xmin), v' = 0 at the wall */
    double velocity = state[1] + $thrust * control - $gravity * cos(3.0 * state[0]);
    double unclipped;
    velocity = velocity > -$max_speed ? velocity : -$max_speed;
    velocity = velocity < $max_speed ? velocity : $max_speed;
    unclipped = state[0] + velocity;
    state[0] = unclipped > $min_position ? unclipped : $min_position;
    state[1] = velocity * (double)(unclipped >= $min_position); /* the wall stops the car */
    *terminal = state[0] > $goal_position; /* the goal; reward -1 per step, 0 into the goal */
    return (double)*terminal - 1.0;""",
    constants={"min_position": MIN_POSITION, "goal_position": GOAL_POSITION,
               "max_speed": MAX_SPEED})
"""The plant in C (see the module)."""
