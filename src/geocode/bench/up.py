"""The cue weights of `--up auto` (`geocode.reconstruct.pose.WEIGHTS`): fitted and measured on
program shapes (needs bpy).

    python -m geocode.bench.up fit            # prints WEIGHTS for geocode/reconstruct/pose.py
    python -m geocode.bench.up measure        # accuracy on fresh shapes, 6 up directions
    python -m geocode.bench.up measure turned # the same, each also turned about its up
    python -m geocode.bench.up real DIR       # accuracy on DIR/<domain>/<file> (README's up)

Shapes: random parameters (seeds FIT_SEEDS for fitting, MEASURE_SEEDS for measuring, so the
measure is on shapes the fit never saw), SURFACE_POINTS surface points, then turned, rescaled,
moved and perturbed as scans are (`perturb`). The committed WEIGHTS are what `fit` prints.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from geocode.reconstruct import pose

DOMAINS = ("chair", "vase", "table", "ceiling_lamp", "cabinet")
KINDS = ("clean", "crop", "noise", "all")
FIT_SEEDS = range(1000, 1020)       # 20 shapes a domain ...
FIT_TURNS = 3                       # ... each kind of each turned by 3 of the 24 axis rotations
MEASURE_SEEDS = range(5000, 5020)
SURFACE_POINTS = 4000
L2 = 1e-2                           # the softmax's weight decay: the cues are correlated


def perturb(p: np.ndarray, rng: np.random.Generator, kind: str) -> np.ndarray:
    """crop: the lowest 8% cut (no underside) and a quarter of one side missing; noise: 1%
    Gaussian noise and 2% outliers in a box 10% larger; all: both."""
    if kind in ("crop", "all"):
        p = p[p[:, 2] > p[:, 2].min() + 0.08 * np.ptp(p[:, 2])]
        d = rng.normal(size=2)
        s = p[:, :2] @ (d / np.linalg.norm(d))
        p = p[s < np.quantile(s, 0.75)]
    if kind in ("noise", "all"):
        ext = np.ptp(p, 0).max()
        p = p + rng.normal(0, 0.01 * ext, p.shape)
        lo, hi = p.min(0), p.max(0)
        p = np.concatenate([p, rng.uniform(lo - 0.1 * ext, hi + 0.1 * ext, (int(0.02 * len(p)), 3))])
    return p


def label_of(rotation: np.ndarray) -> str:
    """The signed axis ("+x", ...) that `rotation` turns +z to."""
    up = rotation @ np.array([0, 0, 1.0])
    k = int(np.argmax(np.abs(up)))
    return ("+" if up[k] > 0 else "-") + "xyz"[k]


def shapes(domain: str, seeds: Iterable[int]) -> Iterator[tuple[np.random.Generator, np.ndarray]]:
    """(the shape's generator, SURFACE_POINTS surface points) of a random shape per seed."""
    from geocode.points import sample_surface
    from geocode.program import Program

    program = Program.load(domain)
    for s in seeds:
        rng = np.random.default_rng(s)
        yield rng, sample_surface(program.evaluate(program.random_values(rng)), SURFACE_POINTS, rng).astype(np.float64)


def cases(domain: str, seeds: Iterable[int],
          rotations_of: Callable[[int, int], list[np.ndarray]]) -> Iterator[tuple[np.ndarray, str]]:
    """(points as a file might hold them, the true up axis) of every shape, kind and rotation."""
    for i, (rng, base) in enumerate(shapes(domain, seeds)):
        for j, kind in enumerate(KINDS):
            for r in rotations_of(i, j):
                p = perturb(base, rng, kind) @ r.T * rng.uniform(0.01, 100) + rng.normal(0, 10, 3)
                yield p, label_of(r)


def features(points: np.ndarray) -> np.ndarray:
    """`pose.up_features` of a seeded subsample of FEATURE_POINTS points, as `pose.up_candidates` sees them."""
    pick = np.random.default_rng(0).choice(len(points), min(pose.FEATURE_POINTS, len(points)), replace=False)
    return pose.up_features(points[pick])


def fit_weights(x: np.ndarray, y: np.ndarray, l2: float = L2) -> np.ndarray:
    """The weights w (F,) of a softmax over the six signed axes, score = x @ w, fitted by
    maximum likelihood with weight decay `l2` (scipy's BFGS from zero): x (N, 6, F) the cues
    of N cases, y (N,) the index of each case's true up axis in `pose.AXES`."""
    from scipy.optimize import minimize

    def loss(w: np.ndarray) -> float:
        s = x @ w
        s = s - s.max(1, keepdims=True)
        return -(s[np.arange(len(y)), y] - np.log(np.exp(s).sum(1))).mean() + l2 * (w @ w)

    return minimize(loss, np.zeros(x.shape[2])).x


def fit() -> dict[str, tuple[float, ...]]:
    """WEIGHTS as pose.py holds them: for each domain and for any shape (""), fitted on the
    FIT_SEEDS shapes of the domain (of all domains for ""), rounded to 2 decimals."""
    rotations = pose.axis_rotations()

    def turned(i: int, j: int) -> list[np.ndarray]:
        return [rotations[(i * 4 + j * 7 + k * 5) % 24] for k in range(FIT_TURNS)]

    x, y, of = [], [], []
    for domain in DOMAINS:
        for points, label in cases(domain, FIT_SEEDS, turned):
            x.append(features(points))
            y.append(pose.AXES.index(label))
            of.append(domain)
    x, y, of = np.array(x), np.array(y), np.array(of)
    groups = [("", np.ones(len(of), bool))] + [(d, of == d) for d in DOMAINS]
    return {key: tuple(round(float(v), 2) + 0.0 for v in fit_weights(x[m], y[m])) for key, m in groups}


def weights_source(weights: dict[str, tuple[float, ...]]) -> str:
    """`weights` as the WEIGHTS assignment of pose.py."""
    rows = "".join(f"    {key!r}: ({', '.join(f'{v:.2f}' for v in w)}),\n" for key, w in weights.items())
    return f"WEIGHTS = {{\n{rows}}}"


def measure(turned: bool = False) -> None:
    """Per domain: 20 fresh shapes x 6 up directions x 4 kinds, with the domain's weights
    and with the general ones, and how often the truth is among the domain's two likeliest
    (`reconstruct --up auto` tries both); `turned`: each turned about its up axis by a random
    angle (not a quarter-turn) first, as a file whose front is off its axes."""
    ups = [pose.axis_rotation(a).T for a in pose.AXES]   # brings +z to each axis
    quarter = pose.turns(4)

    def rotations(i: int, j: int) -> list[np.ndarray]:
        if turned:
            angles = np.random.default_rng([i, j]).uniform(10, 80, len(ups)) + 90 * ((i + j) % 4)
            return [u @ pose.turn_z(a) for u, a in zip(ups, angles, strict=True)]
        return [u @ quarter[(i + j) % 4] for u in ups]

    for d in DOMAINS:
        hits = {which: {k: [] for k in KINDS} for which in ("domain", "general", "domain top 2")}
        for n, (p, label) in enumerate(cases(d, MEASURE_SEEDS, rotations)):
            kind = KINDS[(n // 6) % 4]
            cues = features(p)
            for which, w in (("domain", pose.WEIGHTS[d]), ("general", pose.WEIGHTS[""])):
                ranked = [pose.AXES[i] for i in np.argsort(-(cues @ np.asarray(w)), kind="stable")]
                hits[which][kind].append(ranked[0] == label)
                if which == "domain":
                    hits["domain top 2"][kind].append(label in ranked[:2])
        for which, h in hits.items():
            print(f"{d:13s} {which:12s}", "  ".join(f"{k} {np.mean(v):.2f}" for k, v in h.items()),
                  f"  all {np.mean(sum(h.values(), [])):.2f}", flush=True)


def real(folder: Path) -> None:
    """README convention: .off and .ply are +Z up, the rest +Y up. Per file the likeliest
    axis with the domain's and the general weights, and whether the truth is among the
    domain's two likeliest (`reconstruct --up auto` tries both and keeps the nearer fit)."""
    from geocode.reconstruct import inputs

    ok = {"domain": 0, "general": 0, "domain top 2": 0}
    files = sorted(Path(folder).glob("*/*"))
    for f in files:
        truth = "+z" if f.suffix in (".off", ".ply") else "+y"
        p = inputs.surface_points(inputs.read_geometry(f), SURFACE_POINTS, np.random.default_rng(0))
        two = pose.up_candidates(p, f.parent.name, k=2)
        general = pose.up_axis(p)[1]
        ok["domain"] += two[0] == truth
        ok["general"] += general == truth
        ok["domain top 2"] += truth in two
        print(f"{f.parent.name}/{f.name}: truth {truth}, domain {two}, general {general}")
    print(", ".join(f"{k} {v}/{len(files)}" for k, v in ok.items()))


if __name__ == "__main__":
    command = sys.argv[1:2]
    if command == ["fit"]:
        print(weights_source(fit()))
    elif command == ["measure"]:
        measure(sys.argv[2:] == ["turned"])
    elif command == ["real"] and len(sys.argv) == 3:
        real(Path(sys.argv[2]))
    else:
        sys.exit("usage: python -m geocode.bench.up fit | measure [turned] | real DIR")
