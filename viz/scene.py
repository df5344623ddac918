"""The 3-D scene: the MuJoCo models' geometry (static) and the bodies' poses per step.

Geometry is read from the compiled model's geoms (box, capsule, sphere, cylinder, ellipsoid,
plane) with their rgba colours and logged once, static, in its body's frame under
`scene/<body>/<geom>`. A moving body's pose is a Transform3D on `scene/<body>`, one row per
state of an episode, computed from the recorded states: `qpos` is the state's positions (the
state vector interleaves qpos and qvel joint by joint, for both plants), and the poses are
MuJoCo's forward kinematics of it. A domain without an MJCF model brings its own `Drawing`
(its scene's, `viz.scenes`): boxes and lines, fixed or on moving bodies, and the bodies' poses.

`body_poses` evaluates MuJoCo's kinematics (`mj_kinematics`: body offsets, then each joint's
slide or rotation about its anchor) over all the states at once in NumPy; it is checked
against `mujoco.mj_kinematics` state by state (`body_poses_mujoco`, and the tests), and
models with other joints than hinges and slides go through that loop.
"""

import mujoco
import numpy as np
import rerun as rr

from lwrl import models
from lwrl.viz import names, scenes
from lwrl.viz.drawing import Line, boxes_of, qpos_of, quat_mul, quat_rotate
from lwrl.viz.columns import episode_indexes, log_static, send

PLANE_EXTENT = 5.0
"""Half-size drawn for an infinite MuJoCo plane (size 0)."""
PLANE_THICKNESS = 0.005
"""A plane is drawn as a slab this thick, its top at the plane."""
GRID_SPACING = 0.5
"""Spacing of the grid lines drawn on a plane (m)."""



def has_model(task: str) -> bool:
    """True for the domains drawn from a MuJoCo model."""
    return names.domain(task).model is not None


def load_model(task: str) -> mujoco.MjModel:
    """The compiled MuJoCo model of a task's domain (`DOMAIN` or `DOMAIN.TASK`)."""
    domain = names.domain(task)
    if domain.model is None:
        from lwrl import tasks  # as names.domain does: the registry, for its domains' models

        having = [name for name, other in tasks.DOMAINS.items() if other.model is not None]
        raise ValueError(f"{domain.name} has no MuJoCo model; models exist for {', '.join(having)}")
    return mujoco.MjModel.from_xml_string(models.read(domain.model))


def body_name(model: mujoco.MjModel, body: int) -> str:
    return model.body(body).name or f"body{body}"


def geom_name(model: mujoco.MjModel, geom: int) -> str:
    return model.geom(geom).name or f"geom{geom}"


def _xyzw(quat_wxyz) -> np.ndarray:
    """MuJoCo's (w, x, y, z) quaternions as Rerun's (x, y, z, w)."""
    quat_wxyz = np.asarray(quat_wxyz, dtype=np.float64)
    return quat_wxyz[..., [1, 2, 3, 0]]


def _axis_angle(axis, angle) -> np.ndarray:
    """(w, x, y, z) quaternions of rotations by `angle` (T,) about the unit `axis` (3,)."""
    half = 0.5 * np.asarray(angle, dtype=np.float64)
    return np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * np.asarray(axis)], axis=1)


def body_poses_mujoco(model: mujoco.MjModel, qpos) -> tuple[np.ndarray, np.ndarray]:
    """`(xpos (T, nbody, 3), xquat (T, nbody, 4) w-first)` from `mujoco.mj_kinematics`, state by state."""
    qpos = np.asarray(qpos, dtype=np.float64).reshape(-1, model.nq)
    data = mujoco.MjData(model)
    xpos = np.empty((len(qpos), model.nbody, 3))
    xquat = np.empty((len(qpos), model.nbody, 4))
    for t, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        xpos[t] = data.xpos
        xquat[t] = data.xquat
    return xpos, xquat


def _vectorisable(model: mujoco.MjModel) -> bool:
    joint_types = {int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)}
    return (all(int(t) in joint_types for t in model.jnt_type)
            and not np.any(model.body_mocapid >= 0))


