"""Shared fixtures: every (domain, task, plant) of the suite's dm_env environments, physical
parameter values away from the paper's, short time limits, a command run in this process, an
OpenGL backend that renders headless; and the check that a call is refused in one line."""

import os
import pathlib
import re
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
from hypothesis import settings

from lwrl import tasks
from lwrl.cli import main as cli

settings.register_profile("derandomized", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "derandomized"))
"""Hypothesis draws the same examples on every run (`derandomized`): a failure it finds is
found again, and the suite does not pass or fail by the draw. `HYPOTHESIS_PROFILE=explore
pytest ...` draws afresh, to look for faults the fixed draws miss."""

TASK_PLANTS = [(domain, task, plant) for domain, task in tasks.ALL_TASKS
               for plant in tasks.ENVIRONMENT_PLANTS[domain]]


@pytest.fixture(params=TASK_PLANTS, ids=lambda p: f"{p[0]}.{p[1]}-{p[2]}")
def task_plant(request):
    """A `(domain, task, plant)` triple; tests using it run over the whole suite."""
    return request.param


def short_time_limit(chosen: dict, domain: str, steps: int = 20) -> float:
    """A time limit short enough that a test's episodes end and restart: `chosen[domain]`, the
    one the test chose for each of lwrl's own domains, else `steps` control steps of the
    domain's first task (a domain of another package, `tasks.ENTRY_POINT_GROUP`)."""
    if domain in chosen:
        return chosen[domain]
    return steps * tasks.definition(domain, next(iter(tasks.domain(domain).tasks))).control_timestep


def set_state(env, state):
    """Put a dm_env environment of the suite in `state` (after a reset)."""
    env.reset()
    with env.physics.reset_context():
        env.physics.set_state_vector(state)


def one_step(domain, task, state, action, **options):
    """The analytic plant's state after `action` from `state`."""
    env = tasks.load(domain, task, plant="analytic", **options)
    env.reset()
    set_state(env, state)
    env.step(action)
    return env.physics.state_vector()


def off_nominal(domain: str, rng: np.random.Generator, count=None) -> np.ndarray:
    """Physical parameter values of `domain` away from the paper's: each nominal value times
    2^u, u ~ U[-1, 1] drawn for each, within the accepted range; `(count, P)` rows, or one
    vector `(P,)` where `count` is None."""
    parameters = tasks.domain(domain).parameters
    nominal = np.asarray(parameters.nominal)
    values = nominal * 2.0 ** rng.uniform(-1, 1, size=nominal.shape if count is None
                                          else (count, len(nominal)))
    return np.clip(values, [p.low for p in parameters.items], [p.high for p in parameters.items])


def run_cli(argv, capsys):
    """`(status, stdout, stderr lines)` of the command, in this process."""
    try:
        status = cli.main(argv)
    except SystemExit as exit_:
        status = exit_.code
    captured = capsys.readouterr()
    return status, captured.out, captured.err.strip().splitlines()


OPENGL_PROBE = ("from dm_control import mujoco\n"
                "physics = mujoco.Physics.from_xml_string('<mujoco><worldbody><light pos=\"0 0 1\"/>"
                "<geom size=\"0.1\"/></worldbody></mujoco>')\n"
                "assert physics.render(16, 16).std() > 0\n")


@pytest.fixture(scope="session")
def opengl():
    """`MUJOCO_GL` of a backend that renders headless here (EGL, else OSMesa), for child
    processes; skips the test where there is none."""
    for backend in ("egl", "osmesa"):
        probe = subprocess.run([sys.executable, "-c", OPENGL_PROBE], capture_output=True,
                               env={**os.environ, "MUJOCO_GL": backend}, timeout=120)
        if probe.returncode == 0:
            return backend
    pytest.skip("no headless OpenGL here: apt-get install libegl1 libegl-mesa0 "
                "libgl1-mesa-dri (EGL) or libosmesa6 (OSMesa)")


TOYS = ("toy_learner", "toy_task")
"""The toy packages of tests/: a learner and a domain from outside lwrl, each a project with
its pyproject.toml."""


