"""What several studies share: statistics over agents and figures."""
