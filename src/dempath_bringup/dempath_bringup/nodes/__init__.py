"""The node graphs that bring a dempath system up (one process, no launch)."""
