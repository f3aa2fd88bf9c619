"""The column model: boxes stacked on a floor, moving only vertically (the lab's world).

- ``state``: ``ColumnState``, the batch of columns; ``monitor``: what solvers update after every step;
- ``measures``: a run's measures and those the bench adds (its every-step error against ``exact`` is the
  bench's: ``stackx.bench.error_column``);
- ``model``: the plugin tying them together (registered as ``column``).
"""
