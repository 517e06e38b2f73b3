"""The pose of a user's shape in the programs' frame: Z up, unit sphere, front searched.

The programs build furniture standing on the floor at z = 0, Z up, the chair's backrest at +y
(so a chair faces -y), and the dataset scales every shape into the unit sphere about its
bounding-box centre (meshio.normalise_unit_sphere). A user's file comes in any of those
respects wrong: Y-up (glTF, most asset tools) or Z-up (ModelNet, scans), sometimes upside
down, in metres or millimetres, far from the origin, facing any way.

- `up_axis(points)` picks which of the six signed axes of the file is up (`--up auto`).
- `turns(k)` are the k rotations about the up axis that the front search tries.
- `normalise(points, robust=...)` centres and scales as the dataset does, or robustly for
  partial scans; `Pose` keeps the whole input -> canonical transform as a 4x4 matrix and its
  inverse, so that a result can be written back over the user's scan (`to_input_frame`).

Rotations act on row points as `points @ R.T` (R maps the input's axes to canonical ones).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError, cKDTree

from geocode.errors import UserError
from geocode.seeds import generator

AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
FEATURE_POINTS = 3000      # up_axis looks at this many points (subsampled, seeded)
TRIM = 0.5                 # percent cut at each end of a range: outliers do not set it
SLAB = 0.06                # the bottom or top slab: this share of the height
HEIGHT_BINS = 8            # mass profile along a candidate up axis
ROBUST_RADIUS = 99.0       # percentile of the radii that is 1 in the robust normalisation
LEVEL_POINTS = 8000        # level_turn looks at this many points (subsampled, seeded) ...
LEVEL_NEIGHBOURS = 10      # ... and fits a plane to each one's nearest
SQUARE_GAIN = 0.02         # square_rotation turns a file only when that squares it this much more
TILT_GAIN = 0.04           # ... and find_pose tilts a candidate's up axis by it only for this much


def axis_rotation(label: str) -> np.ndarray:
    """The rotation (3x3) that turns the input's signed axis `label` ("+y", "-z", "y", ...)
    to +z by the shortest turn; "+y" is the quarter turn about X, (x, y, z) -> (x, -z, y),
    that `--up y` has always meant."""
    given = label
    label = label.strip().lower()
    label = label if label[:1] in "+-" else "+" + label
    table = {
        "+z": [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
        "-z": [[1, 0, 0], [0, -1, 0], [0, 0, -1]],
        "+y": [[1, 0, 0], [0, 0, -1], [0, 1, 0]],
        "-y": [[1, 0, 0], [0, 0, 1], [0, -1, 0]],
        "+x": [[0, 0, -1], [0, 1, 0], [1, 0, 0]],
        "-x": [[0, 0, 1], [0, 1, 0], [-1, 0, 0]],
    }
    if label not in table:
        raise UserError(f"--up {given}", "not an axis", "give auto, x, y, z, -x, -y or -z")
    return np.array(table[label], dtype=np.float64)


def axis_rotations() -> list[np.ndarray]:
    """The 24 rotations that map coordinate axes to coordinate axes (signed permutations
    with determinant +1)."""
    out = []
    for perm in ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)):
        for signs in np.ndindex(2, 2, 2):
            m = np.zeros((3, 3))
            m[range(3), perm] = [1 - 2 * s for s in signs]
            if np.linalg.det(m) > 0:
                out.append(m)
    return out


def turns(k: int = 4) -> list[np.ndarray]:
    """k rotations about Z by 360/k degrees each, the first the identity: the candidates of
    the front search (4 for furniture drawn square to its axes; 8 or 12 for the odd scan)."""
    if k < 1:
        raise ValueError("turns: k must be at least 1")
    return [turn_z(360.0 * i / k) for i in range(k)]


# -- up axis ------------------------------------------------------------------------------------

def _hull_area(flat: np.ndarray) -> float:
    if len(flat) < 3:
        return 0.0
    try:
        return float(ConvexHull(flat).volume)   # in 2D, Qhull's volume is the area
    except QhullError:  # collinear points
        return 0.0


def _asymmetry(points: np.ndarray, tree: cKDTree, flip: np.ndarray, centre: np.ndarray,
               scale: float) -> float:
    """How unlike its image under `flip` (a diagonal of +-1: a mirror or a half turn about
    `centre`) the cloud is: trimmed mean distance from the image's points to the nearest
    point, over `scale` (the worst tenth, outliers and missing parts, does not count)."""
    d, _ = tree.query((points - centre) @ flip + centre)
    d = np.sort(d)[: int(0.9 * len(d))]
    return float(d.mean() / scale)


def _roundness(flat: np.ndarray, t: np.ndarray, scale: float) -> float:
    """How far the cross-sections normal to an axis are from circles: in each of
    HEIGHT_BINS slabs a circle is fitted by least squares (Kasa: x^2 + y^2 = A x + B y + C),
    which holds for part of a circle too, so a one-sided scan of a vase still reads round;
    the median distance to the circle over `scale`, averaged over the slabs."""
    residuals = []
    for k in range(HEIGHT_BINS):
        xy = flat[(t >= k / HEIGHT_BINS) & (t < (k + 1) / HEIGHT_BINS)]
        if len(xy) < 20:
            continue
        xy = xy - xy.mean(0)
        design = np.column_stack([xy, np.ones(len(xy))])
        (a, b, c), *_ = np.linalg.lstsq(design, (xy ** 2).sum(1), rcond=None)
        radius = np.sqrt(max(c + a * a / 4 + b * b / 4, 0.0))
        residuals.append(np.median(np.abs(np.linalg.norm(xy - [a / 2, b / 2], axis=1) - radius)))
    return float(np.mean(residuals)) / scale if residuals else 1.0


def _filled(flat: np.ndarray, mid: np.ndarray) -> float:
    """Share of a slab's points in the inner half (by radius) of the slab about its centre:
    about 1/4 for a filled disc, 0 for a ring."""
    if len(flat) < 10:
        return 0.0
    r = np.linalg.norm(flat - np.median(flat, axis=0), axis=1)
    return float((r < 0.5 * np.percentile(r, 95)).mean())


def axis_features(points: np.ndarray) -> np.ndarray:
    """(6, F) cues per signed axis (order AXES), each taken as if that axis were up.

    Columns: 0 asymmetry across the axis, relative to the largest of the three (furniture
    is mirror-symmetric about vertical planes, rarely about the horizontal one); 1 asymmetry
    under a half turn about the axis, relative (tables, vases, lamps are symmetric about
    their up axis); 2 spread of the bottom slab minus that of the top (2D convex hull area of
    the slab's points over that of all points, seen along the axis: legs stand wide,
    backrests and lamp canopies end narrow); 3 share of points in the bottom slab minus the
    top (a floor contact is a few feet or a rim, a top is often a full surface); 4 height of
    the centre of mass (0 bottom .. 1 top) minus a half; 5 extent along the axis over the
    largest extent; 6 how far its cross-sections are from circles, relative (`_roundness`:
    vases, lamps, round tables turn about their up axis); 7 how filled the bottom slab is
    minus the top (`_filled`: a vase's foot is a disc, its mouth a ring); 8.. the share of points
    in each of HEIGHT_BINS heights, bottom first,
    minus the uniform share (where the mass lies: a table's top, a lamp's shade).
    """
    pts = np.asarray(points, dtype=np.float64)
    lo = np.percentile(pts, TRIM, axis=0)
    hi = np.percentile(pts, 100 - TRIM, axis=0)
    size = np.maximum(hi - lo, 1e-12)
    scale = size.max()
    mid = (lo + hi) / 2
    tree = cKDTree(pts)
    mirror = np.array([_asymmetry(pts, tree, np.diag(np.where(np.arange(3) == a, -1.0, 1.0)), mid, scale)
                       for a in range(3)])
    half = np.array([_asymmetry(pts, tree, np.diag(np.where(np.arange(3) == a, 1.0, -1.0)), mid, scale)
                     for a in range(3)])
    mirror, half = mirror / max(mirror.max(), 1e-12), half / max(half.max(), 1e-12)
    round_ = np.array([_roundness(np.delete(pts, a, axis=1),
                                  np.clip((pts[:, a] - lo[a]) / size[a], 0, 1), scale) for a in range(3)])
    round_ = round_ / max(round_.max(), 1e-12)
    rows = []
    for a in range(3):
        t = np.clip((pts[:, a] - lo[a]) / size[a], 0, 1)
        flat = np.delete(pts, a, axis=1)
        whole = max(_hull_area(flat), 1e-12)
        low, high = t < SLAB, t > 1 - SLAB
        spread = (_hull_area(flat[low]) - _hull_area(flat[high])) / whole
        share = low.mean() - high.mean()
        com = t.mean() - 0.5
        extent = size[a] / scale
        fill = _filled(flat[low], mid) - _filled(flat[high], mid)
        bins = np.histogram(t, HEIGHT_BINS, (0, 1))[0] / len(t) - 1 / HEIGHT_BINS
        rows.append([mirror[a], half[a], spread, share, com, extent, round_[a], fill, *bins])          # +axis up
        rows.append([mirror[a], half[a], -spread, -share, -com, extent, round_[a], -fill, *bins[::-1]])  # -axis up
    return np.array(rows)


# The cues of `axis_features`, by column (its docstring says what each measures), each read
# as if that axis were up: asymmetry across the axis and under a half turn about it, the
# bottom slab's spread, share of points and fill less the top's, the centre of mass's height,
# the extent along the axis, how far from round its cross-sections are, and the mass in each
# of HEIGHT_BINS heights.
CUES = ("mirror", "half_turn", "slab_spread", "slab_share", "mass_height", "extent", "roundness",
        "slab_fill", *(f"height_{k}" for k in range(HEIGHT_BINS)))

# The weight of each cue (in CUES' order) in an axis's score, for each domain ("": any shape):
# one set per domain, because the cues point opposite ways across domains (a table's mass is
# near its top, a hanging lamp's near its bottom). They are what `python -m geocode.bench.up fit`
# prints: a softmax over the six axes (weight decay 1e-2) fitted on program shapes, 20 random
# shapes a domain, each clean, cut as a scan (no underside, one side missing), noisy (1% noise,
# 2% outliers) and both, each turned by 3 of the 24 axis rotations, rescaled and moved. Refit
# them when the cues or the programs change, and compare with `... measure` and `... real`.
WEIGHTS = {
    "": (1.58, -1.29, 0.58, -1.46, 0.52, 0.85, -1.77, -0.74, -0.02, -0.11, -0.21, 0.37, -0.58, -0.65, 0.02, 1.18),
    "chair": (1.10, -1.07, 1.85, 0.23, -0.16, 1.76, -2.11, -2.08, -0.07, -0.48, 0.20, 1.31, -0.32, -0.40, -0.10, -0.15),
    "vase": (1.08, -1.54, 0.56, 0.67, -0.28, -1.30, -3.00, -0.36, 1.06, -0.44, -0.51, 0.40, -0.53, -0.25, 0.20, 0.06),
    "table": (1.66, -1.61, -0.91, -1.25, 1.36, -0.45, -0.42, 0.72, -0.77, -0.38, -0.21, -0.29, -0.30, -0.17, 0.62,
              1.49),
    "ceiling_lamp": (1.80, -1.66, -0.39, -0.90, -1.64, 0.25, -1.29, 0.11, 1.55, 1.44, 0.47, -0.45, -0.72, -1.08, -1.71,
                     0.50),
    "cabinet": (1.43, 0.87, 0.85, -2.18, 1.76, 2.82, 0.19, -0.01, -0.95, -0.54, -0.77, -0.19, -0.06, 0.23, 0.87, 1.42),
}


def up_features(points: np.ndarray, seed: int = 0) -> np.ndarray:
    """`axis_features` of the cloud first squared to the file's axes (`square_rotation`): a
    file turned about its up axis off the axes (a cabinet at 137 degrees) would otherwise show
    its diagonals along the other two axes, and their extents, slabs and mirror planes would
    read as a box lying on its side."""
    pts = np.asarray(points, dtype=np.float64)
    return axis_features(pts @ square_rotation(pts, seed).T)


def up_candidates(points: np.ndarray, domain: str | None = None, k: int = 1, seed: int = 0) -> list[str]:
    """The `k` likeliest up axes ("+y", ...), best first.

    Each signed axis is scored by `up_features` @ `WEIGHTS[domain]` (the domain's own
    weights where it has them, else the general ones). Uses a seeded subsample of
    FEATURE_POINTS points, and percentile ranges, so a million-point scan costs as much as a
    small one and a few outliers do not move the slabs."""
    scores = up_features(_feature_sample(points, seed), seed) @ np.asarray(WEIGHTS.get(domain or "", WEIGHTS[""]))
    return [AXES[i] for i in np.argsort(-scores, kind="stable")[:k]]


def _feature_sample(points: np.ndarray, seed: int) -> np.ndarray:
    """The seeded subsample of FEATURE_POINTS points that the up axis is judged on."""
    pts = np.asarray(points, dtype=np.float64)
    if len(pts) > FEATURE_POINTS:
        pts = pts[generator(seed, "pose", "up").choice(len(pts), FEATURE_POINTS, replace=False)]
    return pts


def up_axis(points: np.ndarray, domain: str | None = None, seed: int = 0) -> tuple[np.ndarray, str]:
    """The rotation (3x3) that brings the input's likeliest up axis to +z, and that axis."""
    label = up_candidates(points, domain, 1, seed)[0]
    return axis_rotation(label), label


# -- normalisation and the full transform -------------------------------------------------------

def normalise(points: np.ndarray, robust: bool = False) -> tuple[np.ndarray, np.ndarray, float]:
    """(points in the unit sphere, centre, scale) with normalised = (points - centre) / scale.

    Plain (the dataset's way): centre of the bounding box, farthest point at 1. Robust, for
    scans with outliers and missing parts: centre of the bounding box of the 1st..99th
    percentiles per axis, and the ROBUST_RADIUS percentile of the radii at 1 (a few stray
    points can neither pull the centre nor shrink the shape; the shape may reach a little
    beyond the sphere)."""
    pts = np.asarray(points, dtype=np.float64)
    if robust:
        centre = (np.percentile(pts, 1, axis=0) + np.percentile(pts, 99, axis=0)) / 2
        scale = float(np.percentile(np.linalg.norm(pts - centre, axis=1), ROBUST_RADIUS))
    else:
        centre = (pts.min(axis=0) + pts.max(axis=0)) / 2
        scale = float(np.linalg.norm(pts - centre, axis=1).max())
    if not scale > 0:
        raise UserError("input", "all points coincide", "give a shape with some extent")
    return (pts - centre) / scale, centre, scale


@dataclass
class Pose:
    """Input frame -> canonical frame: canonical = rotation @ (x - centre) / scale, with
    `centre` in the input's frame; `up` the input's axis that became +z, `turn` the degrees
    turned about it after."""

    rotation: np.ndarray
    centre: np.ndarray
    scale: float
    up: str = "+z"
    turn: float = 0.0

    @property
    def matrix(self) -> np.ndarray:
        """The 4x4 homogeneous input -> canonical transform."""
        m = np.eye(4)
        m[:3, :3] = self.rotation / self.scale
        m[:3, 3] = -m[:3, :3] @ self.centre
        return m

    @property
    def inverse(self) -> np.ndarray:
        """The 4x4 canonical -> input transform (puts a result back over the user's scan)."""
        m = np.eye(4)
        m[:3, :3] = self.rotation.T * self.scale
        m[:3, 3] = self.centre
        return m

    def to_canonical(self, points: np.ndarray) -> np.ndarray:
        return apply(self.matrix, points)

    def to_input_frame(self, points: np.ndarray) -> np.ndarray:
        return apply(self.inverse, points)

    def turned(self, rotation_z: np.ndarray, degrees: float) -> Pose:
        """The same pose followed by a turn about the canonical Z (one of `turns`)."""
        return Pose(rotation_z @ self.rotation, self.centre, self.scale, self.up, degrees)


def apply(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N, 3) points moved by a 4x4 matrix."""
    pts = np.asarray(points, dtype=np.float64)
    return pts @ matrix[:3, :3].T + matrix[:3, 3]


def _normals(points: np.ndarray, seed: int) -> np.ndarray:
    """(N, 3) unit surface normals (sign arbitrary) of a seeded subsample of LEVEL_POINTS
    points, from the plane through each one's LEVEL_NEIGHBOURS nearest, so a cloud needs no
    faces; the points are spread uniformly over the area, so each normal stands for an equal
    share of it. Empty for a cloud too small to have planes."""
    pts = np.asarray(points, dtype=np.float64)
    if len(pts) > LEVEL_POINTS:
        pts = pts[generator(seed, "pose", "level").choice(len(pts), LEVEL_POINTS, replace=False)]
    if len(pts) <= LEVEL_NEIGHBOURS:
        return np.zeros((0, 3))
    near = pts[cKDTree(pts).query(pts, k=LEVEL_NEIGHBOURS)[1]]
    near -= near.mean(axis=1, keepdims=True)
    return np.linalg.eigh(np.einsum("nki,nkj->nij", near, near))[1][:, :, 0]


def _level_degrees(normals: np.ndarray, weights: np.ndarray | None = None) -> float:
    """`level_turn` of these normals (about +Z), each counting `weights` (default 1)."""
    z = normals[:, 0] + 1j * normals[:, 1]
    h2 = np.abs(z) ** 2
    moment = np.sum(np.where(h2 > 1e-12, z ** 4 / np.maximum(h2, 1e-12), 0.0)
                    * (1.0 if weights is None else weights))
    degrees = float(np.degrees(np.angle(moment) / 4)) if abs(moment) > 0 else 0.0
    return degrees


def level_turn(points: np.ndarray, seed: int = 0,
               faces: tuple[np.ndarray, np.ndarray] | None = None) -> float:
    """The turn (degrees, in (-45, 45]) about +Z that squares the surface to the axes: most
    faces of furniture (seat, back, doors, legs) face along two horizontal axes at right
    angles, so the fourth circular moment of the surface normals' horizontal parts,
    sum h^2 e^(4 i phi) (h, phi: their length and direction; `_normals`, near-horizontal
    faces count little), points along one of them. Turning the input by minus it first makes
    `reconstruct` blind to how the input was turned: any turn of the same shape reaches the
    same frame up to a quarter-turn, which the front search covers. Every turn is taken as
    found, however small: leaving inputs within a degree of square as they are parted a
    shape whose square directions lie a little off (a lamp's arms: 0.01 degrees) from the
    same shape turned, which was turned by the whole angle (docs/design.md#pose-and-sampling).
    `faces`: (normals, areas) of a mesh's faces in the frame
    of `points`, used instead of normals estimated from the points: exact, where the
    estimated ones leave up to 2 degrees (a turned chair then differs from the unturned one
    by a quarter-turn to float precision, and a square one is left square)."""
    if faces is not None:
        return _level_degrees(*faces)
    normals = _normals(points, seed)
    return _level_degrees(normals) if len(normals) else 0.0


def square_rotation(points: np.ndarray, seed: int = 0) -> np.ndarray:
    """The rotation (3x3) that squares the surface to all three axes before the up axis is
    known: the level turn about whichever file axis squares it best, where "square" is the
    mean of n_x^4 + n_y^4 + n_z^4 over the surface normals (1 when every face looks along an
    axis, 0.6 for normals spread evenly). Files keep their up axis on one of their own axes
    and may turn the shape about it; the level turn about that axis undoes the turn. The
    identity (a file already square, a round vase) unless a turn gains SQUARE_GAIN."""
    normals = _normals(points, seed)
    best, best_square = np.eye(3), -np.inf
    if not len(normals):
        return best
    for axis in (None, "+x", "+y", "+z"):
        rotation = np.eye(3)
        if axis is not None:
            to_z = axis_rotation(axis)
            rotation = to_z.T @ turn_z(-_level_degrees(normals @ to_z.T)) @ to_z
        square = float(((normals @ rotation.T) ** 4).sum(axis=1).mean()) - (0 if axis is None else SQUARE_GAIN)
        if square > best_square:
            best, best_square = rotation, square
    return best


def _squareness(normals: np.ndarray, rotation: np.ndarray) -> float:
    """`square_rotation`'s measure: the mean of n_x^4 + n_y^4 + n_z^4 over the turned normals."""
    return float(((normals @ rotation.T) ** 4).sum(axis=1).mean()) if len(normals) else 0.0


def _up_squareness(normals: np.ndarray, rotation: np.ndarray) -> float:
    """How squarely the surface faces along the up axis that `rotation` brings to +Z: the mean
    of n_z^4 over the normals (1: every face looks up or down)."""
    return float(np.mean((normals @ rotation[2]) ** 4)) if len(normals) else 0.0


def find_pose(points: np.ndarray, up: str = "auto", domain: str | None = None, robust: bool = False,
              seed: int = 0, mesh=None, squared: bool | None = None) -> Pose:
    """The pose that brings `points` (input frame, surface samples) Z-up into the unit
    sphere: up axis found (`up="auto"`, with `domain`'s weights) or given ("y", "-z", ...),
    turned about it by minus `level_turn` (the pose's `turn`), then centred and scaled by
    `normalise` in the turned frame (the bounding box taken Z-up, as the dataset's is).
    `mesh` (a trimesh.Trimesh; `points` its surface samples): its vertices set centre and
    scale instead, so that it is normalised exactly as meshio.normalise_unit_sphere does
    (its samples fall a little inside its vertices' box), and its faces the level turn.
    `squared` (the default with "auto"; `up` then one of `up_candidates`): the axis is one of the
    cloud squared by `square_rotation`, as the up
    features judged it; where that squares it about another axis than `up` (a cabinet turned
    137 degrees about its z, `up` its x), the shape is squared first, so that a candidate
    other than the true up still lays the shape square on a side, as it would unturned. Only
    where that squares the up axis itself (`_up_squareness`) or the whole surface by at least
    TILT_GAIN: a vase whose sloping walls square a little better tilted (0.02) stays upright,
    a cabinet turned off its axes (0.05-0.26) is laid square."""
    pts = np.asarray(points, dtype=np.float64)
    rotation, label = up_axis(pts, domain, seed) if up == "auto" else (axis_rotation(up), up)
    if squared or (squared is None and up == "auto"):
        sample = _feature_sample(pts, seed)
        square = square_rotation(sample, seed)
        fixed = np.isclose(np.diag(square), 1.0)
        if not fixed.all() and not fixed[int(np.argmax(np.abs(rotation[2])))]:
            normals = _normals(sample, seed)
            if (_up_squareness(normals, rotation @ square) > _up_squareness(normals, rotation)
                    or _squareness(normals, square) - _squareness(normals, np.eye(3)) >= TILT_GAIN):
                rotation = rotation @ square
    faces = None if mesh is None else (np.asarray(mesh.face_normals) @ rotation.T, np.asarray(mesh.area_faces))
    turn = -level_turn(pts @ rotation.T, seed, faces)
    rotation = turn_z(turn) @ rotation
    frame = pts if mesh is None else np.asarray(mesh.vertices, dtype=np.float64)
    _, centre_rot, scale = normalise(frame @ rotation.T, robust)
    return Pose(rotation, rotation.T @ centre_rot, scale, label if label[:1] in "+-" else "+" + label,
                turn)


def turn_z(degrees: float) -> np.ndarray:
    """The rotation (3x3) by `degrees` about +Z."""
    a = np.radians(degrees)
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
