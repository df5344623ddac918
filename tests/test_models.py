"""The MJCF models (`models/`) against the paper's parameters and closed-form physics.

Sources: Främling (2008), section 4.2 (pendulum) and 4.3 (cart-pole); SPEC.md, "Task 2",
"Task 3" and "Integration"; Sutton and Barto (1998), section 11.3 (acrobot; more in
`test_acrobot.py`).
"""

import importlib
import math

import mujoco
import numpy as np
import pytest

from lwrl import models, tasks
from lwrl.tasks import acrobot, cartpole, pendulum



def module_of(name: str):
    """The task module whose constants the model of domain `name` must follow."""
    return importlib.import_module(tasks.domain(name).plants.step.__module__)


def _load(name: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(models.read(name))


def _pendulum_without_damping(timestep: float) -> mujoco.MjModel:
    model = _load("pendulum")
    model.dof_damping[:] = 0.0
    model.opt.timestep = timestep
    return model


def _energy(angle, angular_velocity):
    """E = 1/2 m l^2 theta_dot^2 + m g l cos(theta), theta = 0 upright (section 4.2)."""
    return (0.5 * pendulum.NOMINAL.mass * pendulum.NOMINAL.length ** 2 * angular_velocity ** 2
            + pendulum.NOMINAL.mass * pendulum.NOMINAL.gravity * pendulum.NOMINAL.length * np.cos(angle))


# --- files and names -----------------------------------------------------------------------

@pytest.mark.parametrize("name", models.names())
def test_model_file_exists_and_compiles(name):
    """`models.path(name)` is a file and `models.read(name)` is MJCF that MuJoCo compiles,
    whose `<mujoco model=...>` is `name` (the right file is read)."""
    assert models.path(name).is_file()
    model = _load(name)
    assert model.names.split(b"\0", 1)[0].decode() == name


@pytest.mark.parametrize("function", [models.path, models.read])
def test_unknown_model_name_lists_the_available_ones(function):
    """An unknown name raises a ValueError naming every model of `models.names()`."""
    with pytest.raises(ValueError, match="quadrotor") as raised:
        function("quadrotor")
    for name in models.names():
        assert name in str(raised.value)


@pytest.mark.parametrize("name", models.names())
def test_every_element_is_named(name):
    """Every joint, body (except the world), geom and actuator has a non-empty name, so the
    plants and viewers can address them by name."""
    model = _load(name)
    counts = {"joint": (0, model.njnt), "body": (1, model.nbody),
              "geom": (0, model.ngeom), "actuator": (0, model.nu)}
    unnamed = [(kind, index) for kind, (first, count) in counts.items()
               for index in range(first, count) if not getattr(model, kind)(index).name]
    assert unnamed == []


# --- parameters against the paper ----------------------------------------------------------

@pytest.mark.parametrize("name", models.names())
def test_options_are_the_papers_euler_step(name):
    """One MuJoCo step is one control step of 0.02 s under gravity g = 9.81 (sections 4.2,
    4.3); the integrator is MuJoCo's (semi-implicit) Euler with eulerdamp disabled, so that
    joint damping is explicit like the paper's friction terms (SPEC "Integration"). The
    acrobot's control step is four MuJoCo steps of 0.05 s under g = 9.8 (the book's; each
    domain's own test file holds its step to its source)."""
    model = _load(name)
    module = module_of(name)
    substeps = tasks.domain(name).plants.substeps
    assert model.opt.timestep * substeps == module.TIMESTEP
    np.testing.assert_array_equal(model.opt.gravity, [0.0, 0.0, -module.NOMINAL.gravity])
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    assert model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_EULERDAMP


@pytest.mark.parametrize("name, kind, element, field, expected", [
    # Section 4.2: m = 1 kg, mu = 0.01 N m s/rad, tau in {-5, +5} N m.
    ("pendulum", "body", "pendulum", "mass", pendulum.NOMINAL.mass),
    ("pendulum", "joint", "hinge", "damping", pendulum.NOMINAL.friction),
    ("pendulum", "joint", "hinge", "frictionloss", 0.0),
    ("pendulum", "actuator", "torque", "ctrlrange", (min(pendulum.TORQUES), max(pendulum.TORQUES))),
    ("pendulum", "actuator", "torque", "ctrllimited", 1),
    # Section 4.3: mc = 1 kg, m = 0.1 kg, mu_p = 2e-6 N m s/rad, F in {-10, +10} N; the cart's
    # only friction is the Coulomb mu_c = 0.0005 N of the `cart_friction` actuator (no
    # viscous damping, no MuJoCo frictionloss, which would also resist at rest).
    ("cartpole", "body", "cart", "mass", cartpole.NOMINAL.cart_mass),
    ("cartpole", "body", "pole", "mass", cartpole.NOMINAL.pole_mass),
    ("cartpole", "joint", "hinge", "damping", cartpole.NOMINAL.pole_friction),
    ("cartpole", "joint", "hinge", "frictionloss", 0.0),
    ("cartpole", "joint", "slider", "damping", 0.0),
    ("cartpole", "joint", "slider", "frictionloss", 0.0),
    ("cartpole", "actuator", "force", "ctrlrange", (min(cartpole.FORCES), max(cartpole.FORCES))),
    ("cartpole", "actuator", "force", "ctrllimited", 1),
    ("cartpole", "actuator", "cart_friction", "forcerange",
     (-cartpole.NOMINAL.cart_friction, cartpole.NOMINAL.cart_friction)),
    ("cartpole", "actuator", "cart_friction", "forcelimited", 1),
    # Sutton and Barto (1998), section 11.3: m1 = m2 = 1 kg, no friction, tau in [-1, 1] N m.
    ("acrobot", "body", "upper_link", "mass", acrobot.NOMINAL.link_mass_1),
    ("acrobot", "body", "lower_link", "mass", acrobot.NOMINAL.link_mass_2),
    ("acrobot", "joint", "shoulder", "damping", 0.0),
    ("acrobot", "joint", "elbow", "damping", 0.0),
    ("acrobot", "actuator", "torque", "ctrlrange", (min(acrobot.TORQUES), max(acrobot.TORQUES))),
    ("acrobot", "actuator", "torque", "ctrllimited", 1),
])
def test_parameter_is_the_papers(name, kind, element, field, expected):
    """Each compiled model parameter equals the paper's value, as the task module states it
    (sections 4.2 and 4.3; SPEC "Task 2", "Task 3")."""
    value = getattr(getattr(_load(name), kind)(element), field)
    np.testing.assert_array_equal(value, np.reshape(expected, np.shape(value)))


def test_paper_constants():
    """The task modules' constants, which the models are checked against, are the paper's
    numbers (sections 4.2, 4.3; SPEC "Task 2", "Task 3")."""
    assert (pendulum.NOMINAL.mass, pendulum.NOMINAL.length, pendulum.NOMINAL.gravity, pendulum.NOMINAL.friction,
            pendulum.TORQUES, pendulum.TIMESTEP) == (1.0, 1.0, 9.81, 0.01, (-5.0, 5.0), 0.02)
    assert (cartpole.NOMINAL.cart_mass, cartpole.NOMINAL.pole_mass, cartpole.NOMINAL.half_length, cartpole.NOMINAL.gravity,
            cartpole.NOMINAL.cart_friction, cartpole.NOMINAL.pole_friction, cartpole.FORCES, cartpole.TIMESTEP) == (
        1.0, 0.1, 0.5, 9.81, 0.0005, 0.000002, (-10.0, 10.0), 0.02)


# --- derived constants against independent sources -----------------------------------------

@pytest.mark.parametrize("name, body, joint, expected", [
    # The paper's pendulum is a point mass on a massless rod: I = m l^2.
    ("pendulum", "pendulum", "hinge", pendulum.NOMINAL.mass * pendulum.NOMINAL.length ** 2),
    # A uniform rod of length 2l about its end: m (2l)^2 / 3 = (4/3) m l^2, the 4/3 of the
    # paper's cart-pole equation (section 4.3; Barto, Sutton and Anderson 1983).
    ("cartpole", "pole", "hinge", 4.0 / 3.0 * cartpole.NOMINAL.pole_mass * cartpole.NOMINAL.half_length ** 2),
    # The book's links: I + m lc^2 = 1 + 0.25 about each joint (the elbow's is m2 lc2^2 + I2,
    # the lower right entry of the book's mass matrix).
    ("acrobot", "upper_link", "shoulder", acrobot.NOMINAL.link_inertia_1 + acrobot.NOMINAL.link_mass_1 * acrobot.NOMINAL.link_com_1 ** 2),
    ("acrobot", "lower_link", "elbow", acrobot.NOMINAL.link_inertia_2 + acrobot.NOMINAL.link_mass_2 * acrobot.NOMINAL.link_com_2 ** 2),
])
def test_inertia_about_the_hinge(name, body, joint, expected):
    """The compiled body's inertia about its hinge axis (its inertia tensor about the centre
    of mass, rotated to the body frame, plus m d^2 with d the distance of `body_ipos` from the
    axis) equals the inertia behind the paper's equation, within 1e-9 relative. (The
    pendulum's 1e-12 kg m^2 of own inertia, which MuJoCo needs, is 1e-12 relative.)"""
    model = _load(name)
    body, joint = model.body(body), model.joint(joint)
    assert joint.bodyid == body.id
    rotation = np.empty(9)
    mujoco.mju_quat2Mat(rotation, body.iquat)
    rotation = rotation.reshape(3, 3)
    inertia_at_centre = rotation @ np.diag(body.inertia) @ rotation.T
    axis = joint.axis / np.linalg.norm(joint.axis)
    offset = body.ipos - joint.pos
    distance_squared = offset @ offset - (offset @ axis) ** 2
    inertia = axis @ inertia_at_centre @ axis + body.mass[0] * distance_squared
    assert inertia == pytest.approx(expected, rel=1e-9)


def test_pole_mass_length_is_a_product():
    """m l in the cart-pole equation is the product 0.1 kg * 0.5 m = 0.05 kg m (section 4.3);
    Gymnasium's functional cart-pole once used the sum m + l here. At a spinning pole
    (theta = 0.3 rad, theta_dot = 2 rad/s, the cart at rest, F = 10 N) the accelerations are
    the equations' with the product, computed here from the paper's values, and not those
    with the sum."""
    mc, m, l, g, mu_p = (cartpole.NOMINAL.cart_mass, cartpole.NOMINAL.pole_mass,
                         cartpole.NOMINAL.half_length, cartpole.NOMINAL.gravity,
                         cartpole.NOMINAL.pole_friction)
    theta, theta_dot, force = 0.3, 2.0, 10.0

    def paper(mass_length):
        theta_dd = (g * math.sin(theta) + math.cos(theta) * (
            -force - mass_length * theta_dot ** 2 * math.sin(theta)) / (mc + m)
            - mu_p * theta_dot / mass_length) / (l * (4 / 3 - m * math.cos(theta) ** 2 / (mc + m)))
        x_dd = (force + mass_length * (theta_dot ** 2 * math.sin(theta) - theta_dd * math.cos(theta))) / (mc + m)
        return x_dd, theta_dd

    ours = cartpole.accelerations(0.0, theta, theta_dot, force, False, np.asarray(cartpole.NOMINAL))
    assert ours == pytest.approx(paper(m * l), rel=1e-12)
    assert ours != pytest.approx(paper(m + l), rel=1e-3)


# --- closed forms: period and energy of the pendulum --------------------------------------

PERIOD_TIMESTEP = 0.001
PERIOD_STEPS = 10_000
"""10 s at 1 ms: five upward crossings, four periods."""


def _mujoco_swing(start):
    model = _pendulum_without_damping(PERIOD_TIMESTEP)
    data = mujoco.MjData(model)
    data.qpos[0] = start
    angles = [start]
    for _ in range(PERIOD_STEPS):
        mujoco.mj_step(model, data)
        angles.append(data.qpos[0])
    return np.array(angles)


def _analytic_swing(start):
    angle, angular_velocity = start, 0.0
    angles = [start]
    for _ in range(PERIOD_STEPS):
        angle, angular_velocity = pendulum.step(angle, angular_velocity, 0.0, PERIOD_TIMESTEP, True,
                                                False, np.asarray(pendulum.NOMINAL))
        angles.append(angle)
    return np.array(angles)


@pytest.mark.parametrize("swing", [_mujoco_swing, _analytic_swing], ids=["mujoco", "analytic"])
def test_small_angle_period(swing):
    """A small swing about the hanging equilibrium theta = pi (theta = 0 is upright) has the
    period 2 pi sqrt(l/g) = 2.006067 s of m l^2 theta_dd = m g l sin(theta) linearised
    (section 4.2's equation with tau = 0).

    Started at pi + 0.05 rad at rest, no torque, dt = 1 ms for 10 s; the period is measured
    between successive upward zero crossings of theta - pi (linearly interpolated). Measured:
    MuJoCo (damping set to 0) 2.006379 s; analytic plant (semi-implicit) 2.006369 s down to
    2.006351 s as the swing decays. Both are +1.6e-4 relative to the closed form, the
    finite-amplitude correction theta0^2 / 16 = 1.6e-4, so the check is 0.1 % (tighter than
    1 %: g = 10 instead of 9.81 changes the period by 0.95 %).

    The analytic plant keeps its hinge friction mu = 0.01 (the paper's value): the damped
    frequency omega_d = sqrt(omega0^2 - (mu / 2 m l^2)^2) = sqrt(9.81 - 0.005^2) differs from
    omega0 = sqrt(9.81) by 0.005^2 / (2 * 9.81) = 1.3e-6 relative, which is negligible.
    """
    hanging = math.pi
    offset = swing(hanging + 0.05) - hanging
    upward = np.nonzero((offset[:-1] < 0.0) & (offset[1:] >= 0.0))[0]
    crossings = PERIOD_TIMESTEP * (upward - offset[upward] / (offset[upward + 1] - offset[upward]))
    periods = np.diff(crossings)
    assert len(periods) == 4
    closed_form = 2.0 * math.pi * math.sqrt(pendulum.NOMINAL.length / pendulum.NOMINAL.gravity)
    assert periods == pytest.approx(np.full(4, closed_form), rel=1e-3)


ENERGY_STEPS = 500
"""10 s at the task's 0.02 s."""


@pytest.mark.parametrize("start, bound", [
    # Measured max |E - E0| (J): 0.4547, 0.1706, 0.00317; the first-order modified energy of
    # semi-implicit Euler, E + (dt/2) g theta_dot sin(theta), predicts
    # (dt/2) g max|theta_dot sin(theta)| = 0.4510, 0.1664, 0.00307 along the orbit.
    (0.5, 0.50),
    (2.0, 0.19),
    (3.0, 0.0035),
])
def test_mujoco_energy_without_damping_is_bounded(start, bound):
    """With the hinge damping off and no torque, the MuJoCo pendulum at the task's 0.02 s
    keeps its energy E = 1/2 m l^2 theta_dot^2 + m g l cos(theta) (section 4.2) within a
    bound over 10 s: semi-implicit Euler is symplectic, its error oscillates without drift
    (SPEC "Integration"). Measured max |E - E0| for starts 0.5, 2.0, 3.0 rad from upright:
    0.4547, 0.1706, 0.00317 J (bounds 0.50, 0.19, 0.0035 J).

    No drift: the largest error over the last 5 s is within 1 % of that over the first 5 s
    (measured ratios within 1e-3 of 1); explicit Euler's error grows instead (next test).
    MuJoCo's own `data.energy` agrees with E up to the constant m g times the hinge's height
    (its potential is m g z of the centre of mass), within 1e-9 J (measured 2e-11 J).
    """
    model = _pendulum_without_damping(pendulum.TIMESTEP)
    data = mujoco.MjData(model)
    data.qpos[0] = start
    energies, mujoco_energies = [], []
    for _ in range(ENERGY_STEPS + 1):
        mujoco.mj_forward(model, data)  # data.energy of the current state
        energies.append(_energy(data.qpos[0], data.qvel[0]))
        mujoco_energies.append(data.energy.sum())
        mujoco.mj_step(model, data)
    error = np.abs(np.array(energies) - energies[0])
    assert error.max() < bound
    half = ENERGY_STEPS // 2
    assert error[half:].max() <= 1.01 * error[:half + 1].max()
    hinge_height = model.body("pendulum").pos[2]
    potential_offset = pendulum.NOMINAL.mass * pendulum.NOMINAL.gravity * hinge_height
    np.testing.assert_allclose(np.array(mujoco_energies) - potential_offset, energies,
                               rtol=0, atol=1e-9)


@pytest.mark.parametrize("start, gain", [
    # Measured over 10 s with mu = 0.01: explicit +6.21, +11.43, +0.520 J;
    # semi-implicit -1.28, -0.652, -0.0087 J.
    (0.5, 5.0),
    (2.0, 10.0),
    (3.0, 0.4),
])
def test_explicit_euler_adds_energy(start, gain):
    """Explicit Euler adds energy to the pendulum (SPEC "Integration"): the analytic plant
    (section 4.2's equation, with its friction mu = 0.01, no torque, dt = 0.02 s) started at
    rest 0.5, 2.0, 3.0 rad from upright ends 10 s later with E - E0 = +6.21, +11.43, +0.520 J
    (asserted above 5, 10, 0.4 J), although friction should remove energy; with the
    semi-implicit scheme the same plant loses energy, as friction demands (measured -1.28,
    -0.652, -0.0087 J)."""
    final_energy = {}
    for semi_implicit in (False, True):
        angle, angular_velocity = start, 0.0
        for _ in range(ENERGY_STEPS):
            angle, angular_velocity = pendulum.step(
                angle, angular_velocity, 0.0, pendulum.TIMESTEP, semi_implicit, False,
                np.asarray(pendulum.NOMINAL))
        final_energy[semi_implicit] = _energy(angle, angular_velocity)
    initial_energy = _energy(start, 0.0)
    assert final_energy[False] - initial_energy > gain
    assert final_energy[True] < initial_energy


# --- the cart-pole in MuJoCo --------------------------------------------------------------

def _cartpole_run(force, steps):
    model = _load("cartpole")
    data = mujoco.MjData(model)
    data.ctrl[model.actuator("force").id] = force
    mujoco.mj_step(model, data)
    first_acceleration = data.qacc.copy()
    for _ in range(steps - 1):
        mujoco.mj_step(model, data)
    slider, hinge = (model.joint(name).qposadr[0] for name in ("slider", "hinge"))
    assert (slider, hinge) == tuple(model.joint(name).dofadr[0] for name in ("slider", "hinge"))
    return data, first_acceleration, slider, hinge


def test_cartpole_rests_without_force():
    """From the all-zero start (section 4.3) with F = 0, nothing moves over 100 steps, exactly:
    the cart's Coulomb friction is -mu_c sgn(x_dot) with sgn(0) = 0 (SPEC "Task 3"), so it
    does not act at rest, and the upright pole is in (unstable) equilibrium."""
    data, _, _, _ = _cartpole_run(0.0, 100)
    assert np.all(data.qpos == 0.0)
    assert np.all(data.qvel == 0.0)
    assert np.all(data.qacc == 0.0)
    assert np.all(data.actuator_force == 0.0)


def test_cartpole_positive_force_pushes_cart_toward_plus_x():
    """F = +10 N pushes the cart toward +x and tips the pole toward negative angles (section
    4.3: theta_dd has -F, SPEC "Task 3").

    First step, from rest (sgn(0) = 0, theta = theta_dot = 0), by hand from the paper:
    theta_dd = (-F / (mc + m)) / (l (4/3 - m / (mc + m))) = -(100/11) / (41/66) = -600/41
    = -14.634 rad/s^2 and x_dd = (F - m l theta_dd) / (mc + m) = (10 + 30/41) / 1.1 = 400/41
    = 9.756 m/s^2; MuJoCo's rigid-body accelerations equal them within 1e-9 relative. After
    10 steps (0.2 s): x, x_dot > 0 and theta, theta_dot < 0."""
    data, first_acceleration, slider, hinge = _cartpole_run(10.0, 10)
    assert first_acceleration[slider] == pytest.approx(400.0 / 41.0, rel=1e-9)
    assert first_acceleration[hinge] == pytest.approx(-600.0 / 41.0, rel=1e-9)
    assert data.qpos[slider] > 0.0 and data.qvel[slider] > 0.0
    assert data.qpos[hinge] < 0.0 and data.qvel[hinge] < 0.0
