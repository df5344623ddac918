"""lwrl's agents: gradient-descent Sarsa(lambda) with NRBF features, and a CMAC baseline."""
