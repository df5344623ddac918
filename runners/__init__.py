"""Runners: a run configuration in, results out: the agent-environment loops (stepped and
compiled), episode recordings, sweeps of many runs and the files they write."""
