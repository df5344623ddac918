"""`lwrl export`: a saved agent as a dependency-free C99 controller."""

import time

from lwrl import outputs
from lwrl.cli import fields, output
from lwrl.export import c as export_c


def add_parser(commands) -> None:
    export = commands.add_parser("export", help="write a saved agent as a C99 controller")
    export.add_argument("path", metavar="PATH", help="a file written by lwrl train --save")
    export.add_argument("--c", metavar="OUT_DIR", required=True,
                        help="directory for lwrl_policy.c and lwrl_policy.h")
    export.add_argument("--agent", type=fields.non_negative_int, default=0,
                        help="which agent of the saved batch (default 0)")
    export.add_argument("--real", choices=tuple(export_c.DTYPES), default="float",
                        help="C floating-point type of the weights and arithmetic")
    export.add_argument("--force", action="store_true",
                        help="replace lwrl_policy.c and lwrl_policy.h already in OUT_DIR")
    export.set_defaults(run=export_agent)


def export_agent(args) -> int:
    """Write a saved agent as C99 source and header; report its flash size and speed."""
    output.claim_outputs(args, "c")
    outputs.check_directory(args.c, "--c", args.force, names=(export_c.SOURCE, export_c.HEADER))
    started = time.perf_counter()
    written = export_c.export_c(args.path, args.c, agent_index=args.agent, dtype=args.real)
    print(f"agent {args.agent} of {args.path} ({written['task']}): {written['weight_bytes']} "
          f"bytes of weights and {written['constant_bytes']} of constants")
    try:
        measured = export_c.measure(args.c)
    except ValueError as error:
        print(f"not measured: {error}")
    else:
        print(f"compiled with {measured['compiler']}: {measured['code_bytes']} bytes of code "
              f"(-Os), {measured['rodata_bytes']} of read-only data; "
              f"{measured['ns_per_decision']:.0f} ns per decision (-O2, this machine)")
    output.done(started, [written["source"], written["header"]])
    return 0
