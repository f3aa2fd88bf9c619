"""The columns of a planar contact table: ``ids`` (which bodies, which corners) and ``table`` (where, how
heavy, what impulse), in one place with the model for every solver stage, reference and measure that reads or
writes them (``stackx.solvers.planar.contacts`` describes the table and the stages on it)."""

# ids columns
A, B, FEATURE = 0, 1, 2
# table columns: normal, point, depth (from collide); anchors, masses, friction, target, impulses (prepare
# and the solve); the face normal and point in the reference body's frame and the touching corner in the
# incident body's frame (anchor_locals)
NX, NY, PX, PY, DEPTH, RAX, RAY, RBX, RBY, KN, KT, MU, TARGET, PN, PT = range(15)
LNX, LNY, LFX, LFY, LQX, LQY = range(15, 21)
# on the first point of a two-point manifold (prepare): its 2 x 2 normal mass matrix K and whether K is
# conditioned well enough for the block solve (1.0) or not (0.0): fixed for the step, so found once
K11, K12, K22, CONDITIONED = range(21, 25)
COLUMNS = 25
