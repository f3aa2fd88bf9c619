"""Solver plugins; ``stackx.solvers.base`` holds what they share."""
