"""The analytic and physics-engine plants of a task, compared (`lwrl compare`)."""
