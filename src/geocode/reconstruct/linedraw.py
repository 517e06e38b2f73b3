"""A fast line drawing of a mesh, as the dataset's Freestyle sketches look, and a distance
between two drawings; pure numpy (and scipy's distance transform), no Blender.

The fit to a drawing (`geocode.reconstruct.sketchfit`) renders hundreds of candidate shapes, and
Freestyle takes ~0.1-0.4 s a view; this renderer takes a few milliseconds. It reproduces
what `geocode.blender.sketch.SketchRenderer` draws:

- the same camera: orthographic, looking at the origin from `camera_location` (azimuth about
  +Z, 0 = from -Y, elevation above the horizon), +Z up on the image, the image spanning
  2 * MARGIN unit-sphere radii (blender/scene.py); plus, for drawings that are not framed
  like the dataset's, a roll in the image plane, a scale about the image centre and a shift;
- the same edges: silhouettes (an edge between a face turned towards the camera and one
  turned away; flat faces, as Freestyle with `use_smoothness` off), creases (the normals of
  the two faces more than 180 - CREASE_ANGLE degrees apart, Freestyle's test
  `n_a . n_b <= cos(pi - crease_angle)`), borders (an edge of one face), and edges of more
  than two faces (drawn like creases);
- visible parts only: a z-buffer of every triangle facing the camera (the nearest surface of a
  closed solid always does) at the image's resolution; a point of an
  edge is visible where it is no deeper than the z-buffer's deepest value in its 3x3 pixel
  neighbourhood plus DEPTH_TOLERANCE pixels (the neighbourhood keeps an edge visible next to
  the steep faces it bounds, whose depth at a pixel centre is nearer than the edge's);
- strokes about 2 px wide: each point along a visible edge (every half pixel) inks the 2 x 2
  pixels around it.

`drawing_distance` compares two drawings through distance transforms (see its docstring).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

MARGIN = 1.05            # image half-width in unit-sphere radii (= blender/scene.py's MARGIN)
SIZE = 224               # the sketches' size
CREASE_ANGLE = 134.43    # degrees (= blender/sketch.py's CREASE_ANGLE, Freestyle's default)
DEPTH_TOLERANCE = 0.5    # px of depth an edge point may lie behind the z-buffer and show
WIDTH = 1                # px: the strokes' width (1 or 2)
STEP = 0.5               # px between the points drawn along an edge
TRUNCATE = 8.0           # px: `drawing_distance` counts no stroke pixel as farther than this


@dataclass(frozen=True)
class View:
    """A camera on the unit sphere's shape: `azimuth` degrees about +Z (0 = looking from -Y,
    positive towards +X) and `elevation` degrees above the horizon, as blender/scene.py's
    Camera; then the image turned by `roll` degrees (anticlockwise), scaled by `scale` about
    its centre and shifted by `offset` (x right, y down) pixels at 224 px."""

    azimuth: float = 35.0
    elevation: float = 30.0
    roll: float = 0.0
    scale: float = 1.0
    offset: tuple[float, float] = (0.0, 0.0)

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, forward) unit vectors of the camera in the world: forward points from
        the camera to the origin; right = forward x Z, up = right x forward (Blender's
        `to_track_quat('-Z', 'Y')`: the camera's Y stays as near +Z as it can); then rolled."""
        az, el = math.radians(self.azimuth), math.radians(self.elevation)
        location = np.array([math.cos(el) * math.sin(az), -math.cos(el) * math.cos(az), math.sin(el)])
        forward = -location
        right = np.cross(forward, [0.0, 0.0, 1.0])
        norm = np.linalg.norm(right)
        right = right / norm if norm > 1e-9 else np.array([math.cos(az), math.sin(az), 0.0])
        up = np.cross(right, forward)
        c, s = math.cos(math.radians(self.roll)), math.sin(math.radians(self.roll))
        return c * right + s * up, -s * right + c * up, forward

    def project(self, vertices: np.ndarray, size: int = SIZE) -> tuple[np.ndarray, np.ndarray]:
        """(pixel coordinates (N, 2) as (x right, y down) with pixel (i, j)'s centre at
        (i + 0.5, j + 0.5), depths (N,) in the same pixels, nearer smaller)."""
        right, up, forward = self.axes()
        k = self.scale * size / (2 * MARGIN)
        v = np.asarray(vertices, dtype=np.float64)
        shift = np.asarray(self.offset, dtype=np.float64) * size / SIZE
        xy = np.stack([size / 2 + k * (v @ right) + shift[0],
                       size / 2 - k * (v @ up) + shift[1]], axis=1)
        return xy, k * (v @ forward)

    def to_dict(self) -> dict:
        return {"azimuth": round(self.azimuth % 360, 2), "elevation": round(self.elevation, 2),
                "roll": round(self.roll, 2), "scale": round(self.scale, 4),
                "offset": [round(float(o), 2) for o in self.offset]}


