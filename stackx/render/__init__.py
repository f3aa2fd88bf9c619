"""Renderer plugins: pictures and pages drawn from recorded states."""
