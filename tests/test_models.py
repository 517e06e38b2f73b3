"""Encoders, decoders, losses, the fast/reference DGCNN equivalence, and every model config."""

import math
import os
import subprocess
import sys
import time

import pytest
import torch
import torch.nn.functional as F

from geocode.models import (
    DGCNN,
    VARIANTS,
    Decoders,
    DGCNNReference,
    GeoCodeModule,
    VGGSketchEncoder,
    knn,
)
from geocode.models.heads import median_classes, regression_classes, regression_loss
from geocode.models.neighbours import (
    knn_cells,
    knn_chunked,
    neighbour_max_arg_sum,
    neighbour_max_sum_grad,
)

HEADS = [
    {"name": "size", "n_classes": 5, "continuous": True, "existence": True},
    {"name": "count", "n_classes": 3, "continuous": False, "existence": False},
    {"name": "width", "n_classes": 4, "continuous": True, "existence": False},
]


def _randomise_bn(model, seed=0):
    """Random BN affine parameters (some negative scales) and running statistics."""
    g = torch.Generator().manual_seed(seed)
    for m in model.modules():
        if isinstance(m, torch.nn.modules.batchnorm._BatchNorm):
            m.weight.data = (torch.rand(m.weight.shape, generator=g) * 2 - 0.5).to(m.weight)
            m.bias.data = (torch.rand(m.bias.shape, generator=g) - 0.5).to(m.bias)
            m.running_mean.copy_(torch.rand(m.running_mean.shape, generator=g) - 0.5)
            m.running_var.copy_(torch.rand(m.running_var.shape, generator=g) + 0.5)


def test_knn_chunked_finds_the_same_neighbours():
    x = torch.randn(3, 80, 5, dtype=torch.float64)
    ref = knn(x.transpose(1, 2), 20).sort(dim=-1).values
    fast = knn_chunked(x, 20, chunk_bytes=80 * 80 * 4).sort(dim=-1).values  # one cloud per block
    assert torch.equal(ref, fast)


def _exact_knn_distances(x: torch.Tensor, k: int) -> torch.Tensor:
    """Sorted squared distances to the k nearest, by the definition. x (B, N, C) -> (B, N, k)."""
    d = ((x[:, :, None, :].double() - x[:, None, :, :].double()) ** 2).sum(-1)
    return d.sort(dim=-1).values[..., :k]


