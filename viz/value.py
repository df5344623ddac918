"""The value function over a 2-D grid of states, as images.

For a task's two plotted state variables (its scene's `value_axes`, `viz.scenes`: e.g. position or angle
across, velocity up; the other variables held at 0, e.g. the cart-pole's slice over pole
angle and angular velocity at x = x_dot = 0), a `size x size` grid of cell-centre states
over the learner's value box (`Agents.value_box`: a feature map's normalisation ranges, the
box its centroids span) is evaluated through the learner contract with one agent's weights:
`value/max_q` is the state value (max_a Q for a learner of action values) as an RGB image
(viridis, scaled to that image's own min..max, which the entity also carries as
`max_q_min` / `max_q_max`), `value/greedy_action` the greedy action as a segmentation image
(class a + 1 for action a, class 0 where actions tie, as with all-zero weights), and
`value/centroids` the learner's feature points (an NRBF's centroids) projected on the plane,
in the images' pixel coordinates (pixel (0, 0)'s top-left corner at the origin, u across,
v down).

Images are logged on the `episode` timeline and also at step 0 / sim_time 0, so the `step`
timeline shows the most recently logged one. `log_value_path` adds an episode's states over
the images: `value/state` per step and `value/trajectory` as a whole.
"""

import dataclasses

import numpy as np
import rerun as rr

from lwrl.viz import names, scenes
from lwrl.viz.columns import episode_indexes, log_static, one_row, send

GRID = 100
"""Default cells per side of the value images."""


def value_axes(task: str) -> tuple[int, int]:
    """The indices of the two state variables across (u) and up (v) a task's images."""
    state_names = names.task_definition(task).state_names
    return tuple(state_names.index(name)
                 for name in scenes.value_axes(names.domain_of(task), state_names))

# Viridis, sampled at 0, 1/8, ..., 1.
_VIRIDIS = np.array([(68, 1, 84), (71, 44, 122), (59, 81, 139), (44, 113, 142), (33, 144, 141),
                     (39, 173, 129), (92, 200, 99), (170, 220, 50), (253, 231, 37)], dtype=np.float64)
TIE_COLOR = (60, 60, 60)
NEGATIVE_COLOR = (50, 110, 220)
ZERO_COLOR = (170, 170, 170)
POSITIVE_COLOR = (220, 70, 50)
CENTROID_COLOR = (255, 255, 255, 170)
STATE_COLOR = (255, 60, 200)
TRAJECTORY_COLOR = (255, 140, 220, 200)


@dataclasses.dataclass(frozen=True)
class ValueGrid:
    """A `height x width` grid over two state variables `axes` of a task; the other
    variables are held at `fixed`."""

    axes: tuple
    low: np.ndarray
    """`(d,)` the task's ranges' lower ends; the grid spans [low, high] on its two axes."""
    high: np.ndarray
    width: int
    height: int
    fixed: np.ndarray
    """`(d,)` the state the slice goes through (its `axes` entries are ignored)."""

    def states(self) -> np.ndarray:
        """`(height, width, d)` the cell-centre states, v (rows) from high to low velocity."""
        u, v = self.axes
        xs = self.low[u] + (np.arange(self.width) + 0.5) / self.width * (self.high[u] - self.low[u])
        ys = self.high[v] - (np.arange(self.height) + 0.5) / self.height * (self.high[v] - self.low[v])
        grid = np.broadcast_to(self.fixed, (self.height, self.width, len(self.fixed))).copy()
        grid[:, :, u] = xs[None, :]
        grid[:, :, v] = ys[:, None]
        return grid

    def axes_values(self) -> list:
        """Per state variable, the values the grid's states take: the columns' (u) and the
        rows' (v, high to low) on the plotted axes, the fixed value elsewhere."""
        states = self.states()
        u, v = self.axes
        values = [self.fixed[j:j + 1] for j in range(len(self.fixed))]
        values[u], values[v] = states[0, :, u], states[:, 0, v]
        return values

    def image(self, on_axes) -> np.ndarray:
        """`(height, width, ...)` of values over `axes_values`' grid (shape `(n_0, ...,
        n_{d-1}, ...)`, every axis but the plotted two of length 1)."""
        on_axes = np.asarray(on_axes)
        u, v = self.axes
        dim = len(self.fixed)
        squeezed = on_axes.reshape(tuple(on_axes.shape[j] for j in sorted((u, v)))
                                   + on_axes.shape[dim:])
        return squeezed if v < u else np.swapaxes(squeezed, 0, 1)

    def to_pixels(self, states) -> np.ndarray:
        """`(n, 2)` pixel coordinates (u, v) of states `(n, d)` (their two axes)."""
        states = np.asarray(states, dtype=np.float64)
        u, v = self.axes
        pu = (states[:, u] - self.low[u]) / (self.high[u] - self.low[u]) * self.width
        pv = (self.high[v] - states[:, v]) / (self.high[v] - self.low[v]) * self.height
        return np.stack([pu, pv], axis=1)


