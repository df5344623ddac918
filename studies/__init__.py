"""Studies that read runners' results: the paper's items (`paper`), the plant comparison
(`compare`) and the learning curves of other suites' runs (`other_suites`)."""
