"""MuJoCo's C functions called from compiled code: a plant step of one state without Python.

`mujoco.rollout`, which `tasks.plants.MujocoPlant` calls once per agent step, returns to
Python after every step of the batch; a compiled loop that runs each agent's episodes
through to the end calls the engine itself instead, through the functions of MuJoCo's own
library (`mj_makeData`, `mj_setState`, `mj_step`, `mj_getState`, `mj_deleteData`, loaded
with ctypes and passed to the compiled code as arguments, so that its cached machine code
holds no address of this process).

`step_state` takes the steps `mujoco.rollout` takes for one state (its `_unsafe_rollout`):
the full physics state set, the warm-start accelerations zeroed, the warnings cleared, then
per MuJoCo step, unless a warning was raised, the control set and `mj_step`; the state
read back. The same state and control give the same next state, bit for bit (tested).
"""

import collections
import ctypes
import functools
import pathlib

import mujoco
import numba
import numpy as np
from numba.extending import register_jitable

from lwrl import models

FULL_PHYSICS = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
"""MuJoCo's state signature of the full physics state (`mj_getState`, `mj_setState`)."""
WARMSTART = int(mujoco.mjtState.mjSTATE_WARMSTART)
"""MuJoCo's state signature of the constraint solver's warm start."""
CONTROLS = int(mujoco.mjtState.mjSTATE_CTRL)
"""MuJoCo's state signature of the controls."""
WARNINGS = int(mujoco.mjtWarning.mjNWARNING)
"""The number of MuJoCo's warning kinds, whose counters a step reads."""
LIBRARIES = (f"libmujoco.so.{mujoco.__version__}", "libmujoco*.dylib", "mujoco.dll")
"""The library's file in the `mujoco` package: Linux, macOS, Windows."""

Engine = collections.namedtuple("Engine", "make_data delete_data set_state get_state step")
"""MuJoCo's functions as ctypes objects (a data pointer is `uint8*` to compiled code)."""
EnginePlant = collections.namedtuple(
    "EnginePlant", "engine model substeps actuator controls physics warnings")
"""One MuJoCo plant as compiled code sees it: the `Engine`, the model's address, MuJoCo
steps per agent step, the driven actuator's index, the model's actuator count (`nu`), the
full physics state's size and the byte offset of the warning counters in an `mjData`."""
Workspace = collections.namedtuple("Workspace", "data physics control zeros")
"""An `mjData` and buffers for `step_state`, one per thread at work (a compiled loop opens
one per call of its kernel)."""


@functools.lru_cache(maxsize=None)
def engine() -> Engine:
    """The functions of the MuJoCo library that the `mujoco` package ships (and loaded)."""
    package = pathlib.Path(mujoco.__file__).parent
    found = [path for pattern in LIBRARIES for path in sorted(package.glob(pattern))]
    if not found:
        raise OSError(f"no MuJoCo library ({', '.join(LIBRARIES)}) in {package}")
    library = ctypes.CDLL(str(found[0]))
    # The model goes in as its address, an integer passed as a pointer is on 64-bit ABIs.
    data, model, array = ctypes.POINTER(ctypes.c_uint8), ctypes.c_size_t, ctypes.c_void_p

    def function(name, restype, *argtypes):
        c_function = getattr(library, name)
        c_function.restype, c_function.argtypes = restype, list(argtypes)
        return c_function

    return Engine(
        make_data=function("mj_makeData", data, model),
        delete_data=function("mj_deleteData", None, data),
        set_state=function("mj_setState", None, model, data, array, ctypes.c_uint),
        get_state=function("mj_getState", None, model, data, array, ctypes.c_uint),
        step=function("mj_step", None, model, data))


@functools.lru_cache(maxsize=None)
def _model(name) -> mujoco.MjModel:
    """The MJCF model of `name` (`models.read`), loaded once and kept: compiled code holds
    its address."""
    return mujoco.MjModel.from_xml_string(models.read(name))


def engine_plant(model, actuator: str, substeps: int) -> EnginePlant:
    """The compiled-code view of a model driven through the actuator named `actuator`,
    `substeps` MuJoCo steps per agent step: `model` a model's file as `models.read` takes it
    (`DomainPlants.model`), or a compiled `mujoco.MjModel` that outlives the plant
    (`DomainPlants.mujoco_model`, which keeps the model of each set of parameter values)."""
    model = model if isinstance(model, mujoco.MjModel) else _model(model)
    data = mujoco.MjData(model)
    warnings = data.warning.number.__array_interface__["data"][0] - data._address
    return EnginePlant(engine(), model._address, int(substeps), model.actuator(actuator).id,
                       model.nu, mujoco.mj_stateSize(model, FULL_PHYSICS), warnings)


@register_jitable
def open_workspace(plant):
    """A new `mjData` of the plant's model and buffers; `close_workspace` frees the data."""
    return Workspace(plant.engine.make_data(plant.model), np.zeros(plant.physics),
                     np.zeros(plant.controls), np.zeros(plant.physics))


@register_jitable
def close_workspace(plant, workspace):
    """Free the workspace's `mjData`."""
    plant.engine.delete_data(workspace.data)


@register_jitable
def step_state(plant, workspace, state, control, next_state):
    """One agent step of one state `(d,)` in the task's order (each coordinate, then its
    velocity) with `control` on the plant's actuator, as `mujoco.rollout` steps it; writes
    `next_state`."""
    step_model_state(plant, plant.model, workspace, state, control, next_state)


@register_jitable
def step_model_state(plant, model, workspace, state, control, next_state):
    """`step_state` in the model at address `model` instead of the plant's: a model of the
    same MJCF file at other parameter values (`DomainPlants.mujoco_model`), whose sizes are
    the plant's, so that the workspace's `mjData` serves it, as `mujoco.rollout` steps
    several models with one `mjData` per thread."""
    engine, data, physics = plant.engine, workspace.data, workspace.physics
    half = state.shape[0] // 2
    physics[0] = 0.0
    for j in range(half):
        physics[1 + j] = state[2 * j]
        physics[1 + half + j] = state[2 * j + 1]
    engine.set_state(model, data, physics.ctypes, FULL_PHYSICS)
    engine.set_state(model, data, workspace.zeros.ctypes, WARMSTART)
    # mjWarningStat is (lastinfo, number), two ints: warning i's count is int i * 2 from
    # the first count.
    counters = numba.carray(data, plant.warnings + 8 * WARNINGS)[plant.warnings:].view(np.int32)
    for i in range(WARNINGS):
        counters[i * 2] = 0
    workspace.control[plant.actuator] = control
    for _ in range(plant.substeps):
        warned = False
        for i in range(WARNINGS):
            warned = warned or counters[i * 2] != 0
        if warned:
            break
        engine.set_state(model, data, workspace.control.ctypes, CONTROLS)
        engine.step(model, data)
    engine.get_state(model, data, physics.ctypes, FULL_PHYSICS)
    for j in range(half):
        next_state[2 * j] = physics[1 + j]
        next_state[2 * j + 1] = physics[1 + half + j]
