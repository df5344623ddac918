"""`lwrl reproduce`: run the paper's items, then write their results, figures and report.

Layout of the output directory:

    runs/<key>.csv.gz        one finished run (written as runs finish; reused on resume)
    <item>/results.csv.gz    the item's tidy table: one row per agent-run and episode,
                             with every configuration field
    <item>/configs.jsonl     every run's full configuration
    <item>/confirmation.csv.gz, confirmation-configs.jsonl
                             the confirmation runs (`agents_per_cell`), likewise
    figures/<item>.png/.svg  the paper's figures, redrawn
    report.md                our numbers beside the paper's, item by item
"""

import dataclasses
import datetime
import json
import os
import time

from lwrl import outputs, tasks
from lwrl.analysis.plots import plot_claims, save_figure
from lwrl.runners import sweep
from lwrl.runners.config import PLANT_OPTIONS, EnvironmentSettings
from lwrl.settings import applies as applies_to
from lwrl.studies.paper.items import ITEMS

READINGS = [
    "Centroids at cell midpoints (i + 0.5)/n, the same r² in every task (SPEC.md, Agent).",
    "Mountain-Car: ε = 0; random starts; no episode cap in the protocol, a 10 000-step "
    "safety cap reported as truncations.",
    "Pendulum: ε = 0.1, 10 agents × 200 episodes; the angle's features are not wrapped; "
    "NRBF ranges θ ∈ [−π, π], θ̇ ∈ [−1.5, 1.5].",
    "Cart-Pole: ε = 0.1, 10 agents × 200 episodes; NRBF ranges x ∈ [−2.4, 2.4], "
    "ẋ ∈ [−1.5, 1.5], θ ∈ [−12°, 12°], θ̇ ∈ [−150°/s, 150°/s]; failure also at |x| > 2.4 m.",
    "CMAC baseline (Fig. 2): 5 tilings of 9 × 9 tiles, α from 0.1 to 1.0 divided by the "
    "tilings, replacing traces with resetting (eq. 5) and accumulating traces.",
    "Best α: the α with the best mean over the first half of its agents (seeds); an α at "
    "which one of them diverged is excluded. The chosen α is judged on the second half.",
]

INTERVALS = (
    "Intervals are 95 % percentile bootstrap intervals over agents (`scipy.stats.bootstrap`, "
    "10 000 resamples, seed 0; `lwrl.analysis.statistics`): an agent's episodes stay together, "
    "and a statistic of several runs resamples each run's agents within the run (stratified). "
    "“A better than B” is the probability of improvement of Agarwal et al. (2021): the chance "
    "that an agent of A does better than one of B, ties counting half, over every pair; 0.5 "
    "when neither is ahead. A comparison is decided where its interval excludes 0.5. Where a "
    "best α (or λ) is chosen, it is chosen on the first half of each cell's agents and judged "
    "on the second half, so the choice does not flatter the number it is judged by; a "
    "confirmation run (`--agents-per-cell N`) judges the same chosen cells on N fresh agents "
    "each, and its verdict is the item's. Episode numbers beyond the run read “never”.")


def selected(items) -> list:
    """The items named (a name, `all`, or a list of them), in the paper's order."""
    names = [items] if isinstance(items, str) else list(items)
    for name in names:
        if name != "all" and name not in ITEMS:
            raise ValueError(f"unknown item {name!r}; allowed: {', '.join(ITEMS)}, all")
    return [name for name in ITEMS if name in names or "all" in names]


def reading_fields(configs) -> dict:
    """`{name: field}` of the settings a reading may set (metadata `reading`): the
    environment's and those of the runs' learners."""
    classes = [EnvironmentSettings] + [type(config.settings) for config in configs]
    return {field.name: field for cls in classes for field in dataclasses.fields(cls)
            if field.metadata.get("reading")}


