"""`lwrl tasks`: the suite's tasks and their plants."""

from lwrl import tasks


def add_parser(commands) -> None:
    listing = commands.add_parser("tasks", help="list the suite's tasks and their plants")
    listing.set_defaults(run=run)


def run(args) -> None:
    """Print every task with its plants, the default first, the batched-only marked."""
    del args
    width = max(map(len, tasks.TASK_NAMES)) + 2
    for domain, task in tasks.ALL_TASKS:
        plants = [plant if plant in tasks.ENVIRONMENT_PLANTS[domain] else f"{plant} (batched only)"
                  for plant in tasks.PLANTS[domain]]
        print(f"{f'{domain}.{task}':<{width}}plants: {', '.join(plants)}")