class Outline:
    """A triangle mesh's edges, sorted once into what any view draws (creases, borders,
    edges of more than two faces) and what a view may draw (silhouettes: edges of two faces),
    with the face normals that decide a silhouette."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, crease_angle: float = CREASE_ANGLE):
        self.vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces, dtype=np.int64)
        v = self.vertices
        normals = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
        area = np.linalg.norm(normals, axis=1)
        keep = area > 1e-12 * max(1.0, float(area.max(initial=0.0)))
        self.faces, normals, area = faces[keep], normals[keep], area[keep]
        self.normals = normals / area[:, None]
        self.edges, self.pairs, fixed = self._sort_edges(crease_angle)
        self.fixed = fixed        # edges every view draws (if visible)

    def _sort_edges(self, crease_angle: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(edges (E, 2), their two faces (E, 2) (-1 where not two), whether always drawn (E,))."""
        f = self.faces
        half = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        owner = np.tile(np.arange(len(f)), 3)
        n = max(len(self.vertices), 1)
        keys, inverse, counts = np.unique(half[:, 0] * n + half[:, 1], return_inverse=True,
                                          return_counts=True)   # one integer per edge: fast
        edges = np.stack([keys // n, keys % n], axis=1)
        order = np.argsort(inverse, kind="stable")
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        two = counts == 2
        pairs = np.full((len(edges), 2), -1, dtype=np.int64)
        pairs[two, 0] = owner[order[first[two]]]
        pairs[two, 1] = owner[order[first[two] + 1]]
        cos_limit = math.cos(math.pi - math.radians(crease_angle))
        dots = np.einsum("ij,ij->i", self.normals[pairs[two, 0]], self.normals[pairs[two, 1]])
        crease = np.zeros(len(edges), dtype=bool)
        crease[two] = dots <= cos_limit
        return edges, pairs, crease | ~two


def zbuffer(xy: np.ndarray, depth: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """(size, size) nearest depth of the triangles at each pixel centre (inf: none).

    Scanlines, all triangles at once. A triangle's barycentric coordinates are affine in the
    pixel centre (x, y): (l_a, l_b) = M^-1 ((x, y) - c) with M = [a - c, b - c], and so is
    its depth z = z_c + l_a (z_a - z_c) + l_b (z_b - z_c). On each pixel row of its bounding
    box the three conditions l_a >= 0, l_b >= 0, 1 - l_a - l_b >= 0 (less a 1e-6 slack, so
    that the edges the mesh's triangles share leave no cracks) are each a bound on x, which
    gives the row's run of covered pixels; only those are generated."""
    a, b, c = xy[faces[:, 0]], xy[faces[:, 1]], xy[faces[:, 2]]
    lo = np.clip(np.ceil(np.minimum(np.minimum(a, b), c) - 0.5), 0, size).astype(np.int64)
    hi = np.clip(np.floor(np.maximum(np.maximum(a, b), c) - 0.5), -1, size - 1).astype(np.int64)
    ac, bc = a - c, b - c
    det = ac[:, 0] * bc[:, 1] - bc[:, 0] * ac[:, 1]
    tri = np.nonzero((hi[:, 0] >= lo[:, 0]) & (hi[:, 1] >= lo[:, 1]) & (np.abs(det) > 1e-9))[0]
    buffer = np.full(size * size, np.inf)
    if len(tri) == 0:
        return buffer.reshape(size, size)
    ac, bc, c, det = ac[tri], bc[tri], c[tri], det[tri]
    # conditions g_k = A_k x + B_k y + C_k >= 0 in pixel-centre coordinates, k = a, b, c
    A = np.stack([bc[:, 1], -ac[:, 1]], axis=1) / det[:, None]
    B = np.stack([-bc[:, 0], ac[:, 0]], axis=1) / det[:, None]
    C = -(A * c[:, :1] + B * c[:, 1:2])
    A, B = np.column_stack([A, -A.sum(1)]), np.column_stack([B, -B.sum(1)])
    C = np.column_stack([C, 1.0 - C.sum(1)]) + 1e-6
    zs = depth[faces[tri]]
    za, zb = zs[:, 0] - zs[:, 2], zs[:, 1] - zs[:, 2]
    Az, Bz = A[:, 0] * za + A[:, 1] * zb, B[:, 0] * za + B[:, 1] * zb
    Cz = C[:, 0] * za + C[:, 1] * zb + zs[:, 2] - 1e-6 * (za + zb)
    # one record per (triangle, pixel row)
    rows = hi[tri, 1] - lo[tri, 1] + 1
    r = np.repeat(np.arange(len(tri)), rows)
    y = lo[tri, 1][r] + (np.arange(len(r)) - np.repeat(np.cumsum(rows) - rows, rows)) + 0.5
    rest = B[r] * y[:, None] + C[r]                       # g_k = A_k x + rest_k
    Ar = A[r]
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = -rest / Ar
    low = np.max(np.where(Ar > 0, bound, -np.inf), axis=1)
    high = np.min(np.where(Ar < 0, bound, np.inf), axis=1)
    never = np.any((Ar == 0) & (rest < 0), axis=1)
    x0 = np.maximum(np.ceil(low - 0.5), lo[tri, 0][r])
    x1 = np.minimum(np.floor(high - 0.5), hi[tri, 0][r])
    run = np.where(never, 0, np.maximum(x1 - x0 + 1, 0)).astype(np.int64)
    # one record per covered pixel
    p = np.repeat(np.arange(len(r)), run)
    x = x0[p] + (np.arange(len(p)) - np.repeat(np.cumsum(run) - run, run))
    t = r[p]
    z = Az[t] * (x + 0.5) + (Bz[r] * y + Cz[r])[p]
    pixel = (y[p] - 0.5).astype(np.int64) * size + x.astype(np.int64)
    np.minimum.at(buffer, pixel, z)
    return buffer.reshape(size, size)


def edge_points(xy: np.ndarray, depth: np.ndarray, edges: np.ndarray,
                step: float = STEP) -> tuple[np.ndarray, np.ndarray]:
    """Points every `step` px along each edge (both ends included): (points (P, 2), depths (P,))."""
    a, za = xy[edges[:, 0]], depth[edges[:, 0]]
    d, dz = xy[edges[:, 1]] - a, depth[edges[:, 1]] - za       # per edge, not per point
    n = np.ceil(np.linalg.norm(d, axis=1) / step).astype(np.int64) + 1
    e = np.repeat(np.arange(len(edges)), n)
    t = (np.arange(len(e)) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(np.maximum(n - 1, 1), n)
    return a[e] + t[:, None] * d[e], za[e] + t * dz[e]


def strokes(outline: Outline, view: View, size: int = SIZE, width: int = WIDTH) -> np.ndarray:
    """(size, size) bool: the pixels inked by the visible lines of `outline` from `view`."""
    xy, depth = view.project(outline.vertices, size)
    facing = outline.normals @ view.axes()[2] < 0          # turned towards the camera
    pairs = outline.pairs
    two = pairs[:, 0] >= 0
    silhouette = np.zeros(len(pairs), dtype=bool)
    silhouette[two] = facing[pairs[two, 0]] != facing[pairs[two, 1]]
    drawn = outline.edges[outline.fixed | silhouette]
    points, z = edge_points(xy, depth, drawn, STEP * size / SIZE)
    # the nearest surface along a ray into a closed solid faces the camera, so the faces turned
    # away never set the z-buffer: half the triangles (the programs' parts are closed solids)
    buffer = ndimage.maximum_filter(zbuffer(xy, depth, outline.faces[facing], size), size=3, mode="nearest")
    inside = (points[:, 0] >= 0) & (points[:, 0] < size) & (points[:, 1] >= 0) & (points[:, 1] < size)
    col = np.clip(np.floor(points[:, 0]).astype(np.int64), 0, size - 1)
    row = np.clip(np.floor(points[:, 1]).astype(np.int64), 0, size - 1)
    visible = inside & (z <= buffer[row, col] + DEPTH_TOLERANCE * size / SIZE)
    return ink_points(points[visible], size, width)


def ink_points(points: np.ndarray, size: int, width: int = WIDTH) -> np.ndarray:
    """(size, size) bool: width 1 inks the pixel under each point, width 2 the 2 x 2 pixels
    whose centres are nearest it."""
    ink = np.zeros((size, size), dtype=bool)
    first = np.floor(points - (width - 1) / 2).astype(np.int64)
    for dx in range(width):
        for dy in range(width):
            x, y = first[:, 0] + dx, first[:, 1] + dy
            ok = (x >= 0) & (x < size) & (y >= 0) & (y < size)
            ink[y[ok], x[ok]] = True
    return ink


def render(mesh, view: View, size: int = SIZE) -> np.ndarray:
    """The line drawing of a mesh (vertices/faces attributes, or an `Outline`) from `view`:
    (size, size) float32, white 1, strokes 0, as `geocode.training_data.load_sketch` reads
    the dataset's sketches (less their leading channel axis)."""
    outline = mesh if isinstance(mesh, Outline) else Outline(mesh.vertices, mesh.faces)
    return np.where(strokes(outline, view, size), 0.0, 1.0).astype(np.float32)


# -- the distance between two drawings ---------------------------------------------------------

def stroke_mask(drawing: np.ndarray) -> np.ndarray:
    """The stroke pixels (darker than mid-grey) of a drawing (H, W) or (1, H, W), white 1."""
    drawing = np.asarray(drawing)
    if drawing.dtype == bool:
        return drawing
    return np.squeeze(drawing, axis=0) < 0.5 if drawing.ndim == 3 else drawing < 0.5


class DrawingDistance:
    """`drawing_distance` to one fixed target drawing, its distance transform built once."""

    def __init__(self, target: np.ndarray, truncate: float = TRUNCATE):
        self.mask = stroke_mask(target)
        self.truncate = truncate
        self.field = np.minimum(to_strokes(self.mask), truncate)

    def __call__(self, ink: np.ndarray) -> float:
        """The distance of a drawing (or its stroke mask, bool) to the target, in pixels."""
        ink = stroke_mask(ink)
        if not ink.any() or not self.mask.any():
            return float(self.truncate)
        ours = float(self.field[ink].mean())
        theirs = float(np.minimum(to_strokes(ink)[self.mask], self.truncate).mean())
        return (ours + theirs) / 2


def to_strokes(mask: np.ndarray) -> np.ndarray:
    """Each pixel's Euclidean distance (px) to the nearest stroke pixel (inf without any)."""
    if not mask.any():
        return np.full(mask.shape, np.inf)
    return ndimage.distance_transform_edt(~mask)


def drawing_distance(a: np.ndarray, b: np.ndarray, truncate: float = TRUNCATE) -> float:
    """The symmetric mean distance in pixels between the strokes of two drawings:

        d(A, B) = 1/2 [ mean_{p in A} min(D_B(p), t) + mean_{q in B} min(D_A(q), t) ]

    with D_X the distance transform of X's background (each pixel's distance to X's nearest
    stroke pixel) and t = `truncate` px. Both directions count: strokes of A that B lacks,
    and strokes of B that A lacks (one direction alone is minimised by drawing everything, or
    one line). Means over pixels, not sums, so that a drawing's ink quantity does not matter,
    only where it is. The truncation keeps a few extra strokes (hatching, a ground line, a
    stroke the renderer draws and Freestyle not) from dominating: each costs at most t per
    pixel. 0 for identical drawings; `truncate` when either is blank."""
    return DrawingDistance(b, truncate)(stroke_mask(a))
