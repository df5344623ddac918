"""The suite's tasks in JAX (the `jax` extra): gymnax-style environments whose physics is the
analytic plant's own functions, traced by JAX (`lwrl.jax.translate`).

    import jax
    jax.config.update("jax_enable_x64", True)      # the analytic plant's float64 numbers
    import lwrl.jax
    env, params = lwrl.jax.make("cartpole.balance")
    obs, state = env.reset(key, params)
    obs, state, reward, terminated, truncated, info = env.step(key, state, action, params)

`reset` and `step` are pure functions of their arguments: `jax.jit` compiles them and
`jax.vmap` batches them over keys (agents) and over `params` (the domain's physical
parameters `(P,)`, so randomised physics runs in one program). `tests/test_jax_tasks.py`
holds every domain's JAX step to the analytic plant (the numba functions the other loops
call) within 1e-12 over whole random-action episodes, at the paper's parameter values and
away from them.

`make(name, actions="continuous")` makes the action the control itself, clipped to
`env.action_range(params)` as the NumPy environments clip it; the tests hold its episodes
to `tasks.batched.BatchedEnv`'s within the same 1e-12.

`make(name, plant="mjx")` steps the domain's MuJoCo model by MJX instead of its equations
(`lwrl.jax.mjx`: the pendulum, the cart-pole and the acrobot, at the parameter values it is
made with, in float64); `tests/test_jax_mjx.py` holds its episodes to MuJoCo's C engine.
"""

from lwrl.jax.environment import PLANTS, EnvState, Environment, make

__all__ = ["PLANTS", "EnvState", "Environment", "make"]
