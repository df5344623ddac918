"""Speed benchmarks of lwrl; run each as a module from the repository root."""
