"""Several plants' trajectories from one start in one recording (`lwrl compare --rrd`).

Each plant gets its own copy of the model's moving bodies under `scene/<plant>/<body>`:
the reference in the model's colours, the others as semi-transparent ghosts tinted per
plant; the world's fixed geometry is drawn once. Their state variables, mechanical energy
and error against the reference go on shared plots, one series per plant
(`signals/state/<variable>/<plant>`, `signals/energy/<plant>`,
`signals/error/<variable>/<plant>`), on the `step` and `sim_time` timelines.
"""

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from lwrl.viz import names
from lwrl.viz.blueprint import scene_view
from lwrl.viz.columns import episode_indexes, log_static, send
from lwrl.viz.scene import load_model, log_fixed_geometry, log_moving_geometry, scene_poses

GHOST_ALPHA = 90
"""Opacity (0-255) of a ghost."""
PLANT_COLORS = [(230, 120, 30), (40, 150, 220), (200, 40, 160), (60, 170, 60)]
"""Colours of the ghosts and of the plants' series, in the order the plants are given (the
reference's series takes the first)."""


def _series(rec, path: str, indexes, values, label: str, color) -> None:
    log_static(rec, path, rr.SeriesLines(names=label, colors=[color], widths=1.5))
    send(rec, path, indexes, rr.Scalars.columns(scalars=np.asarray(values, dtype=np.float64)))


def log_plants(rec: rr.RecordingStream, task: str, trajectories: dict, timestep: float,
               reference: str, labels: dict, state_names, energies: dict, errors: dict) -> dict:
    """Log the scene and the signals of `trajectories` (`{plant: (T + 1, d) states}` from one
    start under one action sequence): `reference` opaque, the others as ghosts;
    `energies[plant]` `(T + 1,)` J and `errors[plant]` `{variable: (T + 1,)}` against the
    reference (not for the reference itself). Returns `{plant: [its entity paths]}`."""
    model = load_model(task)
    log_static(rec, names.SCENE, rr.ViewCoordinates.RIGHT_HAND_Z_UP)
    log_fixed_geometry(rec, model)
    logged = {}
    for color, (plant, states) in zip(PLANT_COLORS, trajectories.items()):
        root = names.plant_root(plant)
        ghost = None if plant == reference else (*color, GHOST_ALPHA)
        paths = log_moving_geometry(rec, model, root, ghost)
        indexes = episode_indexes(np.arange(len(states)), timestep, 0)
        for path, (translation, quaternion) in scene_poses(task, states, model, root).items():
            send(rec, path, indexes, rr.Transform3D.columns(translation=translation,
                                                            quaternion=quaternion))
            paths.append(path)
        series = {names.state_path(name, plant): states[:, j] for j, name in enumerate(state_names)}
        series[f"{names.ENERGY}/{plant}"] = energies[plant]
        for variable, values in errors.get(plant, {}).items():
            series[f"{names.ERROR}/{variable}/{plant}"] = values
        for path, values in series.items():
            _series(rec, path, indexes, values, labels[plant], color)
        logged[plant] = paths + list(series)
    return logged


def blueprint(task: str, state_names, compared_variables) -> rrb.Blueprint:
    """The scene beside the shared plots: each state variable, the energy, and each compared
    variable's error against the reference (log scale is the viewer's choice)."""
    plots = [rrb.TimeSeriesView(name=name, origin=f"{names.STATE}/{name}") for name in state_names]
    plots.append(rrb.TimeSeriesView(name="mechanical energy (J)", origin=names.ENERGY))
    plots += [rrb.TimeSeriesView(name=f"|error| of {name} against the reference",
                                 origin=f"{names.ERROR}/{name}") for name in compared_variables]
    return rrb.Blueprint(rrb.Horizontal(scene_view(task), rrb.Grid(*plots, grid_columns=2),
                                        column_shares=[2, 3]),
                         rrb.TimePanel(timeline=names.SIM_TIME), rrb.SelectionPanel(state="collapsed"))