@pytest.fixture(scope="session")
def installed_toys(tmp_path_factory) -> dict:
    """`{toy: directory}`: each of `TOYS` really installed, by pip from its pyproject.toml (its
    entry points, its package data), into a directory of its own (`--target`; lwrl and the
    dependencies are this environment's). Built from a copy, so that the build leaves nothing
    in tests/; setuptools for the build comes from the package index, as for any project."""
    work = tmp_path_factory.mktemp("toys")
    installed = {}
    for toy in TOYS:
        source = work / "source" / toy
        shutil.copytree(pathlib.Path(__file__).parent / toy, source,
                        ignore=shutil.ignore_patterns("__pycache__", "build", "*.egg-info"))
        target = work / toy
        built = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--quiet",
                                "--target", str(target), str(source)],
                               capture_output=True, text=True, timeout=600)
        if built.returncode != 0 and "Could not find a version that satisfies" in built.stderr:
            pytest.skip("building the toy packages needs setuptools from the package index, "
                        "not reachable here")
        assert built.returncode == 0, built.stderr[-3000:]
        installed[toy] = target
    return installed


def learner_case(learner: str, *values):
    """`pytest.param(learner, *values)`, skipped saying why where the learner's libraries
    are not installed (`Learner.unavailable`)."""
    from lwrl import agent as learners
    reason = learners.learner(learner).unavailable()
    return pytest.param(learner, *values, marks=pytest.mark.skipif(reason is not None,
                                                                    reason=str(reason)))


