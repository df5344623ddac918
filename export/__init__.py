"""A trained agent as code for an embedded controller (`lwrl export`)."""
