"""The default layout of a recording in the Rerun viewer.

    +----------------------------+-----------------------------------------+
    | scene (3-D, camera from -y) | [episode signals] [learning curves]     |
    |                            |  one plot per state variable, action,    |
    +--------------+-------------+  control, reward, return, TD error, Q,   |
    | max_a Q      | greedy      |  up-time (step timeline)                 |
    | + centroids  | action      |  / steps, returns, up-time per agent and |
    | + state path | + centroids |  mean (episode timeline)                 |
    +--------------+-------------+-----------------------------------------+
    time panel on the `step` timeline (the blueprint and selection panels collapsed)

A recording opens on the episode logged last: given its length (`replay_steps`), the time
panel plays steps 0..T of the `step` timeline in a loop, so that with no click the scene
moves through that episode and the value images show its value function and path (they are
at step 0 of every episode, and the most recently logged one wins there); the plots show
every logged episode whole. Without it Rerun plays the whole timeline once (the longest
logged episode's steps, which in a task whose episodes shorten, such as Mountain-Car's,
belong to an early episode) and stops at its end.

The learning curves exist on the `episode` timeline only: switch the time panel to it to
see them (Rerun's plots follow the time panel's timeline).
"""

import rerun as rr
import rerun.blueprint as rrb

from lwrl.viz import names, scene
from lwrl.viz.value import GRID


def _plot(name: str, path: str, steps: bool = False) -> rrb.TimeSeriesView:
    """A plot of every series under `path`; `steps`: drawn as a step function (actions)."""
    defaults = [rr.SeriesLines.from_fields(interpolation_mode="StepAfter")] if steps else None
    return rrb.TimeSeriesView(name=name, origin=path, contents="$origin/**", defaults=defaults,
                              plot_legend=rrb.PlotLegend(visible=False))


def signal_views(task: str) -> list:
    """A plot per signal of an episode (every logged episode is a series in it)."""
    definition = names.task_definition(task)
    views = [_plot(name, f"{names.STATE}/{name}") for name in definition.state_names]
    views += [_plot("action", names.ACTION, steps=True), _plot("control", names.CONTROL, steps=True),
              _plot("reward", names.REWARD), _plot("return so far", names.RETURN),
              _plot("TD error", names.TD_ERROR), _plot("Q(s, a)", names.Q)]
    if definition.has_uptime:
        views.append(_plot("up-time so far (s)", names.UPTIME))
    return views


def curve_views(task: str) -> list:
    """Learning curves: steps, returns (and up-time) per episode."""
    views = [rrb.TimeSeriesView(name="steps per episode", origin=names.CURVE_STEPS),
             rrb.TimeSeriesView(name="return per episode", origin=names.CURVE_RETURNS)]
    if names.task_definition(task).has_uptime:
        views.append(rrb.TimeSeriesView(name="up-time per episode (s)", origin=names.CURVE_UPTIME))
    return views


def value_views(task: str, size: int = GRID) -> list:
    """max_a Q and the greedy action, with the centroids and the episode's states over them,
    framed on the `size x size` images (states outside the ranges run off them)."""
    overlays = [f"+ {names.CENTROIDS}", f"+ {names.TRAJECTORY}", f"+ {names.VALUE_STATE}"]
    bounds = rrb.VisualBounds2D(x_range=[0, size], y_range=[0, size])
    return [rrb.Spatial2DView(name="max_a Q", origin=names.VALUE, visual_bounds=bounds,
                              contents=[f"+ {names.MAX_Q}", *overlays]),
            rrb.Spatial2DView(name="greedy action", origin=names.VALUE, visual_bounds=bounds,
                              contents=[f"+ {names.GREEDY_ACTION}", *overlays])]


def scene_view(task: str) -> rrb.Spatial3DView:
    position, target = scene.eye(task)
    return rrb.Spatial3DView(name="scene", origin=names.SCENE,
                             eye_controls=rrb.EyeControls3D(position=position, look_target=target),
                             line_grid=rrb.LineGrid3D(visible=False))


def time_panel(replay_steps: int | None = None) -> rrb.TimePanel:
    """The time panel on the `step` timeline; with `replay_steps` T, playing steps 0..T in a
    loop (the selection Rerun shows, and loops over, on that timeline)."""
    if replay_steps is None:
        return rrb.TimePanel(timeline=names.STEP, state="collapsed")
    if replay_steps < 0:
        raise ValueError(f"replay_steps must be >= 0; got {replay_steps}")
    return rrb.TimePanel(timeline=names.STEP, state="collapsed", play_state="playing",
                         loop_mode="selection",
                         time_selection=rrb.components.AbsoluteTimeRange(0, int(replay_steps)))


def blueprint(task: str, size: int = GRID, replay_steps: int | None = None) -> rrb.Blueprint:
    """The default layout for `task` (`DOMAIN.TASK` or a bare domain); `size` is the value
    images' side (`log_value_function`'s); `replay_steps` the steps of the episode logged
    last, which the recording opens on, playing in a loop (`time_panel`)."""
    left_column = rrb.Vertical(scene_view(task), rrb.Horizontal(*value_views(task, size)),
                               row_shares=[3, 2])
    right = rrb.Tabs(rrb.Grid(*signal_views(task), grid_columns=2, name="episode signals (step)"),
                     rrb.Vertical(*curve_views(task), name="learning curves (episode)"))
    return rrb.Blueprint(rrb.Horizontal(left_column, right, column_shares=[2, 3]),
                         time_panel(replay_steps), rrb.BlueprintPanel(state="collapsed"),
                         rrb.SelectionPanel(state="collapsed"))


def send_blueprint(rec: rr.RecordingStream, task: str, size: int = GRID,
                   replay_steps: int | None = None) -> rrb.Blueprint:
    """Send `blueprint(task, size, replay_steps)` to `rec` as its active and default layout;
    return it."""
    layout = blueprint(task, size, replay_steps)
    rec.send_blueprint(layout, make_active=True, make_default=True)
    return layout