def one_line_error(call, *fragments):
    """`call()` raises a one-line ValueError holding each of `fragments`."""
    with pytest.raises(ValueError) as error:
        call()
    message = str(error.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message


# The quick loop -------------------------------------------------------------------------
# `pytest -m "not slow"` leaves out the tests SLOW names, which take nearly all of the
# suite's time, and keeps a fast test of every module: a case or two of each check that runs
# over every task, plant or learner, and the checks that need no JIT compiling, no child
# process, no tool outside Python and no long run. Plain `pytest`, the README's command and
# CI's, runs every test. The loop's time assumes the learning loops' kernels are cached (in
# ~/.cache/lwrl/kernels, keyed by their sources: a first run, or the first after a kernel's
# source changed, compiles them again, for a minute or more). Each key of SLOW is a regular
# expression matched from the start of a test's id below tests/
# ("test_file.py::test_name[parameters]"); its value says why those tests are slow. A test
# may also carry `@pytest.mark.slow` itself.

NETWORKS_AND_POPULATIONS = (r"((dqn|ppo|sac|td3)(_jax)?|ars(_continuous)?"
                            r"|stream_(q|ac_discrete|ac))")
"""The learners of neural networks (PyTorch, JAX) and the other JAX populations (ARS, the
streaming learners): seconds a run, compiling their programs, where the others take
milliseconds."""

OTHER_TASKS = r"(pendulum|acrobot)"
"""Where a check runs on every task, the mountain car and the cart-pole (the cheapest) stay
in the quick loop and these leave it."""

CONTRACT = (r"test_learners\.py::(test_every_run_path|test_an_agent_is_the_same_alone|test_the_"
            r"arrays_the_loops_read|test_acting_greedily|test_saved_agents_load|test_values_over_"
            r"a_grid|test_a_learner_learns_in_c)[^\[]*")
"""The learner contract's checks that train agents, over every learner and task."""

SLOW = {
    # Tools outside Python.
    r"test_wheel\.py::": "builds the wheel and installs it into a fresh virtual environment",
    r"test_web_viewer\.py::": "starts headless Chromium",
    r"[^:]+::[^\[]*chromium": "starts headless Chromium",
    r"test_typing\.py::test_mypy_": "runs mypy on the package",
    r"test_device\.py::(test_the_emulated_cortex_m4_|test_costs_are_measured_on_both_"
    r"|test_libm_agreement)": "cross-compiles for the Cortex-M4 and runs it under QEMU",
    r"test_timed_costs\.py::test_callgrind_": "runs the exported controller under valgrind",
    r"test_reproduce\.py::test_ray_backend": "starts a local Ray instance",
    r"test_robustness\.py::test_a_study_on_ray": "starts a local Ray instance",
    r"test_conventions\.py::test_physics_renders_pixels_headless"
    r"|test_gymnasium_render\.py::(test_models_are_drawn_from_their_first_camera|test_record_"
    r"video|test_human_rendering)": "a child process renders with OpenGL; a video is encoded "
        "(moviepy); a window opens (pygame, where there is a display)",
    r"test_viz\.py::(test_headless_render_is_not_blank|test_a_recording_opens_on_its_last_logged)":
        "starts the Rerun viewer, rendering through Vulkan (skipped where there is no driver)",
    r"test_nominal\.py::": "computes every plant and run path afresh, numba compiling the "
        "transitions and the engine step",
    # Child processes, each importing lwrl.
    r"test_kernels\.py::": "processes compile the learning loops into empty caches; numba "
        "compiles a probe",
    r"test_kernel_cache\.py::": "two or more processes a case, compiling into fresh caches",
    r"test_cli\.py::(test_bad_input_is_one_line_and_status_2|test_mjx_without_jax)":
        "a process a case",
    r"test_compare\.py::test_bad_task_is_one_line_and_status_2": "a process a case",
    r"test_typing\.py::test_lwrl_tasks_imports_from_the_repository_root": "a process",
    r"test_gymnasium_envs\.py::test_registration_from_a_fresh_interpreter": "a process",
    r"test_store\.py::test_a_batch_claimed_by_a_live_process": "a process holds a claim",
    r"test_outputs\.py::test_ctrl_c_stops_the_work": "trains in a process for seconds",
    r"test_claims\.py::(test_two_trainings_aimed_at_one_directory|test_a_reader_never_sees_one_"
    r"runs_file_beside_anothers)": "trainings in processes; runs written while read",
    # JIT compiling: MJX's and JAX's programs, numba's functions of a test's own (the learning
    # loops' kernels are cached; these are not).
    r"test_mjx_plant\.py::(?!test_every_model_has_an_mjx_plant)": "compiles MJX's step",
    r"test_parameters\.py::test_the_mjx_plant_takes_one_set_of_values": "compiles MJX's step",
    r"test_jax_mjx\.py::(test_every_step|test_a_population)": "compiles MJX's step inside JAX programs",
    r"test_population\.py::(?!test_a_batch_of_settings_that_cannot_be_batched)":
        "compiles JAX programs of networks",
    r"test_jax_peer\.py::": "compiles and runs the JAX peer (a benchmark, not the package)",
    r"test_jax_tasks\.py::(test_every_step_of_an_episode_is_the_analytic_plants\[(?!nominal-"
    r"cartpole)|test_float32_steps_stay_within_float32_rounding\[(?!mountain_car)|test_starts_"
    r"follow_the_tasks_distribution|test_params_batch_over_vmap|test_a_time_limit_is_a_"
    r"truncation|test_an_episode_ends_in_a_new_start|test_action_delay_and_sensor)":
        "compiles a JAX program a case; one case of two checks stays",
    r"test_suite\.py::test_transition_is_the_plant_step_and_the_task": "numba compiles the "
        "transition afresh a case (the learning loops' cached kernels hold it)",
    r"test_disturbances\.py::test_a_compiled_loop_calling_the_pieces"
    r"|test_engine\.py::test_a_compiled_step_is_rollouts_step"
    r"|test_nrbf\.py::test_single_state_function_equals_the_batch_method"
    r"|test_traces\.py::test_rules_compiled_in_numba"
    r"|test_policy\.py::(test_greedy_picks_the_best_action|test_ties_are_broken|test_epsilon_"
    r"explores)"
    r"|test_parameters\.py::test_the_compiled_loops_engine_steps_the_model":
        "numba compiles a loop of the test's own",
    r"test_learner_c\.py::(?!test_double_learner_is_the_python_learner_bit_for_bit\[mountain_car\]"
    r"|test_bad_inputs)": "compiles the C learner and trains in C and in Python",
    r"test_export_c\.py::(test_measure_reports|test_c_controller_picks_the_python_agents_greedy_"
    r"action\[(?!mountain_car)|test_double_precision_controller_agrees_too\[(?!mountain_car)"
    r"|test_c_actor_gives_the_python_agents_greedy_action\[(?!pendulum_actor-float))":
        "compiles and runs C controllers",
    r"test_robustness\.py::test_the_c_controller_acts": "compiles a C controller",
    r"test_ars_c\.py::(?!test_continuous_actions)": "compiles ARS's C learner and trains it "
        "(on the emulated Cortex-M4 too)",
    r"test_stream_q_c\.py::": "compiles stream-Q's C learner and trains it (on the emulated "
        "Cortex-M4 too)",
    r"test_device\.py::test_host_build_in_double_is_the_python_learner_on_the_python_plant"
    r"\[(?!paper)": "compiles and runs the device program on the host",
    # The network learners and the JAX populations (their modules stay in the quick loop
    # through the settings checks of test_stable_baselines.py, test_population.py,
    # test_ars.py and test_streaming.py).
    rf"{CONTRACT}\[{NETWORKS_AND_POPULATIONS}-": "trains networks or JAX populations",
    rf"test_robustness\.py::test_every_learner_goes_on_with_its_kept_agents[^\[]*"
    rf"\[{NETWORKS_AND_POPULATIONS}\]": "trains networks or JAX populations",
    r"test_stable_baselines\.py::(?!test_bad_settings)":
        "builds and trains SB3's networks (PyTorch); exports a network and compiles it",
    r"test_streaming\.py::(test_stream_q_learns|test_stream_(q|ac)_s_first_updates|test_every_"
    r"observation_enters|test_sparse_initialisation)"
    r"|test_ars\.py::(test_the_policy_moves|test_ars_learns|test_every_rollout_s_steps)"
    r"|test_observation_normalisation\.py::(test_the_first_observations|test_a_saved_and_loaded"
    r"|test_a_streaming_learner_without|test_a_stopped_normalising_run|test_the_action_values_"
    r"read|test_a_greedy_act_leaves)"
    r"|test_budget\.py::test_a_family_of_budgets|test_records\.py::test_(the_cpu_grows|the_"
    r"arithmetic_is_the)|test_timed_costs\.py::test_a_row_whose_agents_have_no_c"
    r"|test_jax_tasks\.py::test_(makes_example_runs|continuous_actions_jit_and_vmap)"
    r"|test_resume\.py::":
        "trains JAX populations (ARS, the streaming learners), compiling their programs (their "
        "equations by hand and their settings' checks stay)",
    r"test_hil\.py::(test_the_device_learns_over_the_link_what_lwrl_learns\[(?!mountain_car)"
    r"|test_the_emulated_board)": "trains over the link on MuJoCo's pendulum, or on the "
        "emulated board (the mountain car's case stays)",
    # Learning runs, whole commands and long rollouts.
    r"test_learners\.py::test_every_run_path_gives_the_same_numbers\[(?!ase_ace)[^-]+-(?!"
    r"mountain_car)": "every run path over whole episodes; the mountain car stays",
    r"test_acrobot\.py::(test_train_command_smoke|test_agents_learn_to_swing_up)": "trains agents",
    r"test_ase_ace\.py::test_it_learns_to_balance": "trains agents",
    r"test_external\.py::test_mountain_car_agents_learn": "trains agents",
    r"test_external\.py::(test_dm_control_episodes_end_at_the_time_limit|test_bad_input_is_one_"
    r"line_and_exit_2\[argv\d+-dmc)": "runs dm_control's tasks (one flattening check stays)",
    r"test_run\.py::test_pendulum_agents_balance_within": "trains agents",
    r"test_viz\.py::test_episodes_recorded_by_training": "trains agents",
    r"test_verdicts\.py::test_probability_of_improvement": "bootstraps",
    r"test_robustness\.py::test_lwrl_robustness_writes_its_report": "a robustness study",
    r"test_robustness\.py::test_a_quick_study_trains_evaluates_and_reports_a_population":
        "a robustness study of a JAX population learner: compiles its programs",
    r"test_robustness\.py::test_a_quick_study_trains_evaluates_and_reports_a_continuous":
        "a robustness study of the continuous actor-critic, its C controller compiled",
    r"test_benchmark_report\.py::test_the_report_keeps_every_row": "writes the committed "
        "benchmark's report twice (its figures, its bootstrap intervals)",
    r"test_benchmark_killed\.py::": "lwrl bench run three times in child processes (killed, "
        "resumed, uninterrupted)",
    r"test_benchmark_study\.py::test_a_tiny_continuous_benchmark": "a tiny benchmark of "
        "the continuous pendulum: trains the actor-critic and SAC, compiling its programs",
    r"test_benchmark_study\.py::test_the_pendulum_with_three_torques": "two tiny "
        "benchmarks: the paper's agent and the actor-critic trained, evaluated and measured",
    r"test_benchmark_study\.py::test_a_tiny_benchmark": "a tiny "
        "benchmark: searches, trains and evaluates every linear row (and measures its costs)",
    r"test_budget\.py::(test_a_population|test_a_budget_cuts_the_run_it_would_have_been\[cartpole)":
        "compiles a JAX program; runs the cart-pole twice (Mountain-Car's case stays)",
    r"test_timed_costs\.py::test_population_agents_act": "compiles a JAX network",
    r"test_benchmark3_report\.py::test_(the_report|a_row_not_rising)": "runs a tiny third "
        "benchmark (the CPU to the level's reading on arrays stays)",
    r"test_table_schemas\.py::test_(every_run_table|the_third_benchmarks_run_tables)": "reads the "
        "committed benchmarks' run tables against their schema",
    r"test_benchmark3\.py::test_(a_tiny_third_benchmark|the_status_of_a_directory_not_begun)":
        "a tiny third benchmark; the status of every row's trainings planned",
    r"test_benchmark_planning\.py::test_(saturation_facts|pendulum_detectable)": "reads the "
        "second benchmark's committed tables (the flags' checks stay)",
    r"test_benchmark_evaluation\.py::test_the_random_row_is_far_from_the_classical_row\[(?!"
    r"mountain_car)|test_benchmark_judging\.py::test_the_(report_judges_every_task|verdicts_yes"
    r"_no_and_partly)|test_benchmark_variants\.py::test_classical_controller_meets":
        "the reference rows' episodes, or the judging of a whole benchmark (Mountain-Car's "
        "case and the judging's parts stay)",
    r"test_benchmark_outside_properties\.py::test_(a_table_that_breaks|every_table_on_the)":
        "Hypothesis: a table scored for each of many generated inputs",
    r"test_link\.py::test_(faults_cost_their_step|a_device_that_comes_back)"
    r"|test_hil\.py::(test_a_device_that_(stalls|restarts)|test_in_real_time|test_late_answers"
    r"|test_duplicated_observations|test_against_a_silent_noisy_or_wrong_device\[(?!silent))":
        "sessions over the link of many steps, each waiting its deadlines (one of each kind of "
        "fault stays)",
    r"test_benchmark_harness\.py::(test_a_continuous_policy|test_an_episode_that_does_not_reach"
    r"|test_lwrl_bench_evaluate|test_saved_agents_act|test_a_policy_of_a_batch_of_one)"
    r"|test_sb3_cost\.py::test_(on_mujocos_model|a_run_resumed_across)"
    r"|test_agent_io\.py::test_a_file_from_before_learners_said_what_they_have_loads\[(?!ars)":
        "the protocol's episodes evaluated, a model built or a network saved (the harness's "
        "checks of its inputs stay)",
    r"test_jax_task_properties\.py::test_a_step_within_the_spaces_is_finite\[(?!mountain_car)"
    r"|test_jax_tasks\.py::test_continuous_episodes_are_the_numpy_environments\[(?!mountain_car)"
    r"|test_continuous_actions\.py::test_the_plants_agree_under_continuous_actions\[(?!pendulum)"
    r"|test_graphical\.py::test_the_family_wise_error_rate"
    r"|test_verdicts\.py::test_the_intervals_are_rliable_s"
    r"|test_benchmark_outside_properties\.py::test_(a_damaged_gzip|lwrl_bench_score_refuses)":
        "the same check on the other tasks, or a simulation, a bootstrap or generated inputs "
        "(Mountain-Car's case, or a hand-worked one, stays)",
    r"test_benchmark_evaluation\.py::test_the_classical_cartpole_balances_every_240_s"
    r"|test_sb3_cost\.py::test_the_report_multiplies|test_benchmark_compute_plan\.py::test_one_"
    r"row_recomputed": "the classical controller's 240-s episodes; a report or a plan read "
        "from the committed ledgers",
    r"test_benchmark_dataset\.py::test_the_committed_dataset": "reads the committed Parquet "
        "dataset and a run table of every fifty",
    r"test_reproduce\.py::test_runs_of_one_program_train": "compiles a JAX population's "
        "programs for a batch of one run and of three",
    r"test_reproduce\.py::(test_a_killed_sweep_resumes|test_quick_reproduction_writes|test_fig3_"
    r"verdict_counts_both_conditions\[(?!60\.0-40-))": "a reproduction sweep; fig. 3's "
        "verdict drawn for each case (one stays)",
    r"test_config\.py::test_reproduce_sets_readings_from_the_command_line": "a reproduction sweep",
    r"test_compare\.py::(test_quick_cli_run_writes|test_recording_holds_an_entity|test_replay_on_"
    r"mujoco)": "`lwrl compare --quick`; an episode replayed on MuJoCo",
    r"test_benchmarks\.py::test_\w+_quick_prints_its_table": "a quick benchmark",
    r"test_sb3_cost\.py::test_every_configuration_is_measured": "trains SB3's DQN and PPO "
    "(a quick benchmark)",
    r"test_implementations\.py::test_the_report_is_written": "draws the report's figures",
    r"test_verdicts\.py::test_the_claims_figure_draws": "draws the claims' figure",
    r"test_aggregates\.py::test_(the_aggregates|profiles_and_improvement)_are_rliable_s": "rliable's "
        "bootstrap, a Python loop over its resamples (its seeding and input checks stay)",
    r"test_gymnasium_envs\.py::test_observations_stay_inside_the_box": "rolls out several "
        "policies over long episodes (test_observation_bounds stays)",
    r"test_gymnasium_vector\.py::test_the_same_transitions_as_the_single_environments":
        "long episodes through both (the vector wrapper's episode count stays)",
    r"test_plant_check\.py::(test_(acrobot|pendulum)_plants_agree_over_50_and_200|test_cartpole_"
    r"plants_agree_over_whole|test_explicit_euler_departs_from_both\[acrobot)":
        "steps the plants over long episodes",
    r"test_classical\.py::(test_cartpole_balances_for_the_full_episode|test_pendulum_swings_up_"
    r"and_holds_from_random_starts|test_pendulum_swings_up_away)":
        "long episodes under the classical controllers",
    r"test_disturbances\.py::(test_observation_noise_is_gaussian|test_action_noise_is_added)":
        "thousands of steps of dm_env environments",
    r"test_robustness\.py::(test_the_compiled_loop_gives_each_agent|test_randomised_physics_is_"
    r"the_same_on_every_path)[^\[]*\[mujoco": "runs the loops on MuJoCo (the analytic plant stays)",
    r"test_parameters\.py::test_the_run_paths_give_one_set_of_numbers_at_other_values"
    r"|test_run\.py::test_mujoco_dm_env_and_compiled_paths_agree": "runs every path",
    # Checks over every task or plant: the cheapest cases stay.
    rf"test_viz\.py::\w+\[({OTHER_TASKS}\.\w+|cartpole\.balance)-(mujoco|analytic)\]"
    rf"(?<!cartpole\.balance-mujoco\])"
    rf"|test_batched\.py::test_batched_equals_single_environments\[(?!mountain_car)"
    rf"|test_viz\.py::test_q_on_grid_equals_the_feature_maps\[\w+-(?!mountain_car)"
    rf"|test_gymnasium_envs\.py::test_trajectories_equal_the_dm_env\[(?!mountain_car)"
    rf"|test_gymnasium_vector\.py::test_make_vec_gives_the_batched_vector_environment"
    rf"\[lwrl/(?!mountain_car)"
    rf"|test_claims\.py::test_a_command_aimed_at_a_claimed_output_stops_at_once\[(?!0\])"
    rf"|test_nrbf\.py::test_factorised_equals_direct_evaluation\[[^\]]*-4-6\]"
    rf"|test_suite\.py::test_deterministic_for_a_seed\[{OTHER_TASKS}"
    rf"|test_compare\.py::\w+\[{OTHER_TASKS}"
    rf"|{CONTRACT}\[[^-]+-{OTHER_TASKS}"
    rf"|test_run\.py::\w+\[{OTHER_TASKS}"
    rf"|test_gymnasium_envs\.py::test_same_seed_same_trajectory\[lwrl/(?!mountain_car)"
    rf"|test_disturbances\.py::test_a_batch_is_its_single_environments_with_every_option"
    rf"\[(?!mountain_car)"
    rf"|test_parameters\.py::test_a_batch_spans_a_grid_of_values\[(?!mountain_car)"
    rf"|test_parameters\.py::test_the_plants_agree_away_from_the_papers_values\[\w+-200-":
        "the same check on the other cases (or over longer runs)",
    # Many generated cases (Hypothesis), each a command or a batch.
    r"test_bad_input\.py::"
    r"|test_disturbances\.py::test_bad_options_are_one_line"
    r"|test_parameters\.py::test_bad_parameter_values_are_one_line":
        "Hypothesis: a command or a batch for each of many generated inputs",
}
SLOW_TESTS = re.compile("|".join(f"(?:{pattern})" for pattern in SLOW))


def pytest_collection_modifyitems(config, items):
    """Mark `slow` the tests that SLOW names, and run each learner's checks on a task one
    after the other (`_by_case`)."""
    root = config.rootpath / "tests"
    for item in items:
        if SLOW_TESTS.match(item.path.relative_to(root).as_posix() + "::" + item.name):
            item.add_marker(pytest.mark.slow)
    items[:] = _by_case(items)


def _by_case(items) -> list:
    """`items` with the tests of a file parametrized by one `learner` and `task` moved next to
    the first of that case, in their order (tests/test_learners.py: every check of one learner
    on one task in a row, not one check over every case then the next), so that its checks
    share the JAX programs the first compiles (the same run, `testing.contract_config`):
    run check by check, a worker compiled each case's programs again in each check, after
    `_release_compiled_programs` had let the first ones go. Files stay whole and in order."""
    first = {}

    def case(index, item) -> int:
        params = getattr(getattr(item, "callspec", None), "params", {})
        if "learner" in params and "task" in params:
            return first.setdefault((item.path, params["learner"], params["task"]), index)
        return index

    return [item for _, item in sorted(enumerate(items), key=lambda pair: (case(*pair), pair[0]))]


COMPILES = 0.3
"""Seconds under which a test compiled no population program (each takes seconds): the
mappings of its small programs, if any, are counted after the next longer test."""


@pytest.fixture(autouse=True)
def _release_compiled_programs():
    """After each test, JAX's compiled programs released where this process holds more than
    half the memory mappings it may (`runners.mappings`): a worker that compiles hundreds of
    programs (tests/test_learners.py over every JAX learner and task) passed Linux's limit,
    where XLA's next compilation died with a segmentation fault. Releasing them costs a
    compilation where a later test needs the same program again, and changes no number. The
    mappings (milliseconds to count) are counted after the tests that took `COMPILES` or
    more."""
    started = time.perf_counter()
    yield
    if "jax" in sys.modules and time.perf_counter() - started > COMPILES:
        from lwrl.runners.population import release_when_crowded
        release_when_crowded()
