"""`python -m lwrl.cli`: the `lwrl` command."""

import sys

from lwrl.cli.main import main

sys.exit(main())
