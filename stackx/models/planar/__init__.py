"""The planar model: rigid boxes in a vertical plane that slide, rotate and rest on corners.

- ``state``: ``PlanarState``, the batch of worlds; ``collide``: contact manifolds (box on ground, box on box)
  of up to two points each, found by separating axes and clipping as engines do; ``layout``: the columns of
  the contact table solvers fill from them.
"""