def body_poses(model: mujoco.MjModel, qpos) -> tuple[np.ndarray, np.ndarray]:
    """`(xpos (T, nbody, 3), xquat (T, nbody, 4) w-first)` of every body for joint positions
    `(T, nq)`: `mj_kinematics` evaluated over all T states at once (hinge and slide joints;
    other models fall back to `body_poses_mujoco`)."""
    qpos = np.asarray(qpos, dtype=np.float64).reshape(-1, model.nq)
    if not _vectorisable(model):
        return body_poses_mujoco(model, qpos)
    steps = len(qpos)
    # Poses are kept as (1, .) arrays while they do not depend on the state (the world, and
    # bodies whose chain has no joint yet), so that only the joints' work is done T times.
    positions = [np.zeros((1, 3))]
    quaternions = [np.array([[1.0, 0.0, 0.0, 0.0]])]
    for body in range(1, model.nbody):  # parents come before their children
        parent = model.body_parentid[body]
        # Offsets that are zero or the identity (the common case) change nothing: skipped.
        pos, quat = positions[parent], quaternions[parent]
        if np.any(model.body_pos[body]):
            pos = pos + quat_rotate(quat, model.body_pos[body])
        if not np.array_equal(model.body_quat[body], [1, 0, 0, 0]):
            quat = quat_mul(quat, model.body_quat[body])
        start = model.body_jntadr[body]
        for joint in range(start, start + model.body_jntnum[body]):
            angle = qpos[:, model.jnt_qposadr[joint]] - model.qpos0[model.jnt_qposadr[joint]]
            axis = model.jnt_axis[joint]
            offset = model.jnt_pos[joint]
            if model.jnt_type[joint] == mujoco.mjtJoint.mjJNT_SLIDE:
                pos = pos + quat_rotate(quat, axis) * angle[:, None]
            else:  # hinge: rotate about the axis through the anchor
                anchor = pos + quat_rotate(quat, offset) if np.any(offset) else pos
                quat = quat_mul(quat, _axis_angle(axis, angle))
                quat /= np.linalg.norm(quat, axis=1, keepdims=True)
                pos = anchor - quat_rotate(quat, offset) if np.any(offset) else anchor
        positions.append(pos)
        quaternions.append(quat / np.linalg.norm(quat, axis=1, keepdims=True))
    xpos = np.stack([np.broadcast_to(p, (steps, 3)) for p in positions], axis=1)
    xquat = np.stack([np.broadcast_to(q, (steps, 4)) for q in quaternions], axis=1)
    return xpos, xquat


def moving_bodies(model: mujoco.MjModel) -> list[int]:
    """Bodies that move with the joints (not welded to the world)."""
    return [b for b in range(1, model.nbody) if model.body_weldid[b] != 0]


def _rgba(model, geom) -> np.ndarray:
    return np.round(np.clip(model.geom_rgba[geom], 0.0, 1.0) * 255).astype(np.uint8)


def _plane_grid(half_x: float, half_y: float, pos, quat, color) -> rr.LineStrips3D:
    xs = np.arange(-half_x, half_x + 1e-9, GRID_SPACING)
    ys = np.arange(-half_y, half_y + 1e-9, GRID_SPACING)
    strips = [[(x, -half_y, 0.0), (x, half_y, 0.0)] for x in xs]
    strips += [[(-half_x, y, 0.0), (half_x, y, 0.0)] for y in ys]
    strips = pos + quat_rotate(quat, np.array(strips))
    return rr.LineStrips3D(strips, radii=0.004, colors=color)


