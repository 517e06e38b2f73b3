"""Structural stability without a physics engine (docs/paper-numbers.md#stability): loose parts and a drop test.

A shape is stable when (a) it has no loose parts and (b) dropped onto the plane from 5% of
its height it keeps its height (z-extent) and its centre-of-mass height within 2% of the
height after at most 5 s of simulated time. Shapes are z-up and read in metres.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

# ---------------------------------------------------------------------------------------------
# Loose parts
# ---------------------------------------------------------------------------------------------


def _point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Exact distance from points p (m,3) to triangles tri (m,3,3), pairwise.

    Inside the triangle's prism the distance is |n.(p-a)|/|n|; outside it is the smallest
    distance to the three edge segments, d(p, ab) = |p - (a + clip(t,0,1)(b-a))|,
    t = (p-a).(b-a)/|b-a|^2.
    """
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, ac, ap = b - a, c - a, p - a
    # barycentric coordinates of the projection of p onto the plane
    d00, d01, d11 = (ab * ab).sum(1), (ab * ac).sum(1), (ac * ac).sum(1)
    d20, d21 = (ap * ab).sum(1), (ap * ac).sum(1)
    denom = d00 * d11 - d01 * d01
    safe = np.where(np.abs(denom) > 1e-30, denom, 1.0)
    v = (d11 * d20 - d01 * d21) / safe
    w = (d00 * d21 - d01 * d20) / safe
    inside = (v >= 0) & (w >= 0) & (v + w <= 1) & (np.abs(denom) > 1e-30)
    normal = np.cross(ab, ac)
    nlen = np.linalg.norm(normal, axis=1)
    plane = np.abs((ap * normal).sum(1)) / np.where(nlen > 0, nlen, 1.0)
    edge = np.full(len(p), np.inf)
    for s, e in ((a, b), (b, c), (c, a)):
        se = e - s
        t = ((p - s) * se).sum(1) / np.maximum((se * se).sum(1), 1e-30)
        q = s + np.clip(t, 0.0, 1.0)[:, None] * se
        edge = np.minimum(edge, np.linalg.norm(p - q, axis=1))
    return np.where(inside, plane, edge)


