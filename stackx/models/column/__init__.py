"""The column model: boxes stacked on a floor, moving only vertically (the lab's world).

- ``state``: ``ColumnState``, the batch of columns; ``monitor``: what solvers update after every step;
- ``measures``: a run's measures and those the bench adds; ``error``: the every-step error against ``exact``;
- ``model``: the plugin tying them together (registered as ``column``).
"""
