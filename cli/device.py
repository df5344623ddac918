"""`lwrl device`: the C learner learning on an emulated Cortex-M4 (QEMU), and its cost.

    lwrl device run DOMAIN.TASK [--episodes K] [--seed S] [--real R] [--learner L]
    lwrl device costs DOMAIN.TASK... [--learner L] [--controller] [--action-kind K] [--real R]
                      [--mhz F]
    lwrl device hil DOMAIN.TASK [--plant P] [--episodes K] [--seed S] [--env-seed E]
                    [--learner L] [--emulated | --port PORT [--baud B]] [--realtime] [--real R]
                    [--time-limit SECONDS] [--timeout T] [--link-timeout W]
                    [--link-misses M] [--out DIR] [--save PATH]
                    [--rrd PATH [--log-episodes WHICH]] [--force]

`hil` puts the learner in the loop over the device link (docs/guide/device-link.md): the host
steps the task's plant (MuJoCo's where the task has it), the C learner (the task's, or
`--learner`'s: one with a C learner) acts, built for this machine, (`--emulated`) on the
emulated Cortex-M4 with its UART as the link, or (`--port`) on a board behind a serial port
that runs the device program; `--realtime` paces the plant at its control period. A session
opens with a handshake that refuses another program in one line, and ends, with the episodes
that finished written and exit status 1, when the device has sent no valid frame for
`--link-timeout` seconds and `--link-misses` deadlines in a row have passed. It prints each
episode and what the link carried, and writes what `lwrl train` writes: `--out` config.json
and episodes.csv (and session.json: whether the session ran whole, and what the link did),
`--save` the device's weights (fetched by frames; they load in `lwrl eval`), `--rrd` a
recording.

`run` builds the task's learner with its plant in C for the host and for a bare-metal
Cortex-M4, runs both (the M4 under qemu-system-arm, mps2-an386) and prints the steps per
episode of each side by side; `costs` measures bytes and instructions per learning step and
per decision (export/device.py), or for a learner without a C learner (`--learner`:
Stream AC(lambda), ARS with continuous actions), or with `--controller`, its greedy
controller's bytes and instructions per decision, beside its counted arithmetic and the
memory its learning needs. Needs gcc-arm-none-eabi, libnewlib-arm-none-eabi, qemu-system-arm
and, for `costs`, valgrind.
"""

import sys
import time

import numpy as np

from lwrl import agent as learners
from lwrl import outputs
from lwrl.cli import fields, output
from lwrl.export import device, frames
from lwrl.tasks.task_definition import ACTIONS

BOARD_RAM = 192 * 1024
"""The STM32F405's SRAM (128 KB and 64 KB of core-coupled memory; ST's datasheet DS8626),
the board whose 168 MHz clock the time estimates take: what a learner must fit on a real
Cortex-M4 (the emulated mps2-an386 has 4 MB)."""