def _knn_distances(x: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
    xd = x.double()
    nb = torch.stack([xd[b][idx[b]] for b in range(len(x))])  # (B, N, k, C)
    return ((nb - xd[:, :, None, :]) ** 2).sum(-1)


def _clouds():
    g = torch.Generator().manual_seed(0)
    sphere = torch.randn(1, 2300, 3, generator=g)
    sphere = sphere / sphere.norm(dim=2, keepdim=True)  # a surface, as the data is
    dense = torch.rand(1, 30000, 3, generator=g) * torch.tensor([1.0, 1.0, 0.01])  # a thin slab
    slab = torch.cat([dense[:, :1500], dense[:, torch.randperm(30000, generator=g)[:800]]], dim=1)
    spread = torch.randn(1, 600, 32, generator=g) * torch.logspace(0, -2, 32)  # anisotropic features
    dupes = torch.randn(1, 50, 3, generator=g).repeat(1, 3, 1)  # every point three times
    line = torch.linspace(0, 1, 60).view(1, 60, 1) * torch.tensor([1.0, 2.0, 0.0, 0.0])
    return {
        "surface": sphere, "fps_and_random": slab, "features": spread, "duplicates": dupes, "collinear": line,
        "batch": torch.rand(3, 200, 16, generator=g), "one_point_many_times": torch.ones(1, 40, 5),
        "two_dims": torch.rand(2, 100, 2, generator=g), "fewer_than_a_group": torch.rand(1, 7, 3, generator=g),
    }


@pytest.mark.parametrize("name", list(_clouds()))
@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_knn_cells_is_exact(name, dtype):
    """The cell search returns the true k nearest, nearest first (distances, since ties
    between equally distant points may be broken either way)."""
    x = _clouds()[name].to(dtype)
    k = min(20, x.shape[1])
    idx = knn_cells(x, k)
    assert idx.shape == (*x.shape[:2], k) and idx.dtype == torch.int64
    got = _knn_distances(x, idx)
    torch.testing.assert_close(got, _exact_knn_distances(x, k), rtol=1e-5, atol=1e-6)
    assert (got.diff(dim=-1) >= -1e-6).all()  # sorted, nearest first


def test_knn_cells_seeds_only_speed_it_up():
    """Seeds (the previous layer's neighbours) change no distance, only the work."""
    x = _clouds()["features"]
    seeds = knn_cells(x[..., :4].contiguous(), 20)  # neighbours in another space
    torch.testing.assert_close(_knn_distances(x, knn_cells(x, 20, seeds)), _exact_knn_distances(x, 20))


def test_compiled_knn_keeps_torchs_thread_count():
    """Numba's OpenMP pool would reset torch to every core when it starts: a 1-thread job
    (OMP_NUM_THREADS=1, as Snakemake sets it) must stay on one thread."""
    code = ("import torch; from geocode.models.neighbours import knn_cells, neighbour_max; "
            "x = torch.rand(2, 300, 3); knn_cells(x, 8); "
            "neighbour_max(torch.rand(300, 4), torch.randint(300, (1200,)), 4); print(torch.get_num_threads())")
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["1"]


def test_knn_cells_rejects_non_finite_features():
    x = torch.rand(1, 50, 3)
    x[0, 7, 1] = float("nan")
    with pytest.raises(ValueError, match="NaN or inf"):
        knn_cells(x, 10)


@pytest.mark.parametrize("train", [True, False])
def test_fast_dgcnn_equals_reference(train):
    """Same weights -> same outputs, input and weight gradients, running statistics.

    float64: in float32 the two (exactly equal in real arithmetic) formulations round
    differently (~1e-6 relative), which can swap a neighbour at a near-tie of the k-th
    distance; float64 keeps the comparison about the algebra."""
    torch.manual_seed(0)
    ref = DGCNNReference(k=20).double()
    _randomise_bn(ref)
    fast = DGCNN(k=20).double()
    fast.load_state_dict(ref.state_dict())
    ref.train(train), fast.train(train)
    x = torch.randn(3, 150, 3, dtype=torch.float64)
    x1, x2 = x.clone().requires_grad_(), x.clone().requires_grad_()
    out1, out2 = ref(x1), fast(x2)
    assert out2.shape == (3, 128)
    torch.testing.assert_close(out2, out1, atol=1e-5, rtol=1e-5)
    w = torch.randn_like(out1)
    (out1 * w).sum().backward()
    (out2 * w).sum().backward()
    torch.testing.assert_close(x2.grad, x1.grad, atol=1e-5, rtol=1e-5)
    for (name, p1), (_, p2) in zip(ref.named_parameters(), fast.named_parameters(), strict=True):
        torch.testing.assert_close(p2.grad, p1.grad, atol=1e-5, rtol=1e-5, msg=name)
    for (name, b1), (_, b2) in zip(ref.named_buffers(), fast.named_buffers(), strict=True):
        torch.testing.assert_close(b2.double(), b1.double(), atol=1e-5, rtol=1e-5, msg=name)


def test_compiled_neighbour_max_and_sum_equal_the_gathered_ones():
    """The training kernels of the fast EdgeConv: max, its source row and the sum over each
    point's neighbours, and the gradient scattered back, as a plain gather computes them."""
    torch.manual_seed(3)
    b, flat, k = torch.randn(200, 6, dtype=torch.float64), torch.randint(200, (200 * 7,)), 7
    mx, src, total = neighbour_max_arg_sum(b, flat, k, True)
    nb = b[flat].view(200, k, 6)
    torch.testing.assert_close(mx, nb.amax(dim=1))
    torch.testing.assert_close(total, nb.sum(dim=1))
    assert torch.equal(b.gather(0, src), mx)
    g_max, g_sum = torch.randn(200, 6, dtype=torch.float64), torch.randn(200, 6, dtype=torch.float64)
    leaf = b.clone().requires_grad_()
    nb = leaf[flat].view(200, k, 6)
    (nb.amax(dim=1) * g_max + nb.sum(dim=1) * g_sum).sum().backward()
    torch.testing.assert_close(neighbour_max_sum_grad(g_max, src, g_sum, flat, k, 200), leaf.grad)
    assert neighbour_max_arg_sum(b, flat, k, False)[2] is None


def test_fast_dgcnn_inference_equals_reference():
    """Without autograd the fast encoder takes its inference path (compiled neighbour max)."""
    torch.manual_seed(2)
    ref = DGCNNReference().double()
    _randomise_bn(ref)
    fast = DGCNN().double()
    fast.load_state_dict(ref.state_dict())
    ref.eval(), fast.eval()
    x = torch.randn(2, 300, 3, dtype=torch.float64)
    with torch.inference_mode():
        torch.testing.assert_close(fast(x), ref(x), atol=1e-5, rtol=1e-5)


def test_fast_dgcnn_float32_close():
    torch.manual_seed(1)
    ref, fast = DGCNNReference(), DGCNN()
    fast.load_state_dict(ref.state_dict())
    x = torch.randn(2, 100, 3)
    out1, out2 = ref(x), fast(x)
    torch.testing.assert_close(out2, out1, atol=1e-4, rtol=1e-4)


def test_encoder_shapes():
    assert DGCNN()(torch.randn(2, 64, 3)).shape == (2, 128)
    assert DGCNN().eval()(torch.randn(1, 30, 3)).shape == (1, 128)
    assert VGGSketchEncoder()(torch.rand(2, 1, 224, 224)).shape == (2, 128)
    dec = Decoders(HEADS)
    out = dec(torch.randn(4, 128))
    assert {k: v.shape for k, v in out.items()} == {"size": (4, 5), "count": (4, 3), "width": (4, 4)}
    reg = Decoders(HEADS, regression=True)(torch.randn(4, 128))
    assert reg["size"].shape == (4, 2) and reg["count"].shape == (4, 3) and reg["width"].shape == (4, 1)


def test_the_sketch_encoder_in_bfloat16_stays_near_float32_and_answers_in_float32():
    torch.manual_seed(0)
    full = VGGSketchEncoder().eval()
    half = VGGSketchEncoder(bfloat16=True).eval()
    half.load_state_dict(full.state_dict())
    x = torch.rand(3, 1, 224, 224)
    a, b = full(x), half(x)
    assert b.dtype == torch.float32 and not torch.equal(a, b)          # it did run in bfloat16
    assert (a - b).norm() / a.norm() < 0.05
    assert all(p.dtype == torch.float32 for p in half.parameters())   # the weights stay float32
    model = GeoCodeModule(HEADS, sketch_bfloat16=True)
    assert model.hparams.sketch_bfloat16 and model.branches[0].sketch.bfloat16


@pytest.mark.parametrize("regression", [False, True])
def test_decoders_stacked_in_eval_equal_the_heads_one_by_one(regression):
    torch.manual_seed(0)
    dec = Decoders(HEADS, in_dim=128, regression=regression)
    _randomise_bn(dec)
    dec.eval()
    z = torch.randn(5, 128)
    one_by_one = {name: head(z) for name, head in dec.heads.items()}
    stacked = dec(z)
    assert stacked.keys() == one_by_one.keys()
    for name in one_by_one:
        torch.testing.assert_close(stacked[name], one_by_one[name], atol=1e-5, rtol=1e-5)


def test_decoders_stack_follows_new_weights():
    """The eval-mode stack is rebuilt after load_state_dict, a train/eval switch and .to()."""
    torch.manual_seed(0)
    dec, other = Decoders(HEADS).eval(), Decoders(HEADS).eval()
    _randomise_bn(other, seed=1)
    z = torch.randn(4, 128)
    before = dec(z)["size"]
    dec.load_state_dict(other.state_dict())
    torch.testing.assert_close(dec(z)["size"], other(z)["size"])
    assert not torch.allclose(dec(z)["size"], before)
    dec.train()
    torch.optim.SGD(dec.parameters(), lr=1.0).zero_grad()
    dec(z)["size"].sum().backward()
    torch.optim.SGD(dec.parameters(), lr=1.0).step()
    dec.eval()
    torch.testing.assert_close(dec(z)["size"], dec.heads["size"](z))
    assert dec.double()(z.double())["size"].dtype == torch.float64


def test_loss_is_sum_of_cross_entropies_with_existence_class():
    dec = Decoders(HEADS)
    out = {"size": torch.randn(3, 5), "count": torch.randn(3, 3), "width": torch.randn(3, 4)}
    labels = torch.tensor([[4, 0, 1], [0, 2, 3], [2, 1, 0]])  # size=4: the existence class
    columns = {"size": 0, "count": 1, "width": 2}
    expected = sum(F.cross_entropy(out[n], labels[:, j]) for n, j in columns.items())
    torch.testing.assert_close(dec.loss(out, labels, columns), expected)
    assert torch.equal(dec.classes(out)["size"], out["size"].argmax(1))


def test_regression_head_loss_and_classes():
    spec = HEADS[0]  # 4 value classes + existence
    target = torch.tensor([4, 0, 3])  # invisible, 0.0, 1.0
    pred = torch.tensor([[0.9, 1.0], [0.0, 0.0], [1.0, 0.0]])
    assert regression_loss(pred, target, spec).item() == pytest.approx(0.0)
    # says visible for the hidden one: its value counts against the existence label -1
    pred_bad = torch.tensor([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0]])
    assert regression_loss(pred_bad, target, spec).item() == pytest.approx(1 / 3 + 1 / 3)
    # predicted invisible: the value's error is not collected, only the existence score's
    hidden = torch.tensor([[0.5, 0.9]])
    assert regression_loss(hidden, torch.tensor([0]), spec).item() == pytest.approx(0.81)
    got = regression_classes(torch.tensor([[0.34, 0.2], [0.7, 0.6], [1.3, 0.0]]), spec)
    assert got.tolist() == [1, 4, 3]


