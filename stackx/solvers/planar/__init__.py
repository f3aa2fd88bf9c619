"""Solvers of the planar model (``models = ("planar",)``); ``contacts`` holds the stages they share."""
