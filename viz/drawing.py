"""Pictures of a domain's states: what the Rerun viewer (`viz.scene`) and Gymnasium's
`render()` (`lwrl.gym`) both draw from.

- `Block`, `Line`, `Drawing`: the shapes of a domain drawn without an MJCF model
  (`viz.scenes`).

- `quat_mul`, `quat_rotate`: (w, x, y, z) quaternion algebra for poses.
- `qpos_of(model, states)`: the joint positions of states that interleave qpos and qvel joint
  by joint (both plants' state vectors do).
- `boxes_of(shape)`, `fixed_shapes(drawing)`, `body_shapes(drawing, state)`: a `Drawing`'s
  lines and boxes in the world: its fixed shapes, and its bodies' shapes moved by
  `drawing.poses` at one state (the geometry and poses the viewer logs).
- `Painter`: frames `(height, width, 3)` uint8 of a domain's states: MuJoCo's rendering from
  the model's first camera for a domain with an MJCF model (a `dm_control` Physics of the
  model set to the state, so the analytic plant's states are drawn as the MuJoCo plant's
  are; needs OpenGL: a display, or `MUJOCO_GL=egl` headless), else the domain's `Drawing`
  seen from its `eye` through a pinhole camera, painted in NumPy (no OpenGL).
"""

import dataclasses
import math
from typing import Callable, Mapping

import numpy as np


@dataclasses.dataclass(frozen=True)
class Block:
    """A solid block (a box) the viewer draws: half sizes and centre (x, y, z), colour (r, g, b)."""

    half_size: tuple
    center: tuple
    color: tuple


@dataclasses.dataclass(frozen=True)
class Line:
    """A polyline the viewer draws: points `(n, 3)`, radius, colour (r, g, b)."""

    points: np.ndarray
    radius: float
    color: tuple


@dataclasses.dataclass(frozen=True)
class Drawing:
    """The 3-D scene of a domain without an MJCF model (z up, in the task's units).

    `fixed` shapes are drawn once in the world; `bodies` maps a moving body's name to its
    shapes in the body's frame; `poses(states (T, d))` gives each body's
    `(translation (T, 3), quaternion (T, 4) x-first)`; `eye` is the default camera
    `(position, look_target)`. Domains with a model are drawn from its geoms and cameras.
    """

    fixed: Mapping
    bodies: Mapping
    poses: Callable
    eye: tuple


MARGIN = 0.05
"""The share of a Drawing's picture left free on each side of its fixed shapes."""
BACKGROUND = (236, 240, 245)
"""A Drawing's background colour (r, g, b)."""