def test_median_decoding_reads_the_middle_of_the_distribution():
    spec = HEADS[0]  # 4 value classes + existence
    probs = torch.tensor([
        [0.40, 0.00, 0.30, 0.30, 0.00],  # argmax at one end; half the mass reached at class 2
        [0.10, 0.15, 0.20, 0.15, 0.40],  # the existence class is the likeliest: hidden
        [0.05, 0.05, 0.10, 0.10, 0.70],
        [0.00, 0.10, 0.00, 0.20, 0.00],  # cumulative 0.1, 0.1, 0.1, 0.3 of 0.3: class 3
    ]) + 1e-9
    got = median_classes(probs.log(), spec)
    assert got.tolist() == [2, 4, 4, 3]
    dec = Decoders([spec, {"name": "count", "n_classes": 3, "continuous": False, "existence": False}])
    out = {"size": probs.log(), "count": torch.tensor([[0.4, 0.0, 0.3]]).repeat(4, 1)}
    classes = dec.classes(out, "median")
    assert classes["size"].tolist() == [2, 4, 4, 3]
    assert classes["count"].tolist() == [0, 0, 0, 0]  # discrete parameters keep the argmax
    assert dec.classes(out)["size"].tolist() == [0, 4, 4, 3]


@pytest.mark.parametrize("variant", VARIANTS)
def test_variants_train_step_and_predict(variant):
    torch.manual_seed(0)
    model = GeoCodeModule(HEADS, variant=variant)
    model.log = model.log_dict = lambda *a, **k: None
    batch = {"points": torch.randn(4, 60, 3), "sketch": torch.rand(4, 1, 224, 224),
             "labels": torch.tensor([[4, 0, 1], [0, 2, 3], [2, 1, 0], [1, 0, 2]])}
    loss = model.training_step(batch, 0)
    loss.backward()
    assert torch.isfinite(loss) and loss.item() > 0
    assert all(p.grad is not None for p in model.parameters() if p.requires_grad)
    pred = model.eval().predict_classes(sketches=batch["sketch"][:1])
    assert pred["sketch"].shape == (1, 3) and (pred["sketch"][0] < torch.tensor([5, 3, 4])).all()
    if variant != "huang":
        assert model.predict_classes(points=batch["points"][:1])["points"].shape == (1, 3)


