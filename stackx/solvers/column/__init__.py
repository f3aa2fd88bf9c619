"""The column's solvers, one file per solver, and the column's shared stages (position, isotonic)."""