def with_readings(configs, readings: dict) -> list:
    """The runs with `readings` (`{name: value}`) in place of the defaults: the settings
    whose metadata marks them readings of SPEC.md's open points (`reading_fields`) and the
    options of the runs' tasks (e.g. the cart-pole's `track_limit`), each applied to the
    runs that have it: a learner's setting to its runs where it matters (`only_with`: an
    NRBF's spread, not the CMAC baseline's), a plant's option where the run's plant has it.
    A name no run has is an error."""
    used = set()
    configs = list(configs)
    readable = reading_fields(configs)
    for index, config in enumerate(configs):
        options = tasks.task_options(config.domain, config.task_name)
        settings_fields = {field.name: field for field in dataclasses.fields(config.settings)}
        fields, task_options = {}, dict(config.task_options)
        for name, value in readings.items():
            if name in readable and name in PLANT_OPTIONS:
                applies = name in config.plant_options
            elif name in readable:
                applies = name in settings_fields and applies_to(settings_fields[name], config.settings)
            else:
                applies = False
            if applies:
                fields[name] = value
            elif name in options and name not in readable:
                task_options[name] = value
            else:
                continue
            used.add(name)
        configs[index] = dataclasses.replace(config, **fields, task_options=task_options)
    unused = sorted(set(readings) - used)
    if unused and unused[0] in PLANT_OPTIONS:
        raise ValueError(f"no run of these items has the reading {unused[0]!r}: it applies to "
                         "the pendulum and cart-pole on the analytic plant (--plant analytic)")
    if unused:
        raise ValueError(f"no run of these items has the reading {unused[0]!r}; allowed: "
                         f"{', '.join(readable)} and the tasks' options")
    return configs


def with_alphas(configs, alphas) -> list:
    """The runs with the NRBF runs' alpha grid replaced by `alphas`: each distinct NRBF run
    but for alpha, once per alpha, in the order first met (the CMAC baseline's runs, on
    their own scale of alpha, stay as they are)."""
    if not alphas:
        raise ValueError("alphas must name at least one learning rate")
    result, seen = [], set()
    for config in configs:
        variants = ([dataclasses.replace(config, alpha=float(alpha)) for alpha in alphas]
                    if getattr(config.settings, "features", None) == "nrbf" else [config])
        for variant in variants:
            if variant.key_json() not in seen:
                seen.add(variant.key_json())
                result.append(variant)
    return result