def test_the_sketch_loss_reads_the_sketches_own_labels():
    """A batch may pair each cloud with a sketch of another shape ("sketch_labels")."""
    torch.manual_seed(0)
    model = GeoCodeModule(HEADS).eval()
    logged = {}
    model.log = lambda name, value, **k: logged.__setitem__(name, float(value))
    model.log_dict = lambda *a, **k: None
    labels = torch.tensor([[4, 0, 1], [0, 2, 3]])
    batch = {"points": torch.randn(2, 60, 3), "sketch": torch.rand(2, 1, 224, 224), "labels": labels}
    model._step(batch, "train")
    same = dict(logged)
    model._step({**batch, "sketch_labels": labels.flip(0)}, "train")
    assert logged["train/loss_points"] == same["train/loss_points"]
    assert logged["train/loss_sketch"] != same["train/loss_sketch"]
    model._step({**batch, "sketch_labels": labels}, "train")
    assert logged["train/loss_sketch"] == same["train/loss_sketch"]


def test_huang_reads_sketches_only_with_two_networks():
    model = GeoCodeModule(HEADS, variant="huang")
    assert model.modalities == ["sketch"]
    assert not any(isinstance(m, (DGCNN, DGCNNReference)) for m in model.modules())
    discrete, continuous = model.branches
    assert [s["name"] for s in discrete.decoder("sketch").specs] == ["count"]
    assert [s["name"] for s in continuous.decoder("sketch").specs] == ["size", "width"]
    assert discrete.sketch is not continuous.sketch                      # an encoder each
    assert continuous.decoder("sketch").modes == {"size": "reg", "width": "reg"}
    with pytest.raises(ValueError, match="huang model takes no points input"):
        model(points=torch.randn(2, 60, 3))
    with pytest.raises(ValueError, match="takes sketch"):
        GeoCodeModule(HEADS, variant="huang", modalities=["points"])
    assert GeoCodeModule(HEADS, modalities=["points"]).modalities == ["points"]


