"""lwrl's experiments: runs, sweeps, the paper's figures, and the `lwrl` command."""