def value_grid(task: str, low, high, size: int = GRID) -> ValueGrid:
    """The `size x size` grid of a task (`DOMAIN.TASK` or a bare domain) over the ranges
    `low..high` (per state variable; a feature map's box), through the zero state on the
    variables not plotted."""
    low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
    if size < 1:
        raise ValueError(f"size must be >= 1; got {size}")
    return ValueGrid(value_axes(task), low, high, int(size), int(size),
                     np.zeros(len(low)))


def values_on_grid(grid: ValueGrid, agents, weights) -> tuple:
    """`(values (h, w), preferences (h, w, A))` of one agent's `weights` (its learner's
    `arrays.weights[b]`) over the grid: the learner's state values and the action values
    (or preferences) it acts greedily on, through the learner contract
    (`Agents.state_values_on_grid`, `action_values_on_grid`). `agent.learner_contract.NoValues`
    where the learner has none."""
    axes = grid.axes_values()
    return (grid.image(agents.state_values_on_grid(axes, weights)),
            grid.image(agents.action_values_on_grid(axes, weights)))


def viridis(values, low: float, high: float) -> np.ndarray:
    """`values` as uint8 RGB, low..high mapped through viridis (a constant image is mid-scale)."""
    values = np.asarray(values, dtype=np.float64)
    scaled = np.full(values.shape, 0.5) if not high > low else np.clip((values - low) / (high - low), 0, 1)
    samples = np.linspace(0.0, 1.0, len(_VIRIDIS))
    rgb = np.stack([np.interp(scaled, samples, _VIRIDIS[:, c]) for c in range(3)], axis=-1)
    return np.round(rgb).astype(np.uint8)


def signed_colors(values) -> np.ndarray:
    """`values` in [-1, 1] as uint8 RGB: -1 the negative action's colour, 0 the zero
    action's grey, +1 the positive action's, linear between (`action_colors`)."""
    values = np.clip(np.asarray(values, dtype=np.float64), -1.0, 1.0)[..., None]
    zero, negative, positive = (np.array(c, dtype=np.float64)
                                for c in (ZERO_COLOR, NEGATIVE_COLOR, POSITIVE_COLOR))
    rgb = np.where(values < 0, zero + (negative - zero) * -values, zero + (positive - zero) * values)
    return np.round(rgb).astype(np.uint8)


def greedy_classes(q) -> np.ndarray:
    """`(..., )` uint8: greedy action + 1, or 0 where several actions share the maximum."""
    q = np.asarray(q)
    best = q.max(axis=-1, keepdims=True)
    ties = (q == best).sum(axis=-1) > 1
    classes = np.argmax(q, axis=-1) + 1
    classes[ties] = 0
    return classes.astype(np.uint8)


def action_colors(controls) -> list:
    """A colour per action by the sign of its control: negative blue, zero grey, positive red."""
    return [NEGATIVE_COLOR if u < 0 else POSITIVE_COLOR if u > 0 else ZERO_COLOR for u in controls]


def greedy_annotations(controls) -> rr.AnnotationContext:
    """Class 0 (tie) and class a + 1 (action a, labelled with its control)."""
    classes = [(0, "tie", TIE_COLOR)]
    classes += [(a + 1, f"a={a}: u={float(u):+g}", color)
                for a, (u, color) in enumerate(zip(controls, action_colors(controls)))]
    return rr.AnnotationContext(classes)


def plane_points(points, grid: ValueGrid) -> np.ndarray | None:
    """Feature points `(K, d)` (`Agents.feature_points`: e.g. an NRBF's centroids, in task
    units) projected on the grid's plane (distinct points), or None where there are none."""
    if points is None:
        return None
    plane = np.unique(np.asarray(points)[:, list(grid.axes)], axis=0)
    out = np.broadcast_to(grid.fixed, (len(plane), len(grid.fixed))).copy()
    out[:, list(grid.axes)] = plane
    return out