# Head outputs for HEADS whose losses are worked out by hand: zero logits cost ln(classes);
# the regression heads predict size 0.5 (label 2 of 4 values: 2/3), visible (0), and width
# 0.0 (label 3 of 4 values: 1.0).
LABELS = torch.tensor([[2, 1, 3]])
ZERO_LOGITS = {"size": torch.zeros(1, 5), "count": torch.zeros(1, 3), "width": torch.zeros(1, 4)}
REGRESSED = {"size": torch.tensor([[0.5, 0.0]]), "count": torch.zeros(1, 3), "width": torch.tensor([[0.0]])}
CLASSIFIED_LOSS = math.log(5) + math.log(3) + math.log(4)
REGRESSED_LOSS = (0.5 - 2 / 3) ** 2 + math.log(3) + 1.0


@pytest.mark.parametrize(("variant", "outputs", "expected"), [
    ("joint", ZERO_LOGITS, CLASSIFIED_LOSS),
    ("separate", ZERO_LOGITS, CLASSIFIED_LOSS),
    ("regression", REGRESSED, REGRESSED_LOSS),
    ("huang", REGRESSED, REGRESSED_LOSS),
])
def test_variant_loss_on_a_hand_computed_example(variant, outputs, expected):
    model = GeoCodeModule(HEADS, variant=variant)
    for modality in model.modalities:
        assert model._loss(outputs, LABELS, modality).item() == pytest.approx(expected, rel=1e-6)
    if variant == "separate":
        branch = model.branches[0]
        assert branch.decoder("points") is not branch.decoder("sketch")


@pytest.mark.parametrize("variant", VARIANTS)
def test_shared_decoders_keep_the_statistics_of_both_modalities_together(variant):
    """Training normalises a decoder's BatchNorm input with its batch's statistics and keeps
    their running average for evaluation. A decoder shared by both modalities must see them
    in one batch: called once per modality, it would keep a blend of two statistics that
    training never normalised with, and eval-mode predictions would suffer (the point
    branch stayed near the majority class on the mini profile; docs/design.md#embedding-norm)."""
    torch.manual_seed(0)
    model = GeoCodeModule(HEADS, variant=variant).train()
    seen = {}
    for b, branch in enumerate(model.branches):
        for key, decoders in branch.decoders.items():
            head = next(iter(decoders.heads.values()))
            head[1].momentum = 1.0  # running mean = the last batch's mean
            head[0].register_forward_hook(lambda m, i, out, key=(b, key), bn=head[1]:
                                          seen.setdefault(key, []).append((out, bn)))
    points = torch.randn(5, 60, 3) if "points" in model.modalities else None  # huang: sketches only
    with torch.no_grad():
        model(points, torch.rand(3, 1, 64, 64))
    sizes = {"points": 0 if points is None else 5, "sketch": 3}
    for (_, key), calls in seen.items():
        assert len(calls) == 1, key  # one call per forward: both modalities, or one if separate
        out, bn = calls[0]
        assert len(out) == {"common": sum(sizes.values()), **sizes}[key]
        torch.testing.assert_close(bn.running_mean, out.mean(dim=0))


