"""The `lwrl` command line.

    lwrl tasks                                     list the suite's tasks and plants
    lwrl rollout DOMAIN.TASK [--plant P] [--steps N] [--seed S]
                                                   run a uniformly random policy
    lwrl train DOMAIN.TASK [--trace T] [--alpha A] [--lambda L] [--episodes K] ...
                                                   train NRBF Sarsa(lambda) agents
    lwrl train dmc:DOMAIN.TASK|gym:ID [--low L,L,..] [--high H,H,..] [--actions V,V,...] ...
                                                   ... on dm_control's or Gymnasium's
    lwrl eval PATH [--episodes K] [--seed S]       run saved agents greedily
    lwrl plot RUN_DIR... [--measure M] [--out PNG] learning curves with 95 % intervals
    lwrl reproduce {fig2,fig3,fig5,fig6,fig8,table1,all}... [--plant P] [--quick] [--out DIR]
                                                   the paper's figures and table, and a report
    lwrl compare DOMAIN.TASK [--seeds N] [--episodes K] [--out DIR] [--rrd PATH] [--quick]
                                                   the analytic and MuJoCo plants compared
    lwrl bench run TASK... | status TASK... | report DIR | score RESULTS...
                                                   the light-weight claim's benchmark
    lwrl robustness DOMAIN.TASK... [--agents N] [--episodes K] [--out DIR] [--quick]
                                                   trained controllers away from the paper's plant
    lwrl export PATH --c OUT_DIR [--agent I]       a saved agent as a C99 controller
    lwrl learner DOMAIN.TASK|PATH --c OUT_DIR [--real R] [--ram BYTES] ...
                                                   the learner itself as C99
    lwrl device run DOMAIN.TASK | costs DOMAIN.TASK...
                                                   learn on an emulated Cortex-M4; the cost
    lwrl view PATH [--web] [--screenshot PNG]      open a Rerun recording of lwrl train --rrd,
                                                   serve it to a browser, or render it

Each subcommand is a module of `lwrl.cli` with `add_parser(commands)`, which sets the
function the command runs. Bad input ends with one line on standard error and exit status 2.
"""

import sys

from lwrl import outputs
from lwrl.cli import (bench, compare, device, evaluate, export, implementations, learner, plot,
                      reproduce, robustness, rollout, tasks, train, view)
from lwrl.cli import output
from lwrl.cli.output import Parser

SUBCOMMANDS = (tasks, rollout, train, evaluate, plot, reproduce, bench, implementations,
               compare, robustness, export, learner, device, view)


def build_parser() -> Parser:
    parser = Parser(prog="lwrl", description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                     parser_class=Parser)
    for module in SUBCOMMANDS:
        module.add_parser(commands)
    return parser


def main(argv=None) -> int:
    """Run one command: 0 when it succeeded, 2 for bad input (one line on standard error),
    1 when an output could not be written after the work, 130 when interrupted (143 when
    stopped by SIGTERM)."""
    parser = build_parser()
    given = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(given)
    args.argv = given  # the command as it was given
    output.INTERRUPTS = output.Interrupts(args.command)
    with output.INTERRUPTS:
        try:
            return output.INTERRUPTS.status(args.run(args) or 0)
        except ValueError as error:
            print(f"lwrl {args.command}: error: {error}", file=sys.stderr)
            return 2
        except OSError as error:  # an output that failed after the work
            print(f"lwrl {args.command}: error: {error}", file=sys.stderr)
            return 1
        except MemoryError:
            print(f"lwrl {args.command}: error: out of memory: use fewer agents or episodes",
                  file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print(f"lwrl {args.command}: interrupted", file=sys.stderr)
            return output.INTERRUPTS.status(130)
        finally:
            outputs.release_claims()  # the command's outputs are in place, or will not be


if __name__ == "__main__":
    sys.exit(main())