def reproduce(item, out_dir: str, plant: str = "analytic", quick: bool = False,
              integrator: str = "semi_implicit", backend: str = "local",
              workers: int | None = None, address: str | None = None,
              readings: dict | None = None, alphas=None,
              agents_per_cell: int | None = None) -> str:
    """Run and analyse `item` (a name, `all`, or a list of names); return the report's path.

    `readings` sets SPEC.md's open points for every run that has them (`with_readings`),
    e.g. `{"r2": 0.05}`: the author's cart-pole script's spread. `alphas` replaces the
    items' alpha grids of the NRBF runs (`with_alphas`). `agents_per_cell` adds a
    confirmation run to the items that take one (`Item.confirm`): that many fresh agents at
    each cell the item's analysis chooses on the first half of the paper-sized run's seeds.
    The wall time of each item is kept
    in `timings.json` from the invocation that computed its runs (a resumed item: only the
    resumed part), so that re-analysing finished runs does not overwrite it.
    """
    if agents_per_cell is not None and agents_per_cell < 2:
        raise ValueError(f"agents per cell must be at least 2 (an interval needs two agents); "
                         f"got {agents_per_cell}")
    plan = {}  # every item's runs, checked before anything is written
    for name in selected(item):
        plan[name] = with_readings(ITEMS[name].configs(plant, quick, integrator), readings or {})
        if alphas is not None:
            plan[name] = with_alphas(plan[name], alphas)
    figure_dir = os.path.join(out_dir, "figures")
    os.makedirs(figure_dir, exist_ok=True)
    timings_path = os.path.join(out_dir, "timings.json")
    timings = json.load(open(timings_path)) if os.path.exists(timings_path) else {}
    sections = {}
    sweep_options = dict(backend=backend, workers=workers, address=address)
    # the items' tables are written while the analyses run; every one is on disk before
    # the report is written, or before an error leaves
    with outputs.BackgroundWriter("lwrl-tables") as tables:
        for name, configs in plan.items():
            item_dir = os.path.join(out_dir, name)
            results = run_and_keep(configs, name, out_dir, item_dir, "", timings, tables,
                                   **sweep_options)
            confirmation, confirming = None, ITEMS[name].confirm
            if agents_per_cell and confirming is not None:
                extra = confirming(configs, results, agents_per_cell)
                confirmation = run_and_keep(extra, f"{name} confirmation", out_dir, item_dir,
                                            "confirmation", timings, tables, **sweep_options)
            sections[name] = (ITEMS[name].analyse(results, figure_dir, confirmation),
                              len(configs), len(results),
                              None if confirmation is None else len(extra))
    evidence = [item for section, *_ in sections.values() for item in section.evidence]
    claims = None if quick or not evidence else save_figure(
        plot_claims(evidence, f"The paper's claims against our 95 % intervals ({plant} plant)"),
        figure_dir, "claims")[0]
    path = os.path.join(out_dir, "report.md")
    with outputs.atomic_write(path) as file:
        file.write(report(sections, timings, plant, integrator, quick, out_dir, readings or {},
                          alphas, claims))
    return path


def run_and_keep(configs, key: str, out_dir: str, item_dir: str, kind: str, timings: dict,
                 tables: outputs.BackgroundWriter, **sweep_options):
    """Run `configs` (`runners.sweep`, resuming from `out_dir/runs`) and return their tidy
    table, written whole to `item_dir` as `results.csv.gz` and `configs.jsonl` (`kind`
    empty) or `<kind>.csv.gz` and `<kind>-configs.jsonl` by the writer `tables`. The wall
    time goes into `timings` (and
    `out_dir/timings.json`) under `key` when this invocation computed runs or none is kept
    yet."""
    start = time.perf_counter()
    results, computed = sweep.run_sweep(configs, out_dir, description=key, **sweep_options)
    if computed or key not in timings:
        timings[key] = {"seconds": time.perf_counter() - start, "runs_computed": computed,
                        "runs": len(configs)}
    with outputs.atomic_write(os.path.join(out_dir, "timings.json")) as file:
        json.dump(timings, file, indent=2)
    os.makedirs(item_dir, exist_ok=True)
    tables.submit(keep_table, results, configs, item_dir, kind)
    return results


def keep_table(results, configs, item_dir: str, kind: str) -> None:
    """Write a sweep's tidy table and configurations into `item_dir` (`run_and_keep`)."""
    table = f"{kind}.csv.gz" if kind else "results.csv.gz"
    outputs.write_table(results, os.path.join(item_dir, table))
    sweep.write_configs(configs, os.path.join(item_dir, f"{kind}-configs.jsonl" if kind
                                              else "configs.jsonl"))


def describe_readings(readings: dict) -> str:
    """`readings` for the report's header (the defaults: SPEC.md's readings, listed below)."""
    if not readings:
        return "every open point at its default reading (below)"
    return "readings departing from the defaults: " + ", ".join(
        f"{name} = {value}" for name, value in readings.items())


def describe_alphas(alphas) -> str:
    """The alpha grid for the report's header, where one replaced the items' own."""
    return "" if alphas is None else "; NRBF α grid " + ", ".join(f"{a:g}" for a in alphas)


NO_VERDICT = "— (a smoke run's tiny grids give no verdict)"


def verdict(section, quick: bool) -> str:
    """The item's verdict, or none for a `--quick` smoke run."""
    return NO_VERDICT if quick else section.verdict


