"""Other suites' environments (dm_control's own suite, Gymnasium) as sources of episodes
for lwrl's agents."""