def test_cosine_schedule_warms_up_then_decays():
    from geocode.models.module import cosine_factor

    factors = [cosine_factor(e, warmup=2, total=10) for e in range(10)]
    assert factors[:3] == pytest.approx([1 / 3, 2 / 3, 1.0])
    assert factors[-1] == pytest.approx(0.05)
    assert all(a > b for a, b in zip(factors[2:], factors[3:], strict=False))  # decays after the warmup
    with pytest.raises(ValueError, match="train.schedule='linear'"):
        GeoCodeModule(HEADS, schedule="linear")


def _compose_model(name):
    """The composed config's model group; the group file alone where conf/config.yaml is missing."""
    from omegaconf import OmegaConf

    from geocode.config import compose
    from geocode.paths import repo_root

    if (repo_root() / "conf" / "config.yaml").exists():
        return compose([f"model={name}", "profile=smoke"]).model
    return OmegaConf.load(repo_root() / "conf" / "model" / f"{name}.yaml")


@pytest.mark.parametrize("name", VARIANTS)
def test_model_configs_compose_and_instantiate(name):
    from hydra.utils import instantiate

    cfg = _compose_model(name)
    model = instantiate(cfg, heads=HEADS, lr=1e-2, step_size=20, gamma=0.9, _convert_="all")
    assert isinstance(model, GeoCodeModule) and model.hparams.variant == name
    assert model.parameter_names == ["size", "count", "width"]


def test_bench_epoch_counts_the_steps_of_an_epoch():
    from geocode.bench.train import bench_epoch

    started = time.perf_counter()
    out = bench_epoch(clouds=5, sketches=10, batch=2, device="cpu", n_points=64, n_heads=3)
    wall = time.perf_counter() - started
    assert out["steps"] == 3 and out["clouds"] == 6 and out["sketches"] == 12
    assert 0 < out["epoch_s"] < wall and out["device"] == "cpu"      # the steps alone, not the set-up
    huang = bench_epoch(clouds=5, sketches=10, batch=2, device="cpu", n_points=64, n_heads=3, variant="huang")
    assert huang["clouds"] == 0 and huang["sketches"] == 12
    first = bench_epoch(clouds=5, sketches=10, batch=2, device="cpu", n_points=64, n_heads=3, max_steps=1)
    assert first["steps"] == 3 and first["timed_steps"] == 1 and first["clouds"] == 6     # the epoch's, not the timed
    assert first["epoch_s"] == pytest.approx(3 * first["step_s"])
    half = bench_epoch(clouds=5, sketches=10, batch=2, device="cpu", n_points=64, n_heads=3, max_steps=1,
                       sketch_bfloat16=True)
    assert half["sketch_bfloat16"] and not first["sketch_bfloat16"]


def test_embedding_norm_gives_the_shared_decoders_each_modality_standardised():
    """A DGCNN pools rectified features and the sketch encoder ends in a linear layer: their
    embeddings differ in scale. With `embedding_norm` each modality's embedding is batch-
    normalised on its own before the shared decoders (docs/design.md#embedding-norm)."""
    torch.manual_seed(0)
    seen = []
    for norm in (False, True):
        model = GeoCodeModule(HEADS, variant="joint", embedding_norm=norm).train()
        head = next(iter(model.branches[0].decoders["common"].heads.values()))
        head[0].register_forward_hook(lambda m, i, out: seen.append(i[0]))
        with torch.no_grad():
            model(torch.randn(6, 60, 3) * 5, torch.rand(6, 1, 64, 64))
    plain, normed = seen[0], seen[1]
    assert set(model.branches[0].norms) == {"points", "sketch"}
    for part in normed.split([6, 6]):          # points, then sketches: each zero mean, unit variance
        torch.testing.assert_close(part.mean(dim=0), torch.zeros(part.shape[1]), atol=1e-5, rtol=0)
        torch.testing.assert_close(part.var(dim=0, unbiased=False), torch.ones(part.shape[1]), atol=0.02, rtol=0)  # eps
    assert not torch.allclose(plain[:6].mean(dim=0), plain[6:].mean(dim=0), atol=0.1)   # unlike without
    assert len(GeoCodeModule(HEADS, variant="huang").branches[0].norms) == 0