def add_parser(commands) -> None:
    parser = commands.add_parser("device", help="learn on an emulated Cortex-M4; measure the cost",
                                 description=__doc__.split("\n\n")[0])
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    run = actions.add_parser("run", help="the learner learns a task on the emulated M4 and the host")
    run.add_argument("task", metavar="DOMAIN.TASK")
    run.add_argument("--episodes", type=fields.positive_int, default=40)
    run.add_argument("--seed", type=fields.non_negative_int, default=0, help="the agent's seed")
    run.add_argument("--real", choices=("float", "double"), default="float")
    run.add_argument("--learner", choices=learners.LEARNER_NAMES, default=None,
                     help="a new agent of this learner with its defaults (default: the task's); "
                          "it must have a C learner (Sarsa(lambda) over NRBF features, ARS, "
                          "Stream Q(lambda))")
    run.set_defaults(run=run_device)
    costs = actions.add_parser("costs", help="bytes and instructions of the tasks' learners, or "
                                             "of a learner's greedy controller")
    costs.add_argument("tasks", metavar="DOMAIN.TASK", nargs="+")
    costs.add_argument("--learner", choices=learners.LEARNER_NAMES, default=None,
                       help="a new agent of this learner with its defaults (default: the "
                            "task's); one without a C learner is measured as its exported "
                            "greedy controller (lwrl export)")
    costs.add_argument("--action-kind", choices=ACTIONS, default=None,
                       help="the tasks' kind of action (default: the task's)")
    costs.add_argument("--train", type=fields.positive_int, default=200_000, metavar="STEPS",
                       help="environment steps a controller's agent learns before it is "
                            "measured, so that its normalisation is not the identity the "
                            "compiler folds away (default 200000)")
    costs.add_argument("--controller", action="store_true",
                       help="measure the greedy controller (lwrl export) of a learner that "
                            "has a C learner too, rather than the C learner")
    costs.add_argument("--real", choices=("float", "double"), default="float")
    costs.add_argument("--mhz", type=fields.finite_number, default=168.0,
                       help="clock of the time estimate (default 168, the STM32F405's)")
    costs.set_defaults(run=measure_costs)
    hil = actions.add_parser("hil", help="the learner in the loop over the device link, the "
                                         "host stepping the plant")
    hil.add_argument("task", metavar="DOMAIN.TASK")
    hil.add_argument("--plant", help="the plant the host steps (default: the domain's first, "
                                     "MuJoCo where the task has it)")
    hil.add_argument("--episodes", type=fields.positive_int, default=5)
    hil.add_argument("--seed", type=fields.non_negative_int, default=0, help="the agent's seed")
    hil.add_argument("--env-seed", type=fields.non_negative_int, default=0,
                     help="the plant's seed (its episodes' starts)")
    hil.add_argument("--learner", choices=learners.LEARNER_NAMES, default=None,
                     help="a new agent of this learner with its defaults (default: the task's); "
                          "it must have a C learner, as for run")
    hil.add_argument("--emulated", action="store_true",
                     help="the learner on the emulated Cortex-M4 (QEMU's mps2-an386, its UART "
                          "the link) rather than built for this machine")
    hil.add_argument("--real", choices=("float", "double"), default=None,
                     help="the learner's arithmetic (default: float on the emulated board, "
                          "double on this machine)")
    hil.add_argument("--time-limit", type=fields.finite_number, default=None, metavar="SECONDS",
                     help="episodes cut at this many seconds of the plant (default: the task's)")
    hil.add_argument("--timeout", type=fields.finite_number, default=1.0,
                     help="seconds an answer may take before the step is a missed deadline "
                          "(default 1; with --realtime, the control period)")
    hil.add_argument("--link-timeout", type=fields.finite_number, default=5.0, metavar="W",
                     help="end the session when the device has sent no valid frame for W "
                          "seconds and --link-misses deadlines in a row have passed (default 5)")
    hil.add_argument("--link-misses", type=fields.positive_int, default=3, metavar="M",
                     help="missed deadlines in a row the watchdog also waits for (default 3)")
    hil.add_argument("--realtime", action="store_true",
                     help="pace the plant at the task's control period; an answer that comes "
                          "later is a missed deadline, the previous action held")
    hil.add_argument("--port", help="the serial port of a board running the device program "
                                    "(needs pyserial: the serial extra)")
    hil.add_argument("--baud", type=fields.positive_int, default=115_200,
                     help="the port's baud rate (default 115200)")
    files = hil.add_argument_group("outputs")
    files.add_argument("--out", metavar="DIR", help="write config.json, episodes.csv and "
                                                    "session.json here")
    files.add_argument("--save", metavar="PATH", help="save the device's weights as an agent (.npz)")
    files.add_argument("--rrd", metavar="PATH", help="save episodes to a Rerun recording")
    files.add_argument("--log-episodes", default="every:20", metavar="WHICH",
                       help="episodes to record: every:K, last, all or numbers like 1,5,20 "
                            "(default every:20)")
    files.add_argument("--force", action="store_true", help="replace existing outputs")
    hil.set_defaults(run=run_hil)


