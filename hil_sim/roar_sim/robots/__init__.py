"""The simulated robots."""
