"""Sink plugins: measured numbers written to files."""