def run_device(args) -> int:
    started = time.perf_counter()
    settings = {"learner": args.learner} if args.learner else {}
    result = device.run_device(args.task, args.episodes, args.seed, args.real, **settings)
    print(f"{args.task}: {result['summary']}, {args.real}, seed {args.seed}; host build and "
          f"emulated Cortex-M4 ({device.BOARD})")
    print("episode   host  device")
    for k, (host, emulated) in enumerate(zip(result["host"]["steps"], result["device"]["steps"]), 1):
        print(f"{k:>7} {host:>6} {emulated:>7}{'' if host == emulated else '   differ'}")
    steps = sum(result["device"]["steps"])
    print(f"steps per episode {'equal' if result['equal_steps'] else 'NOT equal'} on both; final "
          f"weights within {result['weight_ulps']} units in the last place of each other")
    sizes = result["sizes"]
    print(f"firmware: {sizes['text'] + sizes['data']} bytes of flash, {sizes['data'] + sizes['bss']} "
          f"of static RAM (arm-none-eabi-size); {result['instructions']} instructions emulated, "
          f"{result['instructions'] / steps:.0f} per step with the plant's software-double cos")
    output.done(started)
    return 0 if result["equal_steps"] else 1


def measure_costs(args) -> int:
    started = time.perf_counter()
    settings = {name: value for name, value in (("learner", args.learner),
                                                ("actions", args.action_kind)) if value}
    in_c = [task for task in args.tasks
            if not args.controller and device.learns_in_c(task, **settings)]
    if in_c:
        learning_costs(in_c, args, settings)
    controllers = [task for task in args.tasks if task not in in_c]
    if controllers:
        controller_costs(controllers, args, settings)
    output.done(started)
    return 0


def learning_costs(names, args, settings) -> None:
    """The table of the learners that learn in C, one row per task."""
    print(f"per task: RAM computed; code: the learner object for the Cortex-M4 (-O2, {args.real}); "
          f"flash: the whole bench firmware with libm and start-up; "
          f"instructions per call, host x86-64 (callgrind) and emulated M4 (QEMU plugin); "
          f"time an estimate at {args.mhz:g} MHz and one instruction per cycle; counted "
          f"multiply-adds/transcendentals per decision and per learning step (Learner.arithmetic)")
    print(f"{'task':<26} {'RAM B':>6} {'code B':>6} {'flash B':>7} {'stack B':>7} "
          f"{'learn x86':>9} {'learn M4':>8} {'decide x86':>10} {'decide M4':>9} {'learn us':>8}"
          f" {'counted decision':>16} {'counted step':>14}  learner")
    for task in names:
        result = device.costs(task, args.real, **settings)
        print(f"{task:<26} "
              f"{result['ram']['total']:>6} {result['object']['text']:>6} "
              f"{result['firmware']['text'] + result['firmware']['data']:>7} {result['stack']:>7} "
              f"{result['host_learn']:>9.0f} {result['m4_learn']:>8.0f} {result['host_decide']:>10.0f} "
              f"{result['m4_decide']:>9.0f} {device.estimate_us(result['m4_learn'], args.mhz):>8.1f}"
              f" {counted(result['counts'].decision):>16} {counted(result['counts'].step):>14}"
              f"  {result['summary']}")


def controller_costs(names, args, settings) -> None:
    """The table of the learners without a C learner: a new agent's greedy controller,
    measured, and the learner's counted arithmetic and memory, one row per task."""
    print(f"per task, the greedy controller (lwrl export, {args.real}) of an agent after "
          f"{args.train} steps of learning: code+const: the "
          f"controller object for the Cortex-M4 (-O2: code, weights, constants); flash: the whole "
          f"bench firmware; stack: its only RAM; instructions per decision, host x86-64 "
          f"(callgrind) and emulated M4 (QEMU plugin); time an estimate at {args.mhz:g} MHz; "
          f"counted multiply-adds/transcendentals per decision and per learning step "
          f"(Learner.arithmetic); the learner's memory (Learner.memory) against the "
          f"{BOARD_RAM // 1024} KB of an STM32F405's RAM")
    print(f"{'task':<26} {'code+const B':>12} {'flash B':>7} {'stack B':>7} {'decide x86':>10} "
          f"{'decide M4':>9} {'decide us':>9} {'counted decision':>16} {'counted step':>14} "
          f"{'memory B':>9}  learner")
    for task in names:
        result = device.new_policy_costs(task, args.real, args.train, **settings)
        decision, step = result["counts"].decision, result["counts"].step
        fits = "fits" if result["memory"] <= BOARD_RAM else "does not fit"
        print(f"{task:<26} {result['object']['text'] + result['object']['data']:>12} "
              f"{result['firmware']['text'] + result['firmware']['data']:>7} {result['stack']:>7} "
              f"{result['host_decide']:>10.0f} {result['m4_decide']:>9.0f} "
              f"{device.estimate_us(result['m4_decide'], args.mhz):>9.2f} "
              f"{counted(decision):>16} {counted(step):>14} {result['memory']:>9} ({fits})  {result['learner'].name}: {result['counts'].source}")


