"""Reading and validating a config: YAML with positions, the experiment, its schema, expressions, the plan (spec), limits and sizing, and the configs that ship with stackx."""
