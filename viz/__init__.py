"""lwrl's visualisation: episodes streamed or saved to Rerun."""