def _segments_cross(s0: np.ndarray, s1: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Pairwise: does segment s0->s1 pierce triangle tri? (Moller-Trumbore, t in [0,1])."""
    eps = 1e-12
    a = tri[:, 0]
    e1, e2 = tri[:, 1] - a, tri[:, 2] - a
    d = s1 - s0
    h = np.cross(d, e2)
    det = (e1 * h).sum(1)
    ok = np.abs(det) > eps
    inv = 1.0 / np.where(ok, det, 1.0)
    sv = s0 - a
    u = (sv * h).sum(1) * inv
    q = np.cross(sv, e1)
    v = (d * q).sum(1) * inv
    t = (e2 * q).sum(1) * inv
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


def winding_number(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Generalised winding numbers (k,) of a closed triangle soup about points (k,3).

    w = sum of solid angles / 4 pi, with the solid angle of one triangle (van Oosterom and
    Strackee) Omega = 2 atan2(a.(b x c), |a||b||c| + (a.b)|c| + (b.c)|a| + (c.a)|b|), where
    a, b, c are the corners relative to the point. |w| ~ 1 inside, ~ 0 outside.
    """
    # component-wise arithmetic: reductions over a length-3 axis are slow in numpy
    r = np.moveaxis(tri, (1, 2), (0, 1))[None] - points[:, None, :, None]  # (k,3 corners,3,F)
    a, b, c = r[:, 0], r[:, 1], r[:, 2]  # (k,3,F)

    def dot(u, v):
        return u[:, 0] * v[:, 0] + u[:, 1] * v[:, 1] + u[:, 2] * v[:, 2]

    la, lb, lc = np.sqrt(dot(a, a)), np.sqrt(dot(b, b)), np.sqrt(dot(c, c))
    num = (
        a[:, 0] * (b[:, 1] * c[:, 2] - b[:, 2] * c[:, 1])
        + a[:, 1] * (b[:, 2] * c[:, 0] - b[:, 0] * c[:, 2])
        + a[:, 2] * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    )
    den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb
    return np.arctan2(num, den).sum(-1) / (2.0 * np.pi)


class _Part:
    """One connected component: its triangles, edges and bounding box."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, edges: np.ndarray, closed: bool):
        self.tri = vertices[faces]  # (F,3,3)
        self.edges = vertices[edges]  # (E,2,3)
        used = np.zeros(len(vertices), dtype=bool)
        used[faces] = True
        self.points = vertices[used]  # own vertices only
        self.lo, self.hi = self.points.min(0), self.points.max(0)
        t0, t1, t2 = self.tri[:, 0], self.tri[:, 1], self.tri[:, 2]
        self.tri_lo = np.minimum(np.minimum(t0, t1), t2)
        self.tri_hi = np.maximum(np.maximum(t0, t1), t2)
        self.closed = closed

    def overlaps(self, other: _Part, tol: float) -> bool:
        return bool(np.all(self.lo <= other.hi + tol) and np.all(other.lo <= self.hi + tol))

    def in_box(self, pts: np.ndarray, tol: float) -> np.ndarray:
        return np.all((pts >= self.lo - tol) & (pts <= self.hi + tol), axis=1)

    def tri_near(self, lo: np.ndarray, hi: np.ndarray, tol: float) -> np.ndarray:
        """Triangles whose own box meets the box [lo, hi] grown by tol."""
        return np.all((self.tri_lo <= hi + tol) & (self.tri_hi >= lo - tol), axis=1)


def _close_pairs(
    x: np.ndarray, rx: np.ndarray, y: np.ndarray, ry: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j) with |x_i - y_j| <= rx_i + ry_j + reach (balls that come close).

    One tree-tree query at the largest radii (scipy's sparse_distance_matrix, vectorised
    output), then the exact per-pair bound."""
    if len(x) == 0 or len(y) == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    limit = float(rx.max() + ry.max() + reach)
    found = cKDTree(x).sparse_distance_matrix(cKDTree(y), limit, output_type="ndarray")
    i, j = found["i"].astype(np.int64), found["j"].astype(np.int64)
    keep = found["v"] <= rx[i] + ry[j] + reach
    return i[keep], j[keep]


def _ball(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre (centroid) and radius (farthest corner) of each triangle's bounding ball."""
    centre = (tri[:, 0] + tri[:, 1] + tri[:, 2]) / 3
    d = tri - centre[:, None]
    d = d * d
    return centre, np.sqrt((d[..., 0] + d[..., 1] + d[..., 2]).max(1))


def _pairs(pts: np.ndarray, tri: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """(point, triangle) index pairs with the point within reach of the triangle's ball."""
    centre, radius = _ball(tri)
    return _close_pairs(pts, np.zeros(len(pts)), centre, radius, reach)


def _split_segments(edges: np.ndarray, step: float) -> np.ndarray:
    """Cut segments (E,2,3) into pieces no longer than step (their union is unchanged)."""
    length = np.sqrt(((edges[:, 1] - edges[:, 0]) ** 2).sum(1))
    pieces = np.maximum(1, np.ceil(length / step)).astype(np.int64)
    if len(pieces) == 0 or pieces.max() == 1:
        return edges
    owner = np.repeat(np.arange(len(edges)), pieces)
    k = np.arange(len(owner)) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    t0 = (k / pieces[owner])[:, None]
    t1 = ((k + 1) / pieces[owner])[:, None]
    start, d = edges[owner, 0], edges[owner, 1] - edges[owner, 0]
    return np.stack([start + t0 * d, start + t1 * d], axis=1)


def _split_triangles(
    tri: np.ndarray, step: float, box: tuple[np.ndarray, np.ndarray], rounds: int = 16
) -> np.ndarray:
    """Bisect the longest edge of every triangle longer than step until none is (at most
    `rounds` times), dropping pieces whose box misses `box`: the union inside the box is
    unchanged, and the long sides of thin triangles get cut without making many pieces."""
    done = []
    for _ in range(rounds):
        tri = tri[_in_region(tri.min(1), tri.max(1), box)]
        e = tri[:, [1, 2, 0]] - tri  # (F,3,3): edge i runs from corner i to i+1
        e = e * e
        length = e[..., 0] + e[..., 1] + e[..., 2]  # squared; sum(axis=2) is slow here
        big = length.max(1) > step * step
        done.append(tri[~big])
        tri = tri[big]
        if len(tri) == 0:
            break
        i = length[big].argmax(1)
        rows = np.arange(len(tri))
        a, b, c = tri[rows, i], tri[rows, (i + 1) % 3], tri[rows, (i + 2) % 3]
        m = (a + b) / 2
        tri = np.concatenate([np.stack([a, m, c], 1), np.stack([m, b, c], 1)])
    return np.concatenate([*done, tri])


def _in_region(lo: np.ndarray, hi: np.ndarray, box: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    return np.all((lo <= box[1]) & (hi >= box[0]), axis=1)


class _Local:
    """The geometry of p and q near each other: p's vertices and edges and q's triangles
    inside the overlap of their boxes (grown by tol), with long edges and big triangles cut
    to a common size so that each candidate search stays local. Built on first use."""

    def __init__(self, p: _Part, q: _Part, tol: float):
        self.p, self.q, self.tol = p, q, tol
        self.box = (np.maximum(p.lo, q.lo) - tol, np.minimum(p.hi, q.hi) + tol)
        self._pieces = None

    @property
    def points(self) -> np.ndarray:
        return self.p.points[_in_region(self.p.points, self.p.points, self.box)]

    def pieces(self) -> tuple[np.ndarray, np.ndarray]:
        """(segments (S,2,3) of p, triangles (T,3,3) of q), both cut to one size."""
        if self._pieces is None:
            p, q, box = self.p, self.q, self.box
            seg = p.edges[_in_region(p.edges.min(1), p.edges.max(1), box)]
            tri = q.tri[_in_region(q.tri_lo, q.tri_hi, box)]
            if len(seg) and len(tri):
                # cut what is longer than 1/16 of the region (long edges, the long sides
                # of thin triangles): their bounding balls would reach far too many others
                step = float((box[1] - box[0]).max()) / 16
                seg = _split_segments(seg, step)
                seg = seg[_in_region(seg.min(1), seg.max(1), box)]
                tri = _split_triangles(tri, step, box)
            self._pieces = (seg, tri)
        return self._pieces


def _half_length(seg: np.ndarray) -> float:
    return float(np.sqrt(((seg[:, 1] - seg[:, 0]) ** 2).sum(1).max())) / 2 if len(seg) else 0.0


def _inside(local: _Local) -> bool:
    """Whether p's vertex nearest q's box centre lies inside closed q (|winding| > 1/2).
    A part wholly inside another touches no surface, so it needs this test; one point
    suffices there."""
    q = local.q
    if not q.closed:
        return False
    pts = local.points
    if len(pts) == 0:
        return False
    centre = (q.lo + q.hi) / 2
    x = pts[np.argmin(((pts - centre) ** 2).sum(1))]
    return bool(abs(winding_number(x[None], q.tri)[0]) > 0.5)


def _near(local: _Local) -> bool:
    """Whether a vertex of p lies within tol of a triangle of q (exact point-triangle distance)."""
    pts = local.points
    if len(pts) == 0:
        return False  # before pieces(): the cut is the costly part
    tri = local.pieces()[1]
    i, t = _pairs(pts, tri, local.tol)
    return bool(len(i) and (_point_triangle_distance(pts[i], tri[t]) <= local.tol).any())


def _pierces(local: _Local) -> bool:
    """Whether an edge of p crosses a triangle of q (surfaces that intersect transversally
    always have such an edge, even when no vertex is near the other surface)."""
    seg, tri = local.pieces()
    i, t = _pairs(seg.mean(1), tri, _half_length(seg))
    return bool(len(i) and _segments_cross(seg[i, 0], seg[i, 1], tri[t]).any())


def _segment_distance(p0, p1, q0, q1) -> np.ndarray:
    """Pairwise distance between segments p0p1 and q0q1, (n,3) each.

    Minimise |p0 + s d1 - q0 - t d2|^2 over s, t in [0,1]: the unconstrained s from the
    normal equations, clamped; t = (b s + f) / e for that s, clamped, and s recomputed
    for a clamped t (a = d1.d1, b = d1.d2, c = d1.r, e = d2.d2, f = d2.r, r = p0 - q0).
    """
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e = (d1 * d1).sum(1), (d2 * d2).sum(1)
    b, c, f = (d1 * d2).sum(1), (d1 * r).sum(1), (d2 * r).sum(1)
    a, e = np.maximum(a, 1e-30), np.maximum(e, 1e-30)
    denom = a * e - b * b
    parallel = denom <= 1e-12 * a * e
    s = np.where(parallel, 0.0, np.clip((b * f - c * e) / np.where(parallel, 1.0, denom), 0, 1))
    t = (b * s + f) / e
    s = np.where(t < 0, np.clip(-c / a, 0, 1), np.where(t > 1, np.clip((b - c) / a, 0, 1), s))
    t = np.clip(t, 0, 1)
    gap = p0 + s[:, None] * d1 - q0 - t[:, None] * d2
    return np.sqrt((gap * gap).sum(1))


def _edges_near(local: _Local) -> bool:
    """Whether an edge of p passes within tol of an edge of q's triangles. With the
    vertex-triangle and piercing tests this makes the surface distance exact: the
    distance between a segment and a triangle is attained at a segment end, at a crossing,
    or between the segment and a triangle edge (e.g. two stacked planks that cross)."""
    seg, tri = local.pieces()
    if len(seg) == 0 or len(tri) == 0:
        return False
    sides = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    half_seg = np.sqrt(((seg[:, 1] - seg[:, 0]) ** 2).sum(1)) / 2
    half_side = np.sqrt(((sides[:, 1] - sides[:, 0]) ** 2).sum(1)) / 2
    i, j = _close_pairs(seg.mean(1), half_seg, sides.mean(1), half_side, local.tol)
    dist = _segment_distance(seg[i, 0], seg[i, 1], sides[j, 0], sides[j, 1])
    return bool((dist <= local.tol).any())


def _touches(p: _Part, q: _Part, tol: float) -> bool:
    """Whether the surfaces come within tol, or one part lies inside the other. Each test
    runs both ways; containment first: one winding number, and parts that are plugged
    into each other (legs into a seat, handles into a body) pass it at once."""
    if not p.overlaps(q, tol):
        return False
    both = (_Local(p, q, tol), _Local(q, p, tol))
    tests = (_inside, _near, _pierces, _edges_near)
    return any(test(local) for test in tests for local in both)


WELD = 1e-3  # vertices closer than WELD * tol * diagonal are one vertex


def _unique_edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Undirected edges (E,2) of a face array and how many faces use each."""
    a = faces.reshape(-1)
    b = faces[:, [1, 2, 0]].reshape(-1)
    lo, hi = np.minimum(a, b), np.maximum(a, b)  # np.sort(axis=1) is slow for pairs
    base = int(hi.max()) + 1
    keys, counts = np.unique(lo * base + hi, return_counts=True)
    return np.stack([keys // base, keys % base], axis=1), counts


def _merged_ids(vertices: np.ndarray, eps: float) -> np.ndarray:
    """Map each vertex to the smallest index of the vertices within eps of it (welding)."""
    ids = np.arange(len(vertices))
    if eps <= 0:
        return ids
    pairs = cKDTree(vertices, balanced_tree=False).query_pairs(eps, output_type="ndarray")
    if len(pairs):
        n = len(vertices)
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, lab = connected_components(graph, directed=False)
        first = np.empty(lab.max() + 1, dtype=np.int64)
        first[lab[::-1]] = ids[::-1]  # the last write wins: the smallest index per cluster
        ids = first[lab]
    return ids


def _groups(labels: np.ndarray) -> list[np.ndarray]:
    """Indices of each distinct label, in label order."""
    order = np.argsort(labels, kind="stable")
    return np.split(order, np.flatnonzero(np.diff(labels[order])) + 1)


def _components(mesh: trimesh.Trimesh, tol: float) -> tuple[list[_Part], float]:
    """Split into welded, face-connected components; returns them and the absolute tol."""
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    eps = tol * float(np.linalg.norm(vertices.max(0) - vertices.min(0)))
    # weld only (near-)coincident duplicates: welding at tol would chain the vertices of a
    # finely tessellated thin tube into a few points; nearby parts still join by touching
    welded = _merged_ids(vertices, eps * WELD)[faces]
    n = len(vertices)
    r = np.concatenate([welded[:, 0], welded[:, 1]])
    c = np.concatenate([welded[:, 1], welded[:, 2]])
    graph = coo_matrix((np.ones(len(r), dtype=np.int8), (r, c)), shape=(n, n))
    vlabel = connected_components(graph, directed=False)[1]
    edges, counts = _unique_edges(welded)
    elabel = vlabel[edges[:, 0]]
    # a component is closed when each of its edges joins exactly two faces
    open_edges = np.bincount(elabel, weights=counts != 2, minlength=n)
    parts = []
    for f, e in zip(_groups(vlabel[welded[:, 0]]), _groups(elabel), strict=True):
        label = vlabel[welded[f[0], 0]]
        parts.append(_Part(vertices, welded[f], edges[e], open_edges[label] == 0))
    return parts, eps


def loose_parts(mesh: trimesh.Trimesh, tol: float = 1e-3) -> int:
    """Number of connected components that do not belong to the largest touching group.

    `tol` is relative to the bounding-box diagonal d; the absolute tolerance is tol * d.
    Components are face-connected groups after welding coincident vertices (closer than
    WELD * tol * d). Two components touch when their surfaces come within tol * d (exactly:
    a vertex near a triangle, an edge piercing a triangle, or two edges near each other) or
    one lies inside the other (winding number > 1/2 of a vertex, where the other is
    closed). Groups are the connected components of the touching graph; the answer is
    (number of components) - (components in the largest group), so 0 means every part
    holds on to the rest. Pairs whose boxes (grown by tol * d) miss, and pairs already
    joined through others, are not tested.
    """
    if len(mesh.faces) == 0:
        return 0
    parts, eps = _components(mesh, tol)
    n = len(parts)
    if n == 1:
        return 0
    root = list(range(n))  # union-find over components

    def find(i: int) -> int:
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    # biggest parts first: they are the likeliest hubs, so later pairs are often joined
    order = sorted(range(n), key=lambda i: -len(parts[i].tri))
    for a, i in enumerate(order):
        for j in order[a + 1 :]:
            ri, rj = find(i), find(j)
            if ri != rj and _touches(parts[i], parts[j], eps):
                root[ri] = rj
    sizes = np.bincount([find(i) for i in range(n)])
    return int(n - sizes.max())


# ---------------------------------------------------------------------------------------------
# Drop test: a small rigid-body simulation against the plane z = 0
# ---------------------------------------------------------------------------------------------

GRAVITY = 9.81  # m/s^2; shapes are read as metres (unit-sphere shapes are ~1-2 m tall)


@dataclass(frozen=True)
class DropConfig:
    """Settings of the drop test (docs/paper-numbers.md#stability).

    The contact is a spring-damper per penetrating hull vertex, normalised by the number of
    such vertices (a contact patch: total normal stiffness k whatever the count, so a flat
    base of many coplanar vertices is as stiff as one corner and the explicit step stays
    stable). k is set so that the weight alone sinks the body by `sink` * height, and the
    damping ratio zeta from the restitution e: zeta = -ln e / sqrt(pi^2 + ln^2 e).
    Friction is regularised Coulomb, |F_t| = mu F_n |v_t| / sqrt(|v_t|^2 + slip^2).
    """

    drop: float = 0.05  # start with the lowest point this fraction of the height above the plane
    duration: float = 5.0  # s simulated at most
    dt: float = 2e-3  # s per semi-implicit Euler step (outcomes match 1e-3 on the tests) ...
    halvings: int = 3  # ... halved at most this often where a step makes energy (see _simulate)
    energy_slack: float = 0.05  # energy a run may gain (share of m g height) before it counts as blown up
    friction: float = 0.5  # Coulomb coefficient mu
    restitution: float = 0.2  # coefficient of restitution e of one bounce
    sink: float = 5e-4  # static penetration under the weight, as a fraction of the height
    slip: float = 1e-2  # friction regularisation speed, as a fraction of sqrt(g * height)
    tolerance: float = 0.02  # stable when |height after - height before| <= tolerance * before
    max_contacts: int = 256  # hull vertices used as contact points at most (FPS keeps extremes)
    rest_speed: float = 1e-3  # settled when all speeds stay below this * sqrt(g * height) ...
    rest_time: float = 0.3  # ... for this long (s)


@dataclass
class _Body:
    """Rigid body: mass m, inertia about the centre of mass in the body frame, and the
    contact points (convex hull vertices) relative to the centre of mass."""

    mass: float
    inertia: np.ndarray  # (3,3) body frame
    points: np.ndarray  # (N,3) body frame
    source: str  # "solid" (the mesh) or "convex_hull" (fallback for non-closed meshes)


def _oriented_closed(faces: np.ndarray) -> bool:
    """Every directed edge a->b occurs once and its reverse b->a occurs too: closed and
    consistently wound (what a solid's mass integrals need)."""
    a = faces.reshape(-1)
    b = faces[:, [1, 2, 0]].reshape(-1)
    base = int(faces.max()) + 1
    fwd = np.sort(a * base + b)
    if len(fwd) and np.any(fwd[1:] == fwd[:-1]):
        return False
    return bool(np.array_equal(fwd, np.sort(b * base + a)))


def _mass_properties(mesh: trimesh.Trimesh) -> tuple[float, np.ndarray, np.ndarray, str]:
    """(mass, centre of mass, inertia about it, source) at unit density.

    A closed, consistently wound mesh (after welding coincident vertices) with positive
    volume uses its own solid mass properties (overlapping closed parts count twice:
    uniform density per part). Anything else uses its convex hull's solid: a documented
    approximation that keeps the centre of mass inside the support geometry.
    """
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    diag = float(np.linalg.norm(vertices.max(0) - vertices.min(0)))
    if _oriented_closed(_merged_ids(vertices, WELD * 1e-3 * diag)[faces]):
        props = trimesh.triangles.mass_properties(vertices[faces], density=1.0)
        if props.volume > 0:
            return float(props.mass), np.asarray(props.center_mass), props.inertia, "solid"
    props = mesh.convex_hull.mass_properties
    return float(props.mass), np.asarray(props.center_mass), props.inertia, "convex_hull"


def _rigid_body(mesh: trimesh.Trimesh, cfg: DropConfig) -> tuple[_Body, np.ndarray]:
    """The body and its centre of mass in the mesh frame."""
    mass, com, inertia, source = _mass_properties(mesh)
    hull = np.asarray(mesh.convex_hull.vertices, dtype=np.float64)
    if len(hull) > cfg.max_contacts:
        from geocode.points import farthest_point_sampling

        hull = hull[farthest_point_sampling(hull, cfg.max_contacts)]
    return _Body(mass, inertia, hull - com, source), com


def _rotation(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for 3-vectors (np.cross costs ~10 us a call; this runs every step)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def _contact_wrench(
    arm: np.ndarray,
    depth: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    k: float,
    c: float,
    mu: float,
    slip: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Total force and torque (about the centre of mass) from penetrating points.

    arm (n,3) world offsets of the points from the centre of mass, depth (n,) > 0. Point
    velocity u = v + w x arm; normal force F_n = max(0, k depth - c u_z) / n; friction
    F_t = -mu F_n u_t / sqrt(|u_t|^2 + slip^2); torque = sum arm x F.
    """
    n = len(depth)
    ux = v[0] + w[1] * arm[:, 2] - w[2] * arm[:, 1]
    uy = v[1] + w[2] * arm[:, 0] - w[0] * arm[:, 2]
    uz = v[2] + w[0] * arm[:, 1] - w[1] * arm[:, 0]
    fn = np.maximum(k * depth - c * uz, 0.0) / n
    scale = -mu * fn / np.sqrt(ux * ux + uy * uy + slip * slip)
    fx, fy = scale * ux, scale * uy
    ax, ay, az = arm[:, 0], arm[:, 1], arm[:, 2]
    force = np.array([fx.sum(), fy.sum(), fn.sum()])
    torque = np.array(
        [(ay * fn - az * fy).sum(), (az * fx - ax * fn).sum(), (ax * fy - ay * fx).sum()]
    )
    return force, torque


def _simulate(body: _Body, height: float, start_z: float, cfg: DropConfig) -> dict:
    """Semi-implicit (symplectic) Euler from rest at centre-of-mass height start_z.

    v += dt (F/m + g); w += dt I_w^-1 (tau - w x I_w w) with I_w = R I_b R^T;
    x += dt v; q += dt/2 (0, w) * q, renormalised. Stops early once every speed has stayed
    below rest_speed * sqrt(g h) for rest_time seconds.

    A body dropped from rest can only lose energy (the contacts damp, friction dissipates), so
    kinetic + potential energy above the start's (plus energy_slack * m g h) means the explicit
    step is too long for this body's contact stiffness (light shapes with a narrow support
    spin up and flip over in a few steps): the run stops with "unstable" set.
    """
    m, g, dt = body.mass, GRAVITY, cfg.dt
    k = m * g / (cfg.sink * height)
    zeta = -np.log(cfg.restitution) / np.sqrt(np.pi**2 + np.log(cfg.restitution) ** 2)
    c = 2 * zeta * np.sqrt(k * m)
    slip = cfg.slip * np.sqrt(g * height)
    rest = cfg.rest_speed * np.sqrt(g * height)
    inv_inertia = np.linalg.inv(body.inertia)
    x = np.array([0.0, 0.0, start_z])
    q = np.array([1.0, 0.0, 0.0, 0.0])
    v, w = np.zeros(3), np.zeros(3)
    steps, still, step = int(round(cfg.duration / dt)), 0, 0
    need_still = int(round(cfg.rest_time / dt))
    budget = m * g * (start_z + cfg.energy_slack * height)   # energy at rest at the start, and the slack
    unstable = False
    while step < steps:
        step += 1
        rot = _rotation(q)
        arm = body.points @ rot.T
        depth = -(x[2] + arm[:, 2])
        touching = depth > 0
        force = np.array([0.0, 0.0, -m * g])
        torque = np.zeros(3)
        if touching.any():
            f, t = _contact_wrench(arm[touching], depth[touching], v, w, k, c, cfg.friction, slip)
            force += f
            torque += t
        inertia_w = rot @ body.inertia @ rot.T
        v = v + dt * force / m
        w = w + dt * (rot @ inv_inertia @ rot.T) @ (torque - _cross(w, inertia_w @ w))
        x = x + dt * v
        q = q + 0.5 * dt * np.array(
            [
                -w[0] * q[1] - w[1] * q[2] - w[2] * q[3],
                w[0] * q[0] + w[1] * q[3] - w[2] * q[2],
                w[1] * q[0] + w[2] * q[1] - w[0] * q[3],
                w[2] * q[0] + w[0] * q[2] - w[1] * q[1],
            ]
        )
        q /= np.sqrt(q @ q)
        energy = 0.5 * m * (v @ v) + 0.5 * w @ (inertia_w @ w) + m * g * x[2]
        if not energy <= budget:   # also NaN
            unstable = True
            break
        slow = touching.any() and np.abs(v).max() < rest and np.abs(w).max() * height < rest
        still = still + 1 if slow else 0
        if still >= need_still:
            break
    arm = body.points @ _rotation(q).T
    return {
        "steps": step,
        "sim_time": step * dt,
        "settled": still >= need_still,
        "unstable": unstable,
        "x": x,
        "q": q,
        "arm": arm,
    }


def _simulate_stably(body: _Body, height: float, start_z: float, cfg: DropConfig) -> tuple[dict, DropConfig]:
    """`_simulate`, again at half the step while a run blows up (at most cfg.halvings times):
    its outcome and the settings it ran with."""
    for _ in range(cfg.halvings):
        out = _simulate(body, height, start_z, cfg)
        if not out["unstable"]:
            return out, cfg
        cfg = replace(cfg, dt=cfg.dt / 2)
    return _simulate(body, height, start_z, cfg), cfg


def _drop(mesh: trimesh.Trimesh, cfg: DropConfig) -> dict:
    """The dynamic half of the drop test (no loose-part check)."""
    body, _ = _rigid_body(mesh, cfg)
    z = body.points[:, 2]
    before = float(z.max() - z.min())
    if not before > 0:
        raise ValueError("drop_test: the shape has zero height")
    com_before = float(-z.min())  # centre of mass above the lowest point
    out, cfg = _simulate_stably(body, before, com_before + cfg.drop * before, cfg)
    za = out["arm"][:, 2]
    after, com_after = float(za.max() - za.min()), float(-za.min())
    change = abs(after - before) / before
    com_change = abs(com_after - com_before) / before
    up = _rotation(out["q"])[:, 2]
    return {
        "standing": bool(change <= cfg.tolerance and com_change <= cfg.tolerance),
        "height_before": before,
        "height_after": after,
        "height_change": change,
        "com_height_before": com_before,
        "com_height_after": com_after,
        "com_height_change": com_change,
        "tilt_deg": float(np.degrees(np.arccos(np.clip(up[2], -1.0, 1.0)))),
        "settled": out["settled"],
        "sim_time": out["sim_time"],
        "steps": out["steps"],
        "dt": cfg.dt,
        "mass_source": body.source,
    }


def drop_test(mesh: trimesh.Trimesh, cfg: DropConfig | None = None, tol: float = 1e-3) -> dict:
    """Loose parts plus a drop onto the plane z = 0 (docs/paper-numbers.md#stability); z is up.

    The body starts at rest, as given, with its lowest point cfg.drop * height above the
    plane, and runs for cfg.duration s (or until settled). Height = z-extent of the shape
    (max z - min z of its convex-hull vertices, the same as the mesh's); the centre-of-mass
    height is measured above the lowest point. Stable when there are no loose parts and
    both |height_after - height_before| and |com_after - com_before| are at most
    cfg.tolerance * height_before; the second catches a shape that turns over onto a side
    of the same extent (e.g. upside down). Returns stable, loose_parts, height_before,
    height_after, height_change (relative), com_height_*, tilt_deg (angle of the body's up
    axis from z), settled, sim_time, steps, dt (the step used), mass_source.
    """
    cfg = cfg or DropConfig()
    loose = loose_parts(mesh, tol)
    out = _drop(mesh, cfg)
    return {"stable": bool(loose == 0 and out.pop("standing")), "loose_parts": loose, **out}


def is_stable(mesh: trimesh.Trimesh, cfg: DropConfig | None = None, tol: float = 1e-3) -> bool:
    """drop_test(mesh)["stable"], without simulating shapes that have loose parts."""
    if loose_parts(mesh, tol) > 0:
        return False
    return _drop(mesh, cfg or DropConfig())["standing"]
