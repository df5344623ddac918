"""lwrl as C for embedded devices: a trained agent as a frozen controller (`lwrl export`),
the learner itself (`lwrl learner`), and device programs that run it on an emulated
Cortex-M4 (`lwrl device`)."""
