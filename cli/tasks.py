"""`lwrl tasks`: the suite's tasks and their plants, or (`--parameters`) each domain's
physical parameters as the tasks page's tables (docs/guide/tasks.md)."""

from lwrl import tasks


def add_parser(commands) -> None:
    listing = commands.add_parser("tasks", help="list the suite's tasks and their plants")
    listing.add_argument("--parameters", action="store_true",
                         help="print each domain's physical parameters (name, symbol, unit, the "
                              "paper's value, the accepted range) as Markdown tables")
    listing.set_defaults(run=run)


def run(args) -> None:
    """Print every task with its plants, the default first, the batched-only marked; or
    every domain's parameters."""
    if args.parameters:
        print(parameter_tables())
        return
    width = max(map(len, tasks.TASK_NAMES)) + 2
    for domain, task in tasks.ALL_TASKS:
        plants = [plant if plant in tasks.ENVIRONMENT_PLANTS[domain] else f"{plant} (batched only)"
                  for plant in tasks.PLANTS[domain]]
        print(f"{f'{domain}.{task}':<{width}}plants: {', '.join(plants)}")


def parameter_tables() -> str:
    """Each domain's parameters (`Domain.parameters`) as a Markdown table under its name."""
    return "\n\n".join(f"`{name}`\n\n{domain.parameters.table()}" for name, domain in tasks.DOMAINS.items())