def counted(count) -> str:
    """A `Count` as `multiply-adds/transcendentals`, a share of an update's to one decimal."""
    def number(value):
        return f"{value:.0f}" if float(value).is_integer() else f"{value:.1f}"
    return f"{number(count.macs)}/{number(count.exps)}"


BITS_PER_BYTE = 10
"""A serial byte on the wire: 8N1, a start bit, 8 data bits and a stop bit."""


def needed_baud(expected, period: float) -> float:
    """The baud rate the link needs for one observation and its answer per control period
    `period` (seconds) to the device program of identity `expected` (`frames.step_bytes`:
    its observed variables, its kind of action)."""
    continuous = expected.action_kind == frames.CONTINUOUS
    return BITS_PER_BYTE * frames.step_bytes(expected.observations, continuous) / period


def open_port(args, definition, expected):
    """The serial port `--port` at `--baud`, opened for this command alone; one line if it
    cannot be, or cannot carry the frames of the device program of identity `expected`."""
    needed = needed_baud(expected, definition.control_timestep)
    if args.baud < needed:
        raise ValueError(f"--baud {args.baud} cannot carry {definition.name}'s frames at one step "
                         f"per {definition.control_timestep * 1000:g} ms: they need at least "
                         f"{needed:,.0f} baud")
    try:
        import serial
    except ImportError:
        raise ValueError("--port needs pyserial: pip install 'lwrl[serial]'") from None
    try:
        return serial.Serial(args.port, args.baud, timeout=args.timeout, exclusive=True)
    except (serial.SerialException, OSError) as error:
        raise ValueError(f"--port {args.port}: cannot open it ({error})") from None