def geom_archetypes(model: mujoco.MjModel, geom: int, rgba=None) -> list[tuple[str, object]]:
    """`(entity suffix, archetype)` pairs drawing one geom in its body's frame ('' for the
    geom's own entity); empty for geom types not drawn (meshes, height fields). `rgba`
    (0-255) replaces the model's colour."""
    kind = model.geom_type[geom]
    size = model.geom_size[geom]
    pos = model.geom_pos[geom]
    quat = model.geom_quat[geom]
    color = _rgba(model, geom) if rgba is None else np.asarray(rgba, dtype=np.uint8)
    xyzw = [_xyzw(quat)]
    solid = rr.components.FillMode.Solid
    G = mujoco.mjtGeom
    if kind == G.mjGEOM_BOX:
        return [("", rr.Boxes3D(half_sizes=[size], centers=[pos], quaternions=xyzw,
                                colors=[color], fill_mode=solid))]
    if kind == G.mjGEOM_SPHERE:
        return [("", rr.Ellipsoids3D(half_sizes=[[size[0]] * 3], centers=[pos], quaternions=xyzw,
                                     colors=[color], fill_mode=solid))]
    if kind == G.mjGEOM_ELLIPSOID:
        return [("", rr.Ellipsoids3D(half_sizes=[size], centers=[pos], quaternions=xyzw,
                                     colors=[color], fill_mode=solid))]
    if kind == G.mjGEOM_CAPSULE:
        # MuJoCo: centred on pos along the local z, half-length size[1]; Rerun: from its
        # origin to (0, 0, length).
        start = pos - quat_rotate(quat, [0.0, 0.0, size[1]])
        return [("", rr.Capsules3D(lengths=[2 * size[1]], radii=[size[0]], translations=[start],
                                   quaternions=xyzw, colors=[color]))]
    if kind == G.mjGEOM_CYLINDER:
        return [("", rr.Cylinders3D(lengths=[2 * size[1]], radii=[size[0]], centers=[pos],
                                    quaternions=xyzw, colors=[color], fill_mode=solid))]
    if kind == G.mjGEOM_PLANE:
        half_x = size[0] if size[0] > 0 else PLANE_EXTENT
        half_y = size[1] if size[1] > 0 else PLANE_EXTENT
        centre = pos - quat_rotate(quat, [0.0, 0.0, PLANE_THICKNESS / 2])
        line_color = np.concatenate([(color[:3] * 0.6).astype(np.uint8), [255]])
        return [("", rr.Boxes3D(half_sizes=[[half_x, half_y, PLANE_THICKNESS / 2]], centers=[centre],
                                quaternions=xyzw, colors=[color], fill_mode=solid)),
                ("grid", _plane_grid(half_x, half_y, pos + quat_rotate(quat, [0, 0, 1e-3]), quat,
                                     line_color))]
    return []


def _log_geoms(rec: rr.RecordingStream, model: mujoco.MjModel, bodies, root: str,
               rgba=None) -> list[str]:
    """Log the drawable geoms of `bodies`, static, under `root/<body>/<geom>`."""
    paths = []
    for geom in range(model.ngeom):
        body = model.geom_bodyid[geom]
        if body not in bodies:
            continue
        base = f"{names.body_path(body_name(model, body), root)}/{geom_name(model, geom)}"
        for suffix, archetype in geom_archetypes(model, geom, rgba):
            path = f"{base}/{suffix}" if suffix else base
            log_static(rec, path, archetype)
            paths.append(path)
    return paths


def log_fixed_geometry(rec: rr.RecordingStream, model: mujoco.MjModel) -> list[str]:
    """Log the geoms of the world and of the bodies welded to it, static, under
    `scene/<body>/<geom>`, with the welded bodies' (fixed) poses; return the geoms' paths."""
    moving = set(moving_bodies(model))
    fixed = [b for b in range(1, model.nbody) if b not in moving]
    paths = _log_geoms(rec, model, {0, *fixed}, names.SCENE)
    if fixed:
        xpos, xquat = body_poses(model, model.qpos0[None])
        for body in fixed:
            log_static(rec, names.body_path(body_name(model, body)),
                       rr.Transform3D(translation=xpos[0, body], quaternion=_xyzw(xquat[0, body])))
    return paths


def log_moving_geometry(rec: rr.RecordingStream, model: mujoco.MjModel, root: str = names.SCENE,
                        rgba=None) -> list[str]:
    """Log the geoms of the moving bodies, static, in their bodies' frames under
    `root/<body>/<geom>` (a plant's copy of them under `names.plant_root(plant)`), in the
    model's colours or `rgba`; return the paths."""
    return _log_geoms(rec, model, set(moving_bodies(model)), root, rgba)


def log_model_geometry(rec: rr.RecordingStream, model: mujoco.MjModel) -> list[str]:
    """Log every drawable geom, static, under `scene/<body>/<geom>`; return the paths.

    Bodies welded to the world get their (fixed) pose as a static transform.
    """
    return log_fixed_geometry(rec, model) + log_moving_geometry(rec, model)


