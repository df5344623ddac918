"""The `lwrl` command: one module per subcommand."""