def test_reader_gives_the_expected_value_of_shown_parameters():
    """Continuous heads only: the probability-weighted mean of the value classes (their own
    probabilities renormalised), nothing where the existence class has more than half."""
    from types import SimpleNamespace

    import numpy as np

    from geocode.checkpoints import reader
    from geocode.recipe import RecipeParameter

    height = RecipeParameter("height", "float", 0.0, 1.0, 0.5, 3, np.array([0.0, 0.5, 1.0]))
    legs = RecipeParameter("legs", "int", 3, 4, 4, None, np.array([3.0, 4.0]))
    arm = RecipeParameter("arm", "float", 0.0, 2.0, 1.0, 2, np.array([0.0, 2.0]), visible_if=object())
    logits = {"height": torch.log(torch.tensor([[0.5, 0.25, 0.25], [0.0, 0.0, 1.0]])),
              "legs": torch.zeros(2, 2),
              "arm": torch.log(torch.tensor([[0.1, 0.3, 0.6], [0.35, 0.25, 0.4]]))}
    model = lambda sketches: {"sketch": logits}   # noqa: E731
    read = reader(model, SimpleNamespace(parameters=[height, legs, arm]), "sketch")
    first, second = read(np.ones((2, 1, 8, 8), dtype=np.float32))
    assert first == {"height": pytest.approx(0.375)}
    assert second == {"height": pytest.approx(1.0), "arm": pytest.approx(0.5 / 0.6)}


def test_the_mean_read_takes_the_expected_value_of_each_shown_continuous_parameter():
    """eval.decode=mean: a continuous parameter the network sees as present takes the expected
    value of its distribution (off the class grid); a hidden one keeps the existence class's
    default; discrete ones keep their likeliest class. The median read stays on the grid."""
    from types import SimpleNamespace

    import numpy as np

    from geocode.checkpoints import predicted_values
    from geocode.models.heads import Decoders
    from geocode.recipe import RecipeParameter

    height = RecipeParameter("height", "float", 0.0, 1.0, 0.5, 3, np.array([0.0, 0.5, 1.0]))
    legs = RecipeParameter("legs", "int", 3, 4, 4, None, np.array([3.0, 4.0]))
    arm = RecipeParameter("arm", "float", 0.0, 2.0, 1.0, 2, np.array([0.0, 2.0]), visible_if=object())
    specs = [{"name": p.name, "n_classes": p.n_classes, "continuous": p.kind == "float",
              "existence": p.has_existence} for p in (height, legs, arm)]
    decoders = Decoders(specs, in_dim=8)
    logits = {"height": torch.log(torch.tensor([[0.5, 0.25, 0.25], [0.1, 0.1, 0.8]])),
              "legs": torch.tensor([[0.0, 1.0], [1.0, 0.0]]),
              "arm": torch.log(torch.tensor([[0.1, 0.3, 0.6], [0.45, 0.25, 0.3]]))}
    model = SimpleNamespace(parameter_names=["height", "legs", "arm"],
                            classes=lambda out, modality, decode: torch.stack(
                                list(decoders.classes(out, decode).values()), dim=1))
    params = {p.name: p for p in (height, legs, arm)}
    recipe = SimpleNamespace(parameters=[height, legs, arm], values_from_classes=lambda idx: {
        n: float(params[n].classes[c]) if c < params[n].n_values else params[n].default for n, c in idx.items()})

    first, second = predicted_values(model, recipe, logits, "points", "mean")
    assert first == {"height": pytest.approx(0.375), "legs": 4.0, "arm": 1.0}        # arm hidden: its default
    assert second == {"height": pytest.approx(0.85), "legs": 3.0, "arm": pytest.approx(0.5 / 0.7)}
    assert predicted_values(model, recipe, logits, "points", "median") == [
        {"height": 0.0, "legs": 4.0, "arm": 1.0}, {"height": 1.0, "legs": 3.0, "arm": 0.0}]