def shape_archetype(shape):
    """A `Line` as LineStrips3D, a `Block` or a tuple of blocks as solid Boxes3D."""
    if isinstance(shape, Line):
        return rr.LineStrips3D([shape.points], radii=shape.radius, colors=shape.color)
    boxes = boxes_of(shape)
    return rr.Boxes3D(half_sizes=[box.half_size for box in boxes], centers=[box.center for box in boxes],
                      colors=[box.color for box in boxes], fill_mode=rr.components.FillMode.Solid)


def log_drawing(rec: rr.RecordingStream, drawing) -> list[str]:
    """A domain's `Drawing`, static: its fixed shapes under `scene/world/<name>`, its moving
    bodies' shapes under `scene/<body>/<name>`."""
    items = {f"{names.WORLD}/{name}": shape for name, shape in drawing.fixed.items()}
    items.update({f"{names.body_path(body)}/{name}": shape
                  for body, shapes in drawing.bodies.items() for name, shape in shapes.items()})
    for path, shape in items.items():
        log_static(rec, path, shape_archetype(shape))
    return list(items)


def log_task_scene(rec: rr.RecordingStream, task: str) -> list[str]:
    """Log a task's static scene (z up); return the entity paths of its geometry."""
    log_static(rec, names.SCENE, rr.ViewCoordinates.RIGHT_HAND_Z_UP)
    if has_model(task):
        return log_model_geometry(rec, load_model(task))
    return log_drawing(rec, scenes.drawing_of(names.domain_of(task)))


def scene_poses(task: str, states, model: mujoco.MjModel | None = None,
                root: str = names.SCENE) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """`{entity path: (translation (T, 3), quaternion (T, 4) x-first)}` of the moving bodies
    for `(T, d)` states (`model`: the task's compiled model, to skip compiling it again;
    `root`: where the bodies are, for the MuJoCo models)."""
    states = np.asarray(states, dtype=np.float64)
    if has_model(task):
        model = load_model(task) if model is None else model
        xpos, xquat = body_poses(model, qpos_of(model, states))
        return {names.body_path(body_name(model, b), root): (xpos[:, b], _xyzw(xquat[:, b]))
                for b in moving_bodies(model)}
    return {names.body_path(body): pose
            for body, pose in scenes.drawing_of(names.domain_of(task)).poses(states).items()}


def log_scene_poses(rec: rr.RecordingStream, recording, model: mujoco.MjModel | None = None,
                    indexes: list | None = None) -> list[str]:
    """Send the poses of the moving bodies at every state of an `EpisodeRecording` (steps 0
    to T), one `send_columns` per body; return the bodies' paths. `model` (the task's
    compiled model) and `indexes` (the time columns of steps 0..T) save rebuilding them."""
    poses = scene_poses(recording.task, recording.states, model)
    if indexes is None:
        indexes = episode_indexes(np.arange(len(recording.states)), recording.timestep,
                                  recording.episode)
    for path, (translation, quaternion) in poses.items():
        send(rec, path, indexes, rr.Transform3D.columns(translation=translation, quaternion=quaternion))
    return list(poses)


def camera_eye(model: mujoco.MjModel, camera: int = 0) -> tuple[tuple, tuple]:
    """`(position, look_target)` of a model's camera at its rest pose: the target is the
    point of its line of sight nearest the model's centre."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    position = data.cam_xpos[camera].copy()
    forward = -data.cam_xmat[camera].reshape(3, 3)[:, 2]  # cameras look along their -z
    target = position + forward * np.dot(model.stat.center - position, forward)
    return tuple(position.tolist()), tuple(target.tolist())


def eye(task: str) -> tuple[tuple, tuple]:
    """A default camera `(position, look_target)` for the task's 3-D view: the model's first
    camera, or the drawing's eye."""
    if has_model(task):
        return camera_eye(load_model(task))
    return scenes.drawing_of(names.domain_of(task)).eye


__all__ = ["body_poses", "body_poses_mujoco", "camera_eye", "eye", "has_model", "load_model",
           "log_drawing", "log_scene_poses", "log_task_scene", "moving_bodies", "qpos_of",
           "scene_poses"]