def quat_mul(a, b) -> np.ndarray:
    """Hamilton products of (w, x, y, z) quaternions, broadcast over leading axes."""
    aw, ax, ay, az = np.moveaxis(np.asarray(a, dtype=np.float64), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, dtype=np.float64), -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def quat_rotate(q, v) -> np.ndarray:
    """Rotate vectors `v` by unit (w, x, y, z) quaternions `q`, broadcast over leading axes."""
    q = np.asarray(q, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def qpos_of(model, states) -> np.ndarray:
    """`(T, nq)` joint positions of `(T, 2 nq)` states that interleave qpos and qvel per
    joint (`model`: a MuJoCo model, whose joints have one degree of freedom each)."""
    states = np.asarray(states, dtype=np.float64)
    if states.ndim != 2 or states.shape[1] != 2 * model.nq or model.nq != model.nv:
        raise ValueError(f"states must have shape (T, {2 * model.nq}) (qpos and qvel of each "
                         f"one-dof joint, interleaved); got {states.shape}")
    return states[:, 0::2]


def boxes_of(shape) -> tuple:
    """The blocks of a Drawing's shape: a `Block`, or a tuple of them."""
    return (shape,) if isinstance(shape, Block) else tuple(shape)


def _place(shape, translation, rotation) -> list:
    """A shape moved by `rotation` (w, x, y, z) then `translation`: a `Line`, or one
    `(corners (8, 3), colour)` per box."""
    if isinstance(shape, Line):
        return [Line(quat_rotate(rotation, shape.points) + translation, shape.radius, shape.color)]
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    return [(quat_rotate(rotation, np.asarray(box.center) + signs * np.asarray(box.half_size))
             + translation, box.color) for box in boxes_of(shape)]


def fixed_shapes(drawing: Drawing) -> list:
    """A `Drawing`'s fixed shapes in the world (see `_place`)."""
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    return [placed for shape in drawing.fixed.values()
            for placed in _place(shape, np.zeros(3), identity)]


def body_shapes(drawing: Drawing, state) -> list:
    """A `Drawing`'s bodies' shapes in the world at `state` (d,): each body's shapes moved
    by its pose (`drawing.poses`, the poses the viewer logs)."""
    poses = drawing.poses(np.asarray(state, dtype=np.float64)[None])
    placed = []
    for body, shapes in drawing.bodies.items():
        translation, quaternion = (np.asarray(part)[0] for part in poses[body])
        for shape in shapes.values():
            placed += _place(shape, translation, quaternion[[3, 0, 1, 2]])  # x-first to w-first
    return placed


class _Camera:
    """A pinhole camera at `eye = (position, target)`, z up, that frames `points` (n, 3) in
    a picture of `height` x `width` pixels with a margin: world points to pixels."""

    def __init__(self, eye, points, height: int, width: int):
        position, target = (np.asarray(point, dtype=np.float64) for point in eye)
        forward = (target - position) / np.linalg.norm(target - position)
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        self.position, self.axes = position, np.stack([right, np.cross(right, forward), forward])
        self.focal, self.centre = 1.0, np.zeros(2)
        seen = self.project(points)[0]
        low, high = seen.min(axis=0), seen.max(axis=0)
        self.focal = (1.0 - 2 * MARGIN) * min(width / max(high[0] - low[0], 1e-9),
                                              height / max(high[1] - low[1], 1e-9))
        self.centre = np.array([0.5 * width, 0.5 * height]) - self.focal * 0.5 * (low + high)

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """`(pixels (n, 2) as (column, row), depths (n,))` of world points `(n, 3)`."""
        x, y, depth = self.axes @ (np.asarray(points, dtype=np.float64) - self.position).T
        return self.centre + self.focal * np.stack([x, -y], axis=1) / depth[:, None], depth


def _paint_line(frame: np.ndarray, camera: _Camera, line: Line) -> None:
    """Stamp discs of the line's projected radius along its projected segments."""
    pixels, depth = camera.project(line.points)
    radius = max(1.0, camera.focal * line.radius / float(np.median(depth)))
    lengths = np.linalg.norm(np.diff(pixels, axis=0), axis=1)
    samples = [start + (end - start) * t[:, None] for start, end, length in
               zip(pixels[:-1], pixels[1:], lengths)
               for t in [np.linspace(0.0, 1.0, max(2, int(math.ceil(length * 2))))]]
    centres = np.concatenate(samples) if samples else pixels
    span = int(math.ceil(radius))
    offsets = np.array([(dx, dy) for dx in range(-span, span + 1) for dy in range(-span, span + 1)
                        if dx * dx + dy * dy <= radius * radius])
    points = np.rint(centres[:, None, :] + offsets[None]).reshape(-1, 2).astype(np.int64)
    height, width = frame.shape[:2]
    inside = (points[:, 0] >= 0) & (points[:, 0] < width) & (points[:, 1] >= 0) & (points[:, 1] < height)
    frame[points[inside, 1], points[inside, 0]] = line.color


def _hull(points: np.ndarray) -> np.ndarray:
    """The convex hull of 2-D points, counter-clockwise (Andrew's monotone chain)."""
    ordered = sorted(map(tuple, points))

    def turn(o, a, b) -> float:  # the z of (a - o) x (b - o)
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def half(sequence):
        chain = []
        for point in sequence:
            while len(chain) >= 2 and turn(chain[-2], chain[-1], point) <= 0:
                chain.pop()
            chain.append(point)
        return chain[:-1]

    return np.array(half(ordered) + half(reversed(ordered)))


def _paint_box(frame: np.ndarray, camera: _Camera, corners: np.ndarray, color) -> None:
    """Fill the convex hull of the box's projected corners."""
    hull = _hull(camera.project(corners)[0])
    height, width = frame.shape[:2]
    left, top = np.maximum(np.floor(hull.min(axis=0)).astype(int), 0)
    right, bottom = np.minimum(np.ceil(hull.max(axis=0)).astype(int), (width - 1, height - 1))
    if len(hull) < 3 or right < left or bottom < top:
        return
    columns, rows = np.meshgrid(np.arange(left, right + 1) + 0.5, np.arange(top, bottom + 1) + 0.5)
    inside = np.ones(columns.shape, dtype=bool)
    for start, end in zip(hull, np.roll(hull, -1, axis=0)):
        edge = end - start
        inside &= edge[0] * (rows - start[1]) - edge[1] * (columns - start[0]) >= 0
    frame[top:bottom + 1, left:right + 1][inside] = color


def _paint(frame: np.ndarray, camera: _Camera, shapes: list) -> np.ndarray:
    for shape in shapes:
        if isinstance(shape, Line):
            _paint_line(frame, camera, shape)
        else:
            _paint_box(frame, camera, *shape)
    return frame


class Painter:
    """Frames of one domain's states (see the module): `painter(state)` -> `(height, width,
    3)` uint8. `model_xml` is the domain's MJCF text, or None to paint its `drawing`, seen
    from its `eye` and framing its fixed shapes (painted once; the bodies on each frame)."""

    def __init__(self, model_xml: str | None, drawing: Drawing | None, height: int = 240,
                 width: int = 320):
        self.height, self.width = height, width
        self._physics = None
        if model_xml is not None:
            from dm_control import mujoco as dm_mujoco

            self._physics = dm_mujoco.Physics.from_xml_string(model_xml)
            return
        if drawing is None:
            raise ValueError("a domain without an MJCF model needs a Drawing to be pictured")
        self.drawing = drawing
        fixed = fixed_shapes(drawing)
        points = np.concatenate([shape.points if isinstance(shape, Line) else shape[0]
                                 for shape in fixed])
        self._camera = _Camera(drawing.eye, points, height, width)
        self._fixed = _paint(np.full((height, width, 3), BACKGROUND, dtype=np.uint8),
                             self._camera, fixed)

    def __call__(self, state) -> np.ndarray:
        state = np.asarray(state, dtype=np.float64)
        if self._physics is None:
            return _paint(self._fixed.copy(), self._camera, body_shapes(self.drawing, state))
        physics = self._physics
        with physics.reset_context():
            physics.data.qpos[:] = qpos_of(physics.model, state[None])[0]
            physics.data.qvel[:] = state[1::2]
        return physics.render(self.height, self.width, camera_id=0)

    def close(self) -> None:
        if self._physics is not None:
            self._physics.free()
            self._physics = None
