"""Fit or measure `geocode.reconstruct.pose.up_axis` on program shapes (needs bpy).

    python scripts/fit_up_weights.py fit        # prints WEIGHTS for geocode/reconstruct/pose.py
    python scripts/fit_up_weights.py measure    # accuracy on fresh shapes, 6 up directions
    python scripts/fit_up_weights.py measure turned   # the same, each also turned about its up
    python scripts/fit_up_weights.py real DIR   # accuracy on DIR/<domain>/<file> (README's up)

Shapes: random parameters (seeds 1000+i for fitting, 5000+i for measuring, so the measure is
on shapes the fit never saw), 4000 surface points, then turned, rescaled, moved and
perturbed as scans are (`perturb`).
"""

import sys
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from geocode.reconstruct import inputs, pose

DOMAINS = ("chair", "vase", "table", "ceiling_lamp", "cabinet")
KINDS = ("clean", "crop", "noise", "all")


def perturb(p, rng, kind):
    """crop: the lowest 8% cut (no underside) and a quarter of one side missing; noise: 1%
    Gaussian noise and 2% outliers in a box 10% larger."""
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


def label_of(rotation):
    up = rotation @ np.array([0, 0, 1.0])
    k = int(np.argmax(np.abs(up)))
    return ("+" if up[k] > 0 else "-") + "xyz"[k]


def shapes(domain, seeds):
    from geocode.points import sample_surface
    from geocode.program import Program
    program = Program.load(domain)
    for s in seeds:
        rng = np.random.default_rng(s)
        yield rng, sample_surface(program.evaluate(program.random_values(rng)), 4000, rng).astype(np.float64)


def cases(domain, seeds, rotations_of):
    for i, (rng, base) in enumerate(shapes(domain, seeds)):
        for j, kind in enumerate(KINDS):
            for r in rotations_of(i, j):
                p = perturb(base, rng, kind) @ r.T * rng.uniform(0.01, 100) + rng.normal(0, 10, 3)
                yield p, label_of(r)


def fit():
    rots = pose.axis_rotations()
    X, Y, G = [], [], []
    for d in DOMAINS:
        turns = lambda i, j: [rots[(i * 4 + j * 7 + k * 5) % 24] for k in range(3)]  # noqa: E731
        for p, label in cases(d, range(1000, 1020), turns):
            X.append(pose.up_features(p[np.random.default_rng(0).choice(len(p), min(3000, len(p)), replace=False)]))
            Y.append(pose.AXES.index(label))
            G.append(d)
    X, Y, G = np.array(X), np.array(Y), np.array(G)

    def loss(w, X, Y):
        s = X @ w
        s = s - s.max(1, keepdims=True)
        return -(s[np.arange(len(Y)), Y] - np.log(np.exp(s).sum(1))).mean() + 1e-2 * (w @ w)

    print("WEIGHTS = {")
    for key, m in [("", np.ones(len(G), bool))] + [(d, G == d) for d in DOMAINS]:
        w = minimize(loss, np.zeros(X.shape[2]), args=(X[m], Y[m])).x
        print(f"    {key!r}: ({', '.join(f'{v:.2f}' for v in w)}),")
    print("}")


def measure(turned=False):
    """Per domain: 20 fresh shapes x 6 up directions x 4 kinds, with the domain's weights
    and with the general ones, and how often the truth is among the domain's two likeliest
    (`reconstruct --up auto` tries both); `turned`: each turned about its up axis by a random angle
    (not a quarter-turn) first, as a file whose front is off its axes."""
    ups = [pose.axis_rotation(a).T for a in pose.AXES]   # brings +z to each axis
    turn = pose.turns(4)

    def rotations(i, j):
        if turned:
            angles = np.random.default_rng([i, j]).uniform(10, 80, len(ups)) + 90 * ((i + j) % 4)
            return [u @ pose.turn_z(a) for u, a in zip(ups, angles, strict=True)]
        return [u @ turn[(i + j) % 4] for u in ups]

    for d in DOMAINS:
        hits = {which: {k: [] for k in KINDS} for which in ("domain", "general", "domain top 2")}
        for n, (p, label) in enumerate(cases(d, range(5000, 5020), rotations)):
            kind = KINDS[(n // 6) % 4]
            sample = p[np.random.default_rng(0).choice(len(p), min(pose.FEATURE_POINTS, len(p)), replace=False)]
            features = pose.up_features(sample)
            for which, w in (("domain", pose.WEIGHTS[d]), ("general", pose.WEIGHTS[""])):
                ranked = [pose.AXES[i] for i in np.argsort(-(features @ np.asarray(w)), kind="stable")]
                hits[which][kind].append(ranked[0] == label)
                if which == "domain":
                    hits["domain top 2"][kind].append(label in ranked[:2])
        for which, h in hits.items():
            print(f"{d:13s} {which:12s}", "  ".join(f"{k} {np.mean(v):.2f}" for k, v in h.items()),
                  f"  all {np.mean(sum(h.values(), [])):.2f}", flush=True)


def real(folder):
    """README convention: .off and .ply are +Z up, the rest +Y up. Per file the likeliest
    axis with the domain's and the general weights, and whether the truth is among the
    domain's two likeliest (`reconstruct --up auto` tries both and keeps the nearer fit)."""
    ok = {"domain": 0, "general": 0, "domain top 2": 0}
    files = sorted(Path(folder).glob("*/*"))
    for f in files:
        truth = "+z" if f.suffix in (".off", ".ply") else "+y"
        p = inputs.surface_points(inputs.read_geometry(f), 4000, np.random.default_rng(0))
        two = pose.up_candidates(p, f.parent.name, k=2)
        got = two[0], pose.up_axis(p)[1]
        ok["domain"] += got[0] == truth
        ok["general"] += got[1] == truth
        ok["domain top 2"] += truth in two
        print(f"{f.parent.name}/{f.name}: truth {truth}, domain {two}, general {got[1]}")
    print(", ".join(f"{k} {v}/{len(files)}" for k, v in ok.items()))

if __name__ == "__main__":
    {"fit": fit, "measure": lambda: measure(sys.argv[2:] == ["turned"]),
     "real": lambda: real(sys.argv[2])}[sys.argv[1]]()