def report(sections: dict, timings: dict, plant: str, integrator: str, quick: bool,
           out_dir: str, readings: dict, alphas=None, claims: str | None = None) -> str:
    """The Markdown report: a headline table, then each item's claim, the quantity it is
    judged on and our numbers beside the paper's (and the confirmation run's, if any)."""
    confirming = any(confirmed is not None for _, _, _, confirmed in sections.values())
    lines = [f"# Reproduction of Främling (2008){' — quick smoke run' if quick else ''}", "",
             f"Plant: **{plant}** (Mountain-Car always analytic); Euler scheme: {integrator}; "
             f"{describe_readings(readings)}{describe_alphas(alphas)}. "
             f"Written {datetime.date.today().isoformat()}. Wall time: "
             "of the invocation that computed the item's runs, on this machine (an item that "
             "shares another's runs, like Table 1, or resumed an interrupted run shows less).",
             "", INTERVALS, ""]
    if confirming:
        lines += ["| item | reproduces? | the paper-sized run alone | runs | rows | wall time (s) "
                  "| confirmation runs | their wall time (s) |", "|---|---|---|---|---|---|---|---|"]
    else:
        lines += ["| item | reproduces? | runs | rows | wall time (s) |", "|---|---|---|---|---|"]
    for name, (section, runs, rows, confirmed) in sections.items():
        if confirming:
            extra = timings.get(f"{name} confirmation")
            lines.append(
                f"| {name} | {verdict(section, quick)} | "
                f"{verdict(section, quick) if quick else section.paper_sized_verdict or section.verdict} | "
                f"{runs} | {rows} | "
                f"{timings[name]['seconds']:.0f} | {'—' if confirmed is None else confirmed} | "
                f"{'—' if extra is None or confirmed is None else format(extra['seconds'], '.0f')} |")
        else:
            lines.append(f"| {name} | {verdict(section, quick)} | {runs} | {rows} | "
                         f"{timings[name]['seconds']:.0f} |")
    if claims is not None:
        lines += ["", "Each judged quantity's 95 % interval (blue, or grey beside the judged one; the "
                  "point: our estimate), "
                  "the range the item's rule counts as reproducing the paper (green) and the "
                  "paper's own value where it states one (red):", "",
                  f"![the paper's claims against our intervals]({os.path.relpath(claims, out_dir)})"]
    for name, (section, _, _, _) in sections.items():
        judged = (f"Reproduces: **{section.verdict}** — {section.rule}." if not quick else
                  f"Reproduces: {NO_VERDICT}: the rule of a full run would be: {section.rule}.")
        lines += ["", f"## {ITEMS[name].title}", ""]
        if section.claim:
            lines += [f"The paper: {section.claim}", ""]
        if section.measure:
            lines += [f"Judged on: {section.measure}.", ""]
        if section.confirmed is not None:
            lines += [f"Confirmation run: {section.confirmation}; the verdict is judged on it.", ""]
        lines += [judged, ""]
        if section.confirmed is None:
            lines += ["| quantity | ours | paper |", "|---|---|---|"]
            lines += [f"| {quantity} | {ours} | {paper} |" for quantity, ours, paper in section.rows]
        else:
            lines += ["| quantity | ours, paper-sized run | ours, confirmation run | paper |",
                      "|---|---|---|---|"]
            lines += [f"| {quantity} | {ours} | {section.confirmed.get(quantity, '—')} | {paper} |"
                      for quantity, ours, paper in section.rows]
        lines += [""] + [f"- {note}" for note in section.notes] + ([""] if section.notes else [])
        lines += [f"![{name}]({os.path.relpath(path, out_dir)})" for path in section.figures
                  if path.endswith(".png")]
    lines += ["", "## Readings of SPEC.md's open points used here", ""]
    lines += [f"- {reading}" for reading in READINGS]
    return "\n".join(lines) + "\n"
