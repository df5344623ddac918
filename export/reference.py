"""What the C learner (`export.learner`) takes from lwrl's Python learner, in one place.

The C code mirrors the Python learner's arithmetic; these are the only pieces of `agent/` it
reads: the feature map and its clamp, the saved agents' loader, the traces' flush threshold
and trace names, and the SplitMix64 stream's constants. If the learner's modules are
reshaped, these import lines are what follows them.
"""

from lwrl.agent.io import load as load_agents
from lwrl.agent.nrbf import DEFAULT_R2, NRBF, clamp_margin
from lwrl.agent.streams import _GOLDEN_GAMMA, _MIX_1, _MIX_2, _SHIFTS, _TO_UNIT
from lwrl.agent.traces import FLUSH_THRESHOLD, TRACES as TRACE_NAMES

STREAM = {"golden_gamma": int(_GOLDEN_GAMMA), "mix_1": int(_MIX_1), "mix_2": int(_MIX_2),
          "shifts": tuple(int(s) for s in _SHIFTS), "to_unit": float(_TO_UNIT)}
"""SplitMix64 as `agent/streams.py` runs it: the state's increment, the two multipliers,
the four shifts (three of the hash, then the one that keeps 53 bits) and 2^-53."""

TRACES = ("replacing", "accumulating")

"""The trace rules the C learner has: eq. 6 and eq. 2 (`agent/traces.py`'s names)."""

__all__ = ["DEFAULT_R2", "FLUSH_THRESHOLD", "NRBF", "STREAM", "TRACES", "TRACE_NAMES", "clamp_margin",
           "load_agents"]
