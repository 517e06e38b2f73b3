"""Exact k-nearest neighbours for DGCNN: the plain formula, a batched torch version for
GPUs, and a compiled cell search for CPUs that visits a few hundred candidates per point
instead of all N.
"""

from __future__ import annotations

from contextlib import contextmanager

import numba
import numpy as np
import torch

KNN_CHUNK_BYTES = 64 * 2**20  # bound on one block of pairwise scores in `knn_chunked`


def knn(x: torch.Tensor, k: int) -> torch.Tensor:
    """Indices of the k nearest neighbours of every point (itself included).

    d(i, j) = -||x_i - x_j||^2 = -||x_i||^2 + 2 x_i.x_j - ||x_j||^2, top-k over j.

    Shapes: x (B, C, N) -> (B, N, k) int64.
    """
    inner = 2 * torch.matmul(x.transpose(2, 1), x)  # (B, N, N)
    sq = (x * x).sum(dim=1, keepdim=True)  # (B, 1, N)
    neg_dist = inner - sq - sq.transpose(2, 1)  # (B, N, N)
    return neg_dist.topk(k, dim=-1).indices  # (B, N, k)


def knn_chunked(x: torch.Tensor, k: int, chunk_bytes: int = KNN_CHUNK_BYTES) -> torch.Tensor:
    """`knn` on point-major features, a few clouds at a time (bounded memory).

    Ranks by s(i, j) = [x_i, 1] . [2 x_j, -||x_j||^2] = -||x_i - x_j||^2 + ||x_i||^2 (the
    added term is constant per row): one plain `bmm` per block, no broadcast copy.

    Shapes: x (B, N, C) -> (B, N, k) int64.
    """
    b, n, _ = x.shape
    step = max(1, chunk_bytes // (n * n * x.element_size()))
    left = torch.cat([x, x.new_ones(b, n, 1)], dim=2)  # (B, N, C+1)
    right = torch.cat([2 * x, -(x * x).sum(dim=2, keepdim=True)], dim=2)  # (B, N, C+1)
    out = []
    for s in range(0, b, step):
        score = torch.bmm(left[s : s + step], right[s : s + step].transpose(1, 2))  # (b', N, N)
        out.append(score.topk(k, dim=-1, sorted=False).indices)  # (b', N, k)
    return torch.cat(out)  # (B, N, k)


def knn_cells(x: torch.Tensor, k: int, seeds: torch.Tensor | None = None) -> torch.Tensor:
    """`knn` by a search over grid cells, exact, on the CPU.

    Every cloud's features are turned to their principal axes (a rotation: distances
    stay) and bucketed in cubic cells by their first three coordinates. Those three
    alone shorten distances, so a cell's gap to a query in them bounds the distance of
    every point inside from below. Queries go in groups of `GROUP` neighbours in cell
    order (distances vectorise over the group); a group searches rings of cells
    outwards, skipping cells and points that the bound rules out for all its queries,
    until a ring's bound passes every query's k-th distance. Neighbours come sorted
    nearest first. `seeds` (say, the neighbours in the previous layer's features) are
    measured first: they only make the k-th distances tight early.

    Shapes: x (B, N, C), seeds (B, N, S) int64 -> (B, N, k) int64.
    """
    feats = x.detach().to("cpu")
    if not np.isfinite(feats.numpy()).all():
        raise ValueError("kNN: the features hold NaN or inf (is the point cloud finite?)")
    feats = _principal_coordinates(feats).contiguous().numpy()  # (B, N, max(C, 3))
    hint = np.zeros(x.shape[:2] + (0,), np.int64) if seeds is None else seeds.to("cpu").numpy()
    with _numba_threads() as threads:
        idx = _knn_in_cells(feats, k, 4 * threads, hint)
    return torch.from_numpy(idx).to(x.device)


def nearest_neighbours(x: torch.Tensor, k: int, seeds: torch.Tensor | None = None) -> torch.Tensor:
    """The fastest exact kNN for x's device: cells on the CPU (`seeds` as there), batched
    scores elsewhere.

    Shapes: x (B, N, C), seeds (B, N, S) -> (B, N, k) int64.
    """
    return knn_cells(x, k, seeds) if x.device.type == "cpu" else knn_chunked(x, k)


def neighbour_max(b: torch.Tensor, flat: torch.Tensor, k: int) -> torch.Tensor:
    """max_{j in N(i)} b_j for every point i, without the (P, k, O) gather on the CPU.

    Shapes: b (P, O), flat (P*k,) rows of b, k at a time -> (P, O).
    """
    if b.device.type != "cpu":
        return b.index_select(0, flat).view(-1, k, b.shape[1]).amax(dim=1)
    with _numba_threads():
        return torch.from_numpy(_gather_max(b.detach().contiguous().numpy(), flat.numpy(), k))


def neighbour_max_arg_sum(b: torch.Tensor, flat: torch.Tensor, k: int, with_sum: bool):
    """(max_j b_j, the row of b each maximum came from, sum_j b_j or None) over each point's
    neighbours j, for training: on the CPU in one pass, without the (P, k, O) gather.

    Shapes: b (P, O), flat (P*k,) -> (P, O) float, (P, O) int64, (P, O) float or None.
    """
    if b.device.type != "cpu":
        p = flat.numel() // k
        nb = b.index_select(0, flat).view(p, k, -1)  # (P, k, O)
        mx, arg = nb.max(dim=1)  # (P, O) each
        return mx, flat.view(p, k).gather(1, arg), nb.sum(dim=1) if with_sum else None
    with _numba_threads():
        mx, src, total = _gather_max_arg_sum(b.detach().contiguous().numpy(), flat.numpy(), k, with_sum)
    return torch.from_numpy(mx), torch.from_numpy(src), torch.from_numpy(total) if with_sum else None


def neighbour_max_sum_grad(g_max: torch.Tensor, src: torch.Tensor, g_sum: torch.Tensor | None,
                           flat: torch.Tensor, k: int, rows: int) -> torch.Tensor:
    """The gradient on b of `neighbour_max_arg_sum`: g_max to each maximum's row, g_sum_i to
    every neighbour of i.

    Shapes: g_max (P, O), src (P, O), g_sum (P, O) or None, flat (P*k,) -> (rows, O).
    """
    if g_max.device.type != "cpu":
        grad = g_max.new_zeros(rows, g_max.shape[1])
        grad.scatter_add_(0, src, g_max)
        if g_sum is not None:
            grad.index_add_(0, flat, g_sum.repeat_interleave(k, dim=0))
        return grad
    none = np.zeros((0, g_max.shape[1]), g_max.numpy().dtype)
    g_sum = none if g_sum is None else g_sum.contiguous().numpy()
    return torch.from_numpy(_scatter_grad(g_max.contiguous().numpy(), src.numpy(), g_sum, flat.numpy(), k, rows))


@contextmanager
def _numba_threads():
    """Compiled loops use as many threads as torch (OMP_NUM_THREADS, or a job's share).
    Numba's OpenMP pool resets the process's OpenMP thread count to every core when it
    starts, torch's included: a 1-thread job would then run torch on 2 threads and slow
    down a job beside it several times, so torch's count is put back."""
    torch_threads = torch.get_num_threads()
    threads = max(1, min(torch_threads, numba.config.NUMBA_NUM_THREADS))
    numba.set_num_threads(threads)
    try:
        yield threads
    finally:
        if torch.get_num_threads() != torch_threads:
            torch.set_num_threads(torch_threads)


def _principal_coordinates(feats: torch.Tensor) -> torch.Tensor:
    """Each cloud's centred features on its principal axes, largest variance first (as
    they are where C <= 3), at least three columns (zero-padded). The axes come from a
    float64 eigendecomposition: orthonormal to rounding, so distances stay as they were.

    Shapes: feats (B, N, C) -> (B, N, max(C, 3)).
    """
    centred = feats - feats.mean(dim=1, keepdim=True)  # (B, N, C)
    c = centred.shape[2]
    if c <= 3:
        return torch.cat([centred, centred.new_zeros(centred.shape[:2] + (3 - c,))], dim=2)
    cov = (centred.transpose(1, 2) @ centred).double()  # (B, C, C)
    axes = torch.linalg.eigh(cov).eigenvectors.flip(2).to(feats.dtype)  # (B, C, C), eigenvalues descending
    return centred @ axes  # (B, N, C)


# fast maths without assuming finite values: unfilled top-k slots hold inf
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}
GROUP = 32  # queries searched together (lanes of the vectorised loops)
PREFILTER = 16  # leading axes compared for every query before the rest
CELL_POINTS = 16  # about this many points per cell where the cloud is a surface


