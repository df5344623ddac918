"""`lwrl bench export DIR --parquet OUT`: a benchmark's runs as one Parquet dataset with its
data card (`studies/paper/benchmark/dataset.py`)."""

import shlex
import time

from lwrl import outputs
from lwrl.cli import output


def add_export(actions) -> None:
    export = actions.add_parser(
        "export", help="a benchmark's runs as one Parquet dataset with its data card",
        description="Write every run table of the benchmark directory DIR (runs/*.csv.gz, "
                    "as `lwrl bench run` writes them) as one Parquet file, OUT/runs.parquet, "
                    "a column per field of the run tables' schema "
                    "(runners/schemas/run_table.json) typed by it; where the runs have records "
                    "of their costs (runs/records/*.csv.gz), those as OUT/records.parquet, "
                    "typed by runners/schemas/records.json; and the data card, OUT/README.md: "
                    "the fields with their units, the source, the licence, how to cite. "
                    "`pandas.read_parquet('OUT/runs.parquet')` loads it.")
    export.add_argument("directory", metavar="DIR", help="the benchmark's directory")
    export.add_argument("--parquet", metavar="OUT", required=True,
                        help="the dataset's directory (runs.parquet, records.parquet where "
                             "the runs have records, README.md)")
    export.add_argument("--force", action="store_true",
                        help="replace runs.parquet, records.parquet and README.md where OUT "
                             "holds them")
    export.set_defaults(run=run_export)


def run_export(args) -> int:
    """Export the runs of DIR to OUT."""
    module, _ = output.study_modules("bench", "lwrl.studies.paper.benchmark.dataset", "pyarrow")
    output.claim_outputs(args, "parquet")
    outputs.check_directory(args.parquet, "--parquet", force=args.force,
                            names=(module.DATA, module.RECORDS, module.CARD))
    module.run_tables(args.directory)
    started = time.perf_counter()
    written = module.export(args.directory, args.parquet, shlex.join(["lwrl", *args.argv]))
    output.done(started, written)
    return 0
