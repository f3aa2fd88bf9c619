"""Contact manifolds of the planar model: which points of two boxes (or a box and the ground) touch.

A contact is a point with a normal from body ``a`` to body ``b`` (``a`` is -1 for the ground) and a depth
(positive when overlapping). Points are kept while they are within ``margin`` of touching (negative depth),
so that a solver can stop a box that would reach its neighbour within the step instead of after it
(Box2D's speculative distance).

Box on box works as engines do (Box2D's ``b2CollidePolygons`` is the model; this code is written from the
method, not from it): of the eight faces of the two boxes, the one whose outward normal separates the boxes
most (the axis of least penetration) is the **reference face**; the face of the other box most opposed to
it is the **incident face**; the incident face's edge is clipped to the width of the reference face, and
each of its (at most two) ends that lies within ``margin`` of the reference face is a contact point, placed
half-way between the two surfaces. A box resting flat on another gets two points, one at each end of
their overlap, which is what keeps it from rocking; a box on a corner gets one.

``feature`` identifies a point across steps (reference face, incident face, end of the edge), so a solver
can carry its impulse from one step to the next (warm starting) while the same corners touch.
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import inlined, kernel, leaf
from stackx.models.planar.broad import ROUNDING, candidate_pairs, inside, widen

GROUND = -1
REFERENCE_BIAS = 0.98  # box b becomes the reference only when clearly better: keeps the choice from flipping
ABSOLUTE_BIAS = 0.001  # m, added to the bias for faces nearly equal (the stack's resting contact)

# a box's row in the narrow phase's table (``shapes``): what testing a pair reads of both boxes, side by side
X, Y, REACH_X, REACH_Y, HALF, SCALE = range(6)  # centre, bounding half-sizes, ``beaten``'s terms
FACE = 6  # faces 0 to 3 (+x, +y, -x, -y of the box's frame), four columns each: ``face_axis``
CORNER = 22  # corners 0 to 3 (from (+hx, +hy) counter-clockwise), two columns each: x, y
COLUMNS = 30


@kernel
def face_axis(x: float, y: float, c: float, s: float, hx: float, hy: float, face: int) -> tuple[float, float, float, float]:
    """Outward normal ``(nx, ny)`` of face ``face`` (0: +x, 1: +y, 2: -x, 3: -y of the box's own frame), the
    half-extent along it and the half-width of the face."""
    lx = 1.0 if face == 0 else (-1.0 if face == 2 else 0.0)
    ly = 1.0 if face == 1 else (-1.0 if face == 3 else 0.0)
    extent = hx if face % 2 == 0 else hy
    width = hy if face % 2 == 0 else hx
    return c * lx - s * ly, s * lx + c * ly, extent, width


@leaf
def shapes(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
           boxes: np.ndarray) -> None:
    """Every box's row of the narrow phase's table ``boxes`` (``(bodies, COLUMNS)``), found once a call: its
    centre, the half-sizes of its axis-aligned bounding box (``reach_x = |cos| hx + |sin| hy``, the same
    along y), its smaller half-extent and the sum of the sizes of its numbers (``beaten``'s), its faces
    (``face_axis``) and its corners in the world (corner 0 at ``(+hx, +hy)`` of its own frame, then
    counter-clockwise). Each pair the narrow phase tests reads the two boxes' rows instead of turning both
    boxes again; one row a box, so that a pair's few dozen reads come from two places in one array instead
    of from a dozen arrays (each of which the compiled loop must keep the address of)."""
    for i in range(x.shape[0]):
        c, s = np.cos(angle[i]), np.sin(angle[i])
        boxes[i, X], boxes[i, Y] = x[i], y[i]
        boxes[i, REACH_X] = abs(c) * hx[i] + abs(s) * hy[i]
        boxes[i, REACH_Y] = abs(s) * hx[i] + abs(c) * hy[i]
        boxes[i, HALF] = min(abs(hx[i]), abs(hy[i]))
        boxes[i, SCALE] = abs(x[i]) + abs(y[i]) + abs(hx[i]) + abs(hy[i])
        for corner in range(4):
            px = hx[i] if corner == 0 or corner == 3 else -hx[i]
            py = hy[i] if corner < 2 else -hy[i]
            boxes[i, CORNER + 2 * corner] = x[i] + c * px - s * py
            boxes[i, CORNER + 2 * corner + 1] = y[i] + s * px + c * py
        for face in range(4):
            nx, ny, extent, width = face_axis(x[i], y[i], c, s, hx[i], hy[i], face)
            at = FACE + 4 * face
            boxes[i, at], boxes[i, at + 1], boxes[i, at + 2], boxes[i, at + 3] = nx, ny, extent, width


@inlined
def deepest(ux: float, uy: float, n0x: float, n0y: float, n1x: float, n1y: float, hx: float, hy: float,
            lows: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    """``lows``, the separations of a box's faces 0 to 3 (normals ``n0``, ``n1``, ``-n0``, ``-n1``, extents
    ``hx``, ``hy``, ``hx``, ``hy``) from the deepest corner so far, after one more corner at ``u`` from the
    box's centre."""
    p0, p1 = ux * n0x + uy * n0y, ux * n1x + uy * n1y
    d0, d1, d2, d3 = p0 - hx, p1 - hy, -p0 - hx, -p1 - hy
    low0, low1, low2, low3 = lows
    return (d0 if d0 < low0 else low0), (d1 if d1 < low1 else low1), (d2 if d2 < low2 else low2), (
        d3 if d3 < low3 else low3)


@inlined
def spread(ux: float, uy: float, n0x: float, n0y: float, n1x: float, n1y: float,
           ranges: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    """``ranges``, the least and greatest projections so far of a box's corners on normals ``n0`` and
    ``n1`` (``low0, high0, low1, high1``), after one more corner at ``u`` from the other box's centre."""
    p0, p1 = ux * n0x + uy * n0y, ux * n1x + uy * n1y
    low0, high0, low1, high1 = ranges
    return (p0 if p0 < low0 else low0), (p0 if p0 > high0 else high0), (p1 if p1 < low1 else low1), (
        p1 if p1 > high1 else high1)


@inlined
def separation(a: int, b: int, boxes: np.ndarray) -> tuple[float, int]:
    """The largest separation of box b from a face of box a (negative: the overlap along that face's normal)
    and that face (the first of equals): per face of a, the deepest corner of b below its plane.

    A box's opposite faces have opposite normals and equal extents, so the four faces need two projections
    of each corner of b, not four: ``p`` along face 0's normal gives face 0's separation ``p - hx`` and face
    2's ``-p - hx``, the very numbers projecting on face 2's own normal gives (a negated product and sum round
    as the original, negated). Half the multiplications of projecting on every face, the same bits; the
    minimum is taken as ``d if d < low else low``, as ``if d < low: low = d`` does (a corner that is not a
    number never counts), which compiles without branches; the four corners written out, not looped over.

    With finite extents, a face's separation ``p - hx`` (or ``-p - hx``) never decreases as ``p`` grows (or
    falls), rounding included, so the deepest corner is the one of least (greatest) projection: the least
    and greatest projections, then one subtraction per face, give the same four numbers with a quarter of
    the subtractions. A box whose extents are not finite numbers is taken corner by corner (``deepest``)."""
    xa, ya = boxes[a, X], boxes[a, Y]
    n0x, n0y, hx = boxes[a, FACE], boxes[a, FACE + 1], boxes[a, FACE + 2]
    n1x, n1y, hy = boxes[a, FACE + 4], boxes[a, FACE + 5], boxes[a, FACE + 6]
    if abs(hx) < np.inf and abs(hy) < np.inf:
        ranges = (np.inf, -np.inf, np.inf, -np.inf)
        ranges = spread(boxes[b, CORNER] - xa, boxes[b, CORNER + 1] - ya, n0x, n0y, n1x, n1y, ranges)
        ranges = spread(boxes[b, CORNER + 2] - xa, boxes[b, CORNER + 3] - ya, n0x, n0y, n1x, n1y, ranges)
        ranges = spread(boxes[b, CORNER + 4] - xa, boxes[b, CORNER + 5] - ya, n0x, n0y, n1x, n1y, ranges)
        least0, most0, least1, most1 = spread(boxes[b, CORNER + 6] - xa, boxes[b, CORNER + 7] - ya, n0x, n0y,
                                              n1x, n1y, ranges)
        low0, low1, low2, low3 = least0 - hx, least1 - hy, -most0 - hx, -most1 - hy
    else:
        lows = (np.inf, np.inf, np.inf, np.inf)
        lows = deepest(boxes[b, CORNER] - xa, boxes[b, CORNER + 1] - ya, n0x, n0y, n1x, n1y, hx, hy, lows)
        lows = deepest(boxes[b, CORNER + 2] - xa, boxes[b, CORNER + 3] - ya, n0x, n0y, n1x, n1y, hx, hy, lows)
        lows = deepest(boxes[b, CORNER + 4] - xa, boxes[b, CORNER + 5] - ya, n0x, n0y, n1x, n1y, hx, hy, lows)
        low0, low1, low2, low3 = deepest(boxes[b, CORNER + 6] - xa, boxes[b, CORNER + 7] - ya, n0x, n0y, n1x,
                                         n1y, hx, hy, lows)
    best, face = low0, 0
    if low1 > best:
        best, face = low1, 1
    if low2 > best:
        best, face = low2, 2
    if low3 > best:
        best, face = low3, 3
    return best, face


@leaf
def add_point(n: int, a: int, b: int, nx: float, ny: float, px: float, py: float, depth: float, feature: int,
              body_a: np.ndarray, body_b: np.ndarray, normal: np.ndarray, point: np.ndarray, depths: np.ndarray,
              features: np.ndarray) -> int:
    """Store one point at index ``n`` (if there is room) and return the new count; past the room the count
    still grows, so the caller sees that its arrays were too small."""
    if n < body_a.shape[0]:
        body_a[n], body_b[n] = a, b
        normal[n, 0], normal[n, 1] = nx, ny
        point[n, 0], point[n, 1] = px, py
        depths[n], features[n] = depth, feature
    return n + 1


@leaf
def ground_points(boxes: np.ndarray, static: np.ndarray, margin: float, n: int, body_a: np.ndarray,
                  body_b: np.ndarray, normal: np.ndarray, point: np.ndarray, depths: np.ndarray,
                  features: np.ndarray) -> int:
    """Box by box, the (at most two) lowest corners of each movable box whose bounding box comes within
    ``margin`` of the ground that are within ``margin`` of it, normal straight up, after the ``n`` points
    already stored; returns the new count. The corners are the boxes' rows of ``shapes``; one call for every
    box, as a call per box would hand over the point arrays each time."""
    for i in range(boxes.shape[0]):
        if static[i] or not boxes[i, Y] - boxes[i, REACH_Y] <= margin:
            continue
        first, second = -1, -1
        h1, h2 = np.inf, np.inf
        for corner in range(4):
            cy = boxes[i, CORNER + 2 * corner + 1]
            if cy < h1:
                second, h2 = first, h1
                first, h1 = corner, cy
            elif cy < h2:
                second, h2 = corner, cy
        for end in range(2):
            corner = first if end == 0 else second
            at = CORNER + 2 * (corner if corner >= 0 else 1)  # none found (not numbers): the corner (-hx, +hy)
            cx, cy = boxes[i, at], boxes[i, at + 1]
            if cy <= margin:
                n = add_point(n, GROUND, i, 0.0, 1.0, cx, 0.5 * cy, -cy, corner, body_a, body_b, normal, point,
                              depths, features)
    return n


@inlined
def beaten(a: int, b: int, boxes: np.ndarray, below: float) -> bool:
    """Whether every face of box b surely separates box a by less than ``below``, from the centres alone:
    then ``separation(b, a)`` need not be found (its face cannot be the reference, nor its separation pass
    the margin).

    The deepest corner of a below a face of b lies at least a's smaller half-extent past a's centre
    (``hx |cos| + hy |sin| >= min(hx, hy)`` for a unit normal), so that face's separation is at most the
    centre's height over the face, less that half-extent. The bound must clear ``below`` by more than the
    rounding of both it and the corners (``ROUNDING`` of the boxes' scale, the sizes of their centres and
    half-extents); a bound that is not a number clears nothing. In a pile, where a pair's own face is the
    clear reference, this halves the faces tested."""
    dx, dy = boxes[a, X] - boxes[b, X], boxes[a, Y] - boxes[b, Y]
    over0 = abs(dx * boxes[b, FACE] + dy * boxes[b, FACE + 1]) - boxes[b, FACE + 2]
    over1 = abs(dx * boxes[b, FACE + 4] + dy * boxes[b, FACE + 5]) - boxes[b, FACE + 6]
    half = boxes[a, HALF]
    scale = 1.0 + boxes[a, SCALE] + boxes[b, SCALE]
    if not np.isfinite(over0 + over1 + half + scale):  # a max or min could drop a number that is none
        return False
    return max(over0, over1) - half + ROUNDING * scale < below


@inlined
def clipped(bound: float, e0x: float, e0y: float, u0: float, e1x: float, e1y: float,
            u1: float) -> tuple[bool, float, float, float, float, float, float]:
    """An edge from ``e0`` to ``e1`` (at ``u0`` and ``u1`` along the reference face) cut where it passes
    ``bound``: the part above a negative bound, below any other; whether none of it is left, and its ends."""
    out0 = u0 < bound if bound < 0 else u0 > bound
    out1 = u1 < bound if bound < 0 else u1 > bound
    if out0 and out1:
        return True, e0x, e0y, u0, e1x, e1y, u1
    if out0 or out1:
        t = (bound - u0) / (u1 - u0)
        px, py = e0x + t * (e1x - e0x), e0y + t * (e1y - e0y)
        if out0:
            return False, px, py, bound, e1x, e1y, u1
        return False, e0x, e0y, u0, px, py, bound
    return False, e0x, e0y, u0, e1x, e1y, u1


@inlined
def box_points(i: int, j: int, boxes: np.ndarray, margin: float, n: int, body_a: np.ndarray, body_b: np.ndarray,
               normal: np.ndarray, point: np.ndarray, depths: np.ndarray, features: np.ndarray) -> int:
    """The manifold of boxes ``i`` and ``j`` (normal from i to j): reference face, incident face, clipping;
    the boxes' rows of ``shapes``."""
    sep_i, face_i = separation(i, j, boxes)
    if sep_i > margin:  # a face of i keeps j farther than the margin: no contact (nor any test of j's faces)
        return n
    threshold = REFERENCE_BIAS * sep_i + ABSOLUTE_BIAS  # what a face of j must beat to be the reference
    flip, face_j = False, 0
    if not beaten(i, j, boxes, min(threshold, margin)):
        sep_j, face_j = separation(j, i, boxes)
        if sep_j > margin:
            return n
        flip = sep_j > threshold
    r, k = (j, i) if flip else (i, j)  # reference and incident box
    face = face_j if flip else face_i
    at = FACE + 4 * face
    nx, ny, extent, width = boxes[r, at], boxes[r, at + 1], boxes[r, at + 2], boxes[r, at + 3]
    tx, ty = -ny, nx
    # the face of k most opposed to the normal; faces 2 and 3 give the negatives of faces 0 and 1
    d0 = boxes[k, FACE] * nx + boxes[k, FACE + 1] * ny
    d1 = boxes[k, FACE + 4] * nx + boxes[k, FACE + 5] * ny
    incident, lowest = 0, (d0 if d0 < np.inf else np.inf)  # the first of equals; one not a number never
    if d1 < lowest:
        incident, lowest = 1, d1
    if -d0 < lowest:
        incident, lowest = 2, -d0
    if -d1 < lowest:
        incident = 3
    at = FACE + 4 * incident
    fx, fy, e, w = boxes[k, at], boxes[k, at + 1], boxes[k, at + 2], boxes[k, at + 3]
    gx, gy = -fy, fx
    xk, yk, xr, yr = boxes[k, X], boxes[k, Y], boxes[r, X], boxes[r, Y]
    e0x, e0y = xk + fx * e + gx * w, yk + fy * e + gy * w  # the incident edge's two ends
    e1x, e1y = xk + fx * e - gx * w, yk + fy * e - gy * w
    u0 = (e0x - xr) * tx + (e0y - yr) * ty
    u1 = (e1x - xr) * tx + (e1y - yr) * ty
    # clip the edge to the reference face's width, one side at a time
    gone, e0x, e0y, u0, e1x, e1y, u1 = clipped(-width, e0x, e0y, u0, e1x, e1y, u1)
    if gone:
        return n
    gone, e0x, e0y, u0, e1x, e1y, u1 = clipped(width, e0x, e0y, u0, e1x, e1y, u1)
    if gone:
        return n
    sign = -1.0 if flip else 1.0  # the normal goes from i to j
    feature = (1 if flip else 0) * 64 + face * 16 + incident * 4  # and the end
    sep = (e0x - xr) * nx + (e0y - yr) * ny - extent
    if sep <= margin:
        n = add_point(n, i, j, sign * nx, sign * ny, e0x - 0.5 * sep * nx, e0y - 0.5 * sep * ny, -sep, feature,
                      body_a, body_b, normal, point, depths, features)
    sep = (e1x - xr) * nx + (e1y - yr) * ny - extent
    if sep <= margin:
        n = add_point(n, i, j, sign * nx, sign * ny, e1x - 0.5 * sep * nx, e1y - 0.5 * sep * ny, -sep,
                      feature + 1, body_a, body_b, normal, point, depths, features)
    return n


@leaf
def pair_points(near: np.ndarray, boxes: np.ndarray, margin: float, n: int, body_a: np.ndarray,
                body_b: np.ndarray, normal: np.ndarray, point: np.ndarray, depths: np.ndarray,
                features: np.ndarray) -> int:
    """The points of the ``near[0]`` candidate pairs (keys ``i * bodies + j``, increasing, in ``near[1:]``)
    whose bounding boxes come within ``margin``, in their order, after the ``n`` already stored; returns the
    new count. One loop with the narrow phase written into it: a call per pair would hand over a dozen
    arrays each time."""
    bodies = boxes.shape[0]
    i = 0
    for p in range(1, near[0] + 1):
        while near[p] >= (i + 1) * bodies:  # the keys come sorted: i found without a division per pair
            i += 1
        j = near[p] - i * bodies
        if (abs(boxes[i, X] - boxes[j, X]) > boxes[i, REACH_X] + boxes[j, REACH_X] + margin
                or abs(boxes[i, Y] - boxes[j, Y]) > boxes[i, REACH_Y] + boxes[j, REACH_Y] + margin):
            continue
        n = box_points(i, j, boxes, margin, n, body_a, body_b, normal, point, depths, features)
    return n


@kernel
def collide(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray, static: np.ndarray,
            margin: float, body_a: np.ndarray, body_b: np.ndarray, normal: np.ndarray, point: np.ndarray,
            depths: np.ndarray, features: np.ndarray) -> int:
    """Every contact point of one world (one batch row's arrays): boxes on the ground, then pairs of boxes
    whose bounding boxes come within ``margin``, in index order; returns the number of points (more than
    the arrays hold when they were too small). Two static boxes never collide.

    The pairs are the broad phase's candidates (``broad.candidate_pairs``, a grid: linear in the boxes),
    each tested again here as every pair once was, so the points and their order are those of testing
    every pair."""
    near = np.empty(4 * x.shape[0] + 17, np.int64)
    near[0] = -1  # no candidates kept: found afresh, within ``margin``
    count, _ = collide_near(x, y, angle, hx, hy, static, margin, margin, near, np.empty((x.shape[0], 4)), body_a,
                            body_b, normal, point, depths, features)
    return count


@kernel
def collide_near(x: np.ndarray, y: np.ndarray, angle: np.ndarray, hx: np.ndarray, hy: np.ndarray,
                 static: np.ndarray, margin: float, fat: float, near: np.ndarray, wide: np.ndarray,
                 body_a: np.ndarray, body_b: np.ndarray, normal: np.ndarray, point: np.ndarray, depths: np.ndarray,
                 features: np.ndarray) -> tuple[int, np.ndarray]:
    """``collide`` with the broad phase's candidates kept from one call to the next (Box2D's fat bounding
    boxes): ``near[0]`` candidate pairs (-1: none yet) in ``near[1:]``, found within ``fat`` >= ``margin``
    while each box stood inside its bounds ``wide`` (``(bodies, 4)``: low x, high x, low y, high y, grown by
    ``fat / 2``). A call whose boxes, grown by ``margin / 2``, all still lie inside their ``wide`` bounds
    reuses them: every pair within ``margin`` now was within ``fat`` then, and the narrow phase's own test
    drops the rest, so the points and their order are ``collide``'s. Otherwise they are found again around
    where the boxes are now. A resting pile then pays for no broad phase; a wider ``fat`` keeps candidates
    through larger motions and hands the narrow phase more pairs to reject. Returns the count and ``near``
    (a larger array when the candidates outgrew it)."""
    boxes = np.empty((x.shape[0], COLUMNS))
    shapes(x, y, angle, hx, hy, boxes)
    n = ground_points(boxes, static, margin, 0, body_a, body_b, normal, point, depths, features)
    reach_x, reach_y = boxes[:, REACH_X], boxes[:, REACH_Y]
    if near[0] < 0 or not inside(x, y, reach_x, reach_y, margin, wide):
        pairs = candidate_pairs(x, y, reach_x, reach_y, static, fat, near[1:])
        if pairs > near.shape[0] - 1:
            near = np.empty(pairs + 1, np.int64)
            pairs = candidate_pairs(x, y, reach_x, reach_y, static, fat, near[1:])
        near[0] = pairs
        widen(x, y, reach_x, reach_y, fat, wide)
    n = pair_points(near, boxes, margin, n, body_a, body_b, normal, point, depths, features)
    return n, near