@numba.njit(cache=True, nogil=True, parallel=True, fastmath=FAST)
def _gather_max(b, flat, k):
    """(P, O): row i is the element-wise max of b[flat[i*k : (i+1)*k]]."""
    out = np.empty((len(flat) // k, b.shape[1]), b.dtype)
    for i in numba.prange(out.shape[0]):
        row = out[i]
        row[:] = b[flat[i * k]]
        for t in range(1, k):
            nb = b[flat[i * k + t]]
            for c in range(len(row)):
                row[c] = max(row[c], nb[c])
    return out


@numba.njit(cache=True, nogil=True, parallel=True, fastmath=FAST)
def _gather_max_arg_sum(b, flat, k, with_sum):
    """(P, O) maxima over each k rows of b that flat names, the row each came from (the
    first where rows tie), and their sums (an empty array unless with_sum)."""
    p, o = len(flat) // k, b.shape[1]
    mx = np.empty((p, o), b.dtype)
    src = np.empty((p, o), np.int64)
    total = np.empty((p if with_sum else 0, o), b.dtype)
    for i in numba.prange(p):
        first = flat[i * k]
        mx[i] = b[first]
        src[i] = first
        if with_sum:
            total[i] = b[first]
        for t in range(1, k):
            j = flat[i * k + t]
            nb = b[j]
            for c in range(o):
                if nb[c] > mx[i, c]:
                    mx[i, c] = nb[c]
                    src[i, c] = j
            if with_sum:
                for c in range(o):
                    total[i, c] += nb[c]
    return mx, src, total


@numba.njit(cache=True, nogil=True, fastmath=FAST)
def _scatter_grad(g_max, src, g_sum, flat, k, rows):
    """(rows, O): g_max[i, c] added at row src[i, c], and each g_sum row (if any) added at
    every row of its k in flat. One thread: rows are shared between points."""
    p, o = g_max.shape
    grad = np.zeros((rows, o), g_max.dtype)
    for i in range(p):
        for c in range(o):
            grad[src[i, c], c] += g_max[i, c]
    if g_sum.shape[0]:
        for i in range(p):
            for t in range(k):
                row = grad[flat[i * k + t]]
                for c in range(o):
                    row[c] += g_sum[i, c]
    return grad


@numba.njit(cache=True, nogil=True, parallel=True)
def _knn_in_cells(feats, k, chunks, seeds):
    """(B, N, k) neighbour indices, nearest first, of features (float32 or float64) on
    their principal axes (C >= 3); see `knn_cells`. seeds (B, N, S): points offered
    first to each query (S may be 0); each cloud's groups are split in `chunks` parts
    for the threads."""
    bsz, n, c = feats.shape
    out = np.empty((bsz, n, k), np.int64)
    groups = (n + GROUP - 1) // GROUP
    for b in range(bsz):
        lo, side, shape, start, order = _cell_grid(feats[b])
        x = feats[b][order]  # cell order: a cell's points lie together in memory
        rank = np.empty(n, np.int64)
        rank[order] = np.arange(n)
        parts = min(chunks, groups)
        for part in numba.prange(parts):
            # scratch, allocated once per part: allocations cost more than a cell's search
            rows = np.empty((GROUP, c), feats.dtype)
            q = np.empty((c, GROUP), feats.dtype)
            best_d = np.empty((GROUP, k), feats.dtype)
            best_j = np.empty((GROUP, k), np.int64)
            gaps = np.empty((3, shape.max(), GROUP), feats.dtype)
            hint = np.empty((GROUP, seeds.shape[2]), np.int64)
            seeded = np.zeros((GROUP, n), np.int32)  # = group number + 1 where a seed of that query
            for g in range(part * groups // parts, (part + 1) * groups // parts):
                first = g * GROUP
                for m in range(GROUP):
                    s = min(first + m, n - 1)  # the last point fills a short group
                    rows[m] = x[s]
                    q[:, m] = rows[m]
                    for t in range(seeds.shape[2]):
                        hint[m, t] = rank[seeds[b, order[s], t]]
                _search_group(x, rows, q, hint, g + 1, seeded, lo, side, shape, start, best_d, best_j, gaps)
                for m in range(min(GROUP, n - first)):
                    for i in range(k):
                        out[b, order[first + m], i] = order[best_j[m, i]]
    return out


@numba.njit(cache=True, nogil=True)
def _cell_grid(x):
    """Cubic cells over the first three coordinates: (lo (3,), side, shape (3,),
    start (cells+1,), order (N,)); cell (i0 * shape[1] + i1) * shape[2] + i2 holds the
    points order[start[c]:start[c+1]]."""
    n = x.shape[0]
    lo = np.empty(3)
    extent = np.empty(3)
    for a in range(3):
        lo[a] = x[:, a].min()
        extent[a] = x[:, a].max() - lo[a]
    # CELL_POINTS per cell on a surface spanning the two longest axes, at most 64 cells a side
    longest = np.sort(extent)
    side = max(np.sqrt(longest[2] * longest[1] * CELL_POINTS / n), longest[2] / 64, 1e-30)
    shape = np.empty(3, np.int64)
    for a in range(3):
        shape[a] = int(extent[a] / side) + 1
    cell = np.empty(n, np.int64)
    for i in range(n):
        cell[i] = 0
        for a in range(3):
            cell[i] = cell[i] * shape[a] + _index(x[i, a], lo[a], side, shape[a])
    start = np.zeros(shape[0] * shape[1] * shape[2] + 1, np.int64)
    for i in range(n):
        start[cell[i] + 1] += 1
    start = np.cumsum(start)
    order = np.argsort(cell, kind="mergesort")  # stable: ties keep their input order
    return lo, side, shape, start, order


@numba.njit(cache=True, nogil=True, inline="always")
def _index(v, lo, side, size):
    return min(int((v - lo) / side), size - 1)


@numba.njit(cache=True, nogil=True, inline="always")
def _exceeds(bound, kth):
    """A lower bound rules a point out: taken 1e-5 low, exact despite float32 rounding."""
    return bound * (1 - 1e-5) >= kth


@numba.njit(cache=True, nogil=True)
def _search_group(x, rows, q, hint, stamp, seeded, lo, side, shape, start, best_d, best_j, gaps):
    """Fill best_j (GROUP, k) with the rows of x nearest to each query, nearest first, by
    rings of cells around the block of cells the queries occupy, after the rows in hint
    (GROUP, S), which only tighten the k-th distances early; seeded[m, j] = stamp marks
    them, so that their cells do not offer them twice. The queries come twice:
    rows (GROUP, C) and q (C, GROUP); best_d and gaps are scratch."""
    best_d[:] = np.inf
    best_j[:] = 0
    kth = np.full(GROUP, np.inf, x.dtype)  # each query's k-th distance so far
    near = np.empty(GROUP, x.dtype)
    box_lo = np.empty(3, np.int64)
    box_hi = np.empty(3, np.int64)
    i_lo = np.empty(3, np.int64)
    i_hi = np.empty(3, np.int64)
    for a in range(3):
        box_lo[a], box_hi[a] = shape[a], -1
        for m in range(GROUP):
            i = _index(q[a, m], lo[a], side, shape[a])
            box_lo[a], box_hi[a] = min(box_lo[a], i), max(box_hi[a], i)
    for m in range(GROUP):
        for t in range(hint.shape[1]):
            j = hint[m, t]
            if seeded[m, j] != stamp:
                seeded[m, j] = stamp
                _insert(best_d, best_j, kth, m, _distance(x[j], rows[m]), j)
    r = 0
    while True:
        for a in range(3):
            i_lo[a], i_hi[a] = max(box_lo[a] - r, 0), min(box_hi[a] + r, shape[a] - 1)
        _axis_gaps(q, lo, side, i_lo, i_hi, gaps)
        for i0 in range(i_lo[0], i_hi[0] + 1):
            for i1 in range(i_lo[1], i_hi[1] + 1):
                inside01 = box_lo[0] - r < i0 < box_hi[0] + r and box_lo[1] - r < i1 < box_hi[1] + r
                for i2 in range(i_lo[2], i_hi[2] + 1):
                    if r > 0 and inside01 and box_lo[2] - r < i2 < box_hi[2] + r:
                        continue  # searched at a smaller r
                    cell = (i0 * shape[1] + i1) * shape[2] + i2
                    if start[cell] == start[cell + 1]:
                        continue
                    wanted = False
                    for m in range(GROUP):
                        near[m] = gaps[0, i0, m] + gaps[1, i1, m] + gaps[2, i2, m]
                        wanted |= not _exceeds(near[m], kth[m])
                    if wanted:
                        _offer_cell(x, q, rows, start[cell], start[cell + 1], best_d, best_j, kth, near,
                                    stamp, seeded)
        # every point outside the block is at least this far from each query
        done = True
        for m in range(GROUP):
            out_gap = np.inf
            for a in range(3):
                if i_lo[a] > 0:
                    out_gap = min(out_gap, q[a, m] - (lo[a] + i_lo[a] * side))
                if i_hi[a] < shape[a] - 1:
                    out_gap = min(out_gap, lo[a] + (i_hi[a] + 1) * side - q[a, m])
            done &= out_gap == np.inf or _exceeds(max(out_gap, 0.0) ** 2, kth[m])
        if done:
            return
        r += 1


@numba.njit(cache=True, nogil=True, fastmath=FAST)
def _axis_gaps(q, lo, side, i_lo, i_hi, gaps):
    """gaps[a, i, m]: squared distance from query m to cell slab i of axis a."""
    for a in range(3):
        for i in range(i_lo[a], i_hi[a] + 1):
            a0 = lo[a] + i * side
            for m in range(GROUP):
                g = max(a0 - q[a, m], 0.0, q[a, m] - a0 - side)
                gaps[a, i, m] = g * g


@numba.njit(cache=True, nogil=True, fastmath=FAST)
def _offer_cell(x, q, rows, begin, end, best_d, best_j, kth, d, stamp, seeded):
    """Insert the points x[begin:end] into each query's sorted top-k where they are
    nearer than its k-th (kth, kept equal to best_d[:, -1]). The first PREFILTER axes,
    computed for all queries at once, rule most points out. The queries come twice:
    q (C, GROUP) and rows (GROUP, C); d (GROUP,) is scratch; seeds (seeded[m, j] ==
    stamp) are in the top-k already."""
    c = x.shape[1]
    lead = min(c, PREFILTER)
    lanes = q.shape[1]  # GROUP, read at run time: LLVM vectorises this loop, not an unrolled one
    for j in range(begin, end):
        d[:] = 0
        for f in range(lead):
            v = x[j, f]
            for m in range(lanes):
                t = v - q[f, m]
                d[m] += t * t
        wanted = False
        for m in range(lanes):
            wanted |= d[m] < kth[m]
        if not wanted:
            continue
        for m in range(GROUP):
            if d[m] >= kth[m] or seeded[m, j] == stamp:
                continue
            s = d[m]
            for f in range(lead, c):
                t = x[j, f] - rows[m, f]
                s += t * t
            _insert(best_d, best_j, kth, m, s, j)


@numba.njit(cache=True, nogil=True, fastmath=FAST)
def _distance(a, b):
    s = a.dtype.type(0)
    for f in range(a.shape[0]):
        t = a[f] - b[f]
        s += t * t
    return s


@numba.njit(cache=True, nogil=True, inline="always")
def _insert(best_d, best_j, kth, m, s, j):
    """Put row j at squared distance s into query m's sorted top-k, unless it is not
    nearer than the k-th."""
    if s >= kth[m]:
        return
    k = best_d.shape[1]
    p = k - 1
    while p > 0 and best_d[m, p - 1] > s:
        best_d[m, p] = best_d[m, p - 1]
        best_j[m, p] = best_j[m, p - 1]
        p -= 1
    best_d[m, p] = s
    best_j[m, p] = j
    kth[m] = best_d[m, k - 1]