def _times(episode: int) -> list:
    """One row at `episode`, step 0 and sim_time 0."""
    return [rr.TimeColumn(names.EPISODE, sequence=[int(episode)]),
            rr.TimeColumn(names.STEP, sequence=[0]),
            rr.TimeColumn(names.SIM_TIME, duration=np.array([0.0]))]


def log_value_function(rec: rr.RecordingStream, task: str, agents, weights, episode: int, *,
                       size: int = GRID) -> dict:
    """Log the state value, the greedy action and the feature points of one agent of
    `agents` (any learner's `Agents`) with `weights` (its `arrays.weights[b]`, e.g. a
    recording's) over the task's grid on the learner's value box, at `episode`; for a
    learner of continuous actions, in place of the greedy action's class, the greedy action
    itself (`greedy_actions`, in [-1, 1]) shaded from the negative action's colour through grey to
    the positive one's (`signed_colors`). Returns `{"max_q": (h, w) values, "greedy": (h, w)
    classes or means, "centroids": (n, 2) pixels or None}`; a `NoValues` error where the
    learner has no values to show."""
    low, high = agents.value_box()
    grid = value_grid(task, low, high, size)
    times = _times(episode)
    if agents.continuous:
        values = grid.image(agents.state_values_on_grid(grid.axes_values(), weights))
        classes = agents.greedy_actions(grid.states(), weights)
        send(rec, names.GREEDY_ACTION, times, one_row(rr.Image(signed_colors(classes)))
             + one_row(rr.AnyValues(policy_mean_min=float(classes.min()),
                                    policy_mean_max=float(classes.max()))))
    else:
        values, preferences = values_on_grid(grid, agents, weights)
        classes = greedy_classes(preferences)
        controls = names.task_definition(task).controls
        if len(controls) != preferences.shape[-1]:
            raise ValueError(f"weights have {preferences.shape[-1]} actions; {task} has "
                             f"{len(controls)}")
        log_static(rec, names.GREEDY_ACTION, greedy_annotations(controls))
        send(rec, names.GREEDY_ACTION, times, one_row(rr.SegmentationImage(classes)))
    low, high = float(values.min()), float(values.max())
    send(rec, names.MAX_Q, times, one_row(rr.Image(viridis(values, low, high)))
         + one_row(rr.AnyValues(max_q_min=low, max_q_max=high)))
    points = plane_points(agents.feature_points(), grid)
    pixels = None
    if points is not None:
        pixels = grid.to_pixels(points)
        log_static(rec, names.CENTROIDS, rr.Points2D(pixels, radii=0.6, colors=CENTROID_COLOR))
    return {"max_q": values, "greedy": classes, "centroids": pixels}


def _split_wraps(pixels, grid: ValueGrid) -> list:
    """The path cut where it jumps more than half the image (the pendulum's wrapped angle)."""
    if len(pixels) < 2:
        return [pixels]
    jumps = np.abs(np.diff(pixels, axis=0))
    cuts = np.flatnonzero((jumps[:, 0] > grid.width / 2) | (jumps[:, 1] > grid.height / 2)) + 1
    return [piece for piece in np.split(pixels, cuts) if len(piece) > 1]


def log_value_path(rec: rr.RecordingStream, recording, low, high, *, size: int = GRID,
                   indexes: list | None = None) -> None:
    """An episode's observed states over the value images on the ranges `low..high`:
    `value/state` at each step and the whole `value/trajectory` (at the episode, step 0 and
    sim_time 0). `indexes`: the time columns of steps 0..T, if already built."""
    grid = value_grid(recording.task, low, high, size)
    pixels = grid.to_pixels(recording.observations).astype(np.float32)  # float64 is 100x slower
    if indexes is None:
        indexes = episode_indexes(np.arange(len(pixels)), recording.timestep, recording.episode)
    send(rec, names.VALUE_STATE, indexes, rr.Points2D.columns(positions=pixels))
    log_static(rec, names.VALUE_STATE, rr.Points2D.from_fields(radii=1.5, colors=STATE_COLOR))
    strips = _split_wraps(pixels, grid)
    if strips:
        send(rec, names.TRAJECTORY, _times(recording.episode),
             one_row(rr.LineStrips2D(strips, radii=0.3, colors=TRAJECTORY_COLOR)))
