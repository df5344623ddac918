"""Mountain-Car drawn without an MJCF model: the hill z = sin(3x), x in [-1.2, 0.5], in the
x-z plane, with the goal flag, the left wall and the car moving along the hill."""

import numpy as np

from lwrl.tasks.mountain_car import GOAL_POSITION, MIN_POSITION
from lwrl.viz.drawing import Block, Drawing, Line


def altitude(x) -> np.ndarray:
    """The hill's altitude sin(3x)."""
    return np.sin(3.0 * np.asarray(x, dtype=np.float64))


def car_poses(states) -> dict:
    """`{"car": (translation (T, 3), quaternion (T, 4) x-first)}`: the car at (x, 0, sin 3x),
    pitched along the slope 3 cos(3x)."""
    x = np.asarray(states, dtype=np.float64)[:, 0]
    translation = np.stack([x, np.zeros_like(x), altitude(x)], axis=1)
    pitch = -np.arctan(3.0 * np.cos(3.0 * x))  # about +y: a rising slope lifts the nose
    zeros = np.zeros_like(x)
    return {"car": (translation, np.stack([zeros, np.sin(pitch / 2), zeros, np.cos(pitch / 2)], axis=1))}


def drawing() -> Drawing:
    """The hill, the goal flag, the left wall, and the car's body."""
    x = np.linspace(MIN_POSITION, GOAL_POSITION, 200)
    goal_z, wall_z = float(altitude(GOAL_POSITION)), float(altitude(MIN_POSITION))
    grey, car = (110, 110, 110), (0.06, 0.04, 0.03)
    return Drawing(
        fixed={
            "hill": Line(np.stack([x, np.zeros_like(x), altitude(x)], axis=1), 0.008, (90, 160, 90)),
            "goal": (Block((0.004, 0.004, 0.12), (GOAL_POSITION, 0.0, goal_z + 0.12), grey),
                     Block((0.05, 0.004, 0.03), (GOAL_POSITION + 0.05, 0.0, goal_z + 0.21), (240, 200, 40))),
            "wall": Block((0.01, 0.05, 0.15), (MIN_POSITION - 0.01, 0.0, wall_z + 0.1), grey),
        },
        bodies={"car": {"body": Block(car, (0.0, 0.0, car[2]), (200, 60, 50))}},
        poses=car_poses, eye=((-0.35, -2.2, 0.3), (-0.35, 0.0, 0.0)))