def run_hil(args) -> int:
    import subprocess
    import tempfile

    from lwrl import tasks
    from lwrl.cli import rerun_options
    from lwrl.cli.train import check_outputs
    from lwrl.export import hil
    from lwrl.export.link import HostLink, PipePort

    started = time.perf_counter()
    domain, name = tasks.split_name(args.task)
    definition, plant, _ = tasks.resolve(domain, name, args.plant)
    for flag, value in (("--timeout", args.timeout), ("--link-timeout", args.link_timeout)):
        if not value > 0:
            raise ValueError(f"{flag} must be a positive number of seconds; got {value:g}")
    if args.port and args.emulated:
        raise ValueError("--port and --emulated name two devices; give one")
    record = []
    if args.rrd:
        logged = rerun_options.episodes_to_log(args.log_episodes, args.episodes)
        if logged == "best":
            raise ValueError("--log-episodes best needs the run again; the device learns once: "
                             "give every:K, last, all or numbers")
        record = [(0, episode) for episode in logged]
    check_outputs(args)
    args.real = args.real or ("float" if args.emulated or args.port else "double")
    options = {} if args.time_limit is None else {"time_limit": args.time_limit}
    name = (f"the board at {args.port} ({args.baud} baud)" if args.port
            else "the emulated board" if args.emulated else "the device program")
    with tempfile.TemporaryDirectory() as build:
        chosen = hil.learner_setting(args.learner)
        if args.port:
            expected = hil.identity(args.task, args.seed, args.real, **chosen)
            port, device_process = open_port(args, definition, expected), None
        else:
            command = (hil.build_emulated_program(args.task, build, seed=args.seed,
                                                  dtype=args.real, count=True, **chosen)
                       if args.emulated else
                       hil.build_host_program(args.task, build, seed=args.seed, dtype=args.real,
                                              **chosen))
            device_process = subprocess.Popen(command, stdin=subprocess.PIPE,
                                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
            port = PipePort(device_process)
        try:
            link = HostLink(port, args.timeout, args.link_timeout, args.link_misses, name)
            results, device_agent, twin = hil.run_session(
                link, args.task, args.episodes, seed=args.seed, plant=plant,
                env_seed=args.env_seed, realtime=args.realtime, record=record,
                dtype=args.real, learner=args.learner, **options)
            instructions = (hil.counted_instructions(device_process, build) if args.emulated
                            else None)
        finally:
            if device_process is None:
                port.close()
            else:
                device_process.kill()
                device_process.wait()
    config = hil.session_config(args.task, args.seed, plant, args.learner, **options)
    where = (f"on the emulated Cortex-M4 ({device.BOARD}, its UART the link)" if args.emulated
             else f"on the board at {args.port} ({args.baud} baud)" if args.port
             else "built for this machine")
    print(f"{args.task} on the {plant} plant (seed {args.env_seed}): the C learner ({args.real}, "
          f"agent seed {args.seed}) {where}, acting over the device link"
          f"{', in real time' if args.realtime else ''}")
    output.print_results(results, config.seeds, "", definition.has_uptime)
    print(link_report(link.counts, device_agent, definition))
    if instructions is not None:
        per_step = instructions / max(link.counts.exchanges, 1)
        print(f"device: {per_step:,.0f} instructions a step (its waits for the link's bytes left "
              f"out, the weights' frames in), {device.estimate_us(per_step, 168.0):,.0f} us at "
              "168 MHz and one instruction a cycle (an estimate)")
    written = output.Outputs("device hil")
    if args.rrd:
        def record_run():
            with outputs.atomic_path(args.rrd) as temporary:
                rerun_options.send_run(config, results, twin, rrd_path=temporary)
            return [f"the recording {args.rrd} ({len(results.recordings)} episodes)"]
        written.write(f"--rrd {args.rrd}", record_run)
    finished = int(np.isfinite(results.steps).sum())
    ended = link.lost or ("interrupted" if results.interrupted else "every episode ran")
    session = {"complete": not results.interrupted, "episodes_finished": finished, "ended": ended,
               "link": {field: value for field, value in vars(link.counts).items()
                        if field != "round_trips"}}
    output.write_out_and_save(written, args, config, results, twin,
                              "the device's weights as an agent", {"session": session})
    output.done(started, written.written, results.interrupted)
    status = written.report()
    if link.lost is None:
        return 130 if results.interrupted else status
    print(f"lwrl {args.command}: error: {link.lost}; the session was cut short: "
          f"{finished} of {args.episodes} episodes finished, the one under way left out",
          file=sys.stderr)
    return 1


def link_report(counts, device_agent, definition) -> str:
    """What the link carried and how fast, in a few lines."""
    trips = np.array(counts.round_trips or [np.nan]) * 1e6
    per_step = (counts.bytes_sent + counts.bytes_received) / max(counts.exchanges, 1)
    period = definition.control_timestep
    lines = [f"link: {counts.exchanges} exchanges, {counts.missed} missed deadlines (the action "
             f"held), {counts.late} late and {counts.duplicates} duplicated answers; round trip "
             f"median {np.median(trips):.0f} us, 99th percentile {np.percentile(trips, 99):.0f} us, "
             f"largest {np.max(trips):.0f} us",
             f"{per_step:.0f} bytes a step, {BITS_PER_BYTE * per_step / period:,.0f} baud at one "
             f"step per {period * 1000:g} ms (8N1: 10 bits a byte); {counts.bytes_fetched} bytes "
             f"fetching the weights at the episodes' ends, {counts.bytes_handshake} the handshake"]
    if device_agent.period is not None:
        lines.append(f"real time: {device_agent.overruns} periods the host overran")
    return "\n".join(lines)
