"""The exported C controller in the loop: `lwrl_act` compiled as a shared library and called
through ctypes for every step of every environment.

`export.c.export_c` writes one saved agent as `lwrl_policy.c` (in double here, so that its
arithmetic is the Python agent's: the float export may round a near tie the other way);
`CController` compiles it with the system C compiler (`-O2 -shared -fPIC`) and stands in
for a batch of agents in the stepped loop (`runners.stepped.run_batched`: it acts, it never
learns), so that its episodes are counted as every run's are. A controller of discrete
actions returns an action's index (`int lwrl_act`), one of continuous actions the action in
[-1, 1] (`lwrl_real lwrl_act`, here a double), which the loop scales to the actuator's range
as it scales every continuous learner's (`tasks.commands`).
"""

import ctypes
import os

import numpy as np

from lwrl.export.c import SOURCE, compile_in, export_c, find_compiler
from lwrl.runners.run import environment_options
from lwrl.runners.stepped import run_batched
from lwrl.tasks.batched import BatchedEnv

LIBRARY = "liblwrl_policy.so"


def build(agent_path, out_dir: str, agent_index: int = 0, compiler=None) -> str:
    """Export agent `agent_index` of the agent file `agent_path` to C (double) in `out_dir`
    and compile it as a shared library there; return the library's path."""
    export_c(agent_path, out_dir, agent_index, dtype="double")
    library = os.path.join(out_dir, LIBRARY)
    compile_in([find_compiler(compiler), "-std=c99", "-O2", "-shared", "-fPIC", "-o", LIBRARY,
                SOURCE, "-lm"], out_dir)
    return library


class CController:
    """B copies of one C controller (`lwrl_act`), acting greedily on B observations: the
    interface of `Agents` that the stepped loop uses (`step`, `diverged`, `batch_size`,
    `continuous`)."""

    def __init__(self, library: str, batch_size: int, continuous: bool = False):
        self.continuous = continuous
        """False: it returns an action's index (`lwrl_act`'s int); True: a continuous
        action in [-1, 1] (its `lwrl_real`, a double)."""
        self._act = ctypes.CDLL(os.path.abspath(library)).lwrl_act
        self._act.argtypes = [ctypes.POINTER(ctypes.c_double)]
        self._act.restype = ctypes.c_double if continuous else ctypes.c_int
        self.batch_size = batch_size
        self.diverged = np.zeros(batch_size, dtype=bool)

    def act(self, observation: np.ndarray) -> int | float:
        """`lwrl_act` of one observation `(d,)`."""
        state = np.ascontiguousarray(observation, dtype=np.float64)
        return self._act(state.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))

    def step(self, first, reward, discount, observation, active=None, learn=True,
             greedy=True) -> np.ndarray:
        """The controller's action for each observation `(B, d)`; it learns nothing."""
        return np.array([self.act(row) for row in observation],
                        dtype=np.float64 if self.continuous else np.int64)


def run_controller(library: str, configs, seeds):
    """The C controller's episodes in each of `configs` (`RunConfig`s of one agent each, as
    the study evaluates, all of one kind of action, the controller's; environment b seeded
    with `seeds[b]`), all in one `BatchedEnv` whose environments have each configuration's
    physics and sensors."""
    base = configs[0]
    env = BatchedEnv(base.domain, base.task_name, base.plant_name, seeds, **base.plant_options,
                     **base.task_options, **environment_options(configs), actions=base.actions)
    return run_batched(env, CController(library, len(configs), base.actions == "continuous"),
                       base.episodes, learn=False, greedy=True)
