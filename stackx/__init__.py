"""stackx: run, compare and stress-test rigid-body contact solvers from YAML configs."""

__version__ = "0.1.0"
