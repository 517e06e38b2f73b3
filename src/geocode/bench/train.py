"""Throughput of the point encoders, single-sample inference latency and the time of a training
epoch (`geocode bench train`, `geocode bench epoch`; docs/paper-numbers.md#training)."""

from __future__ import annotations

import numpy as np
import torch

from geocode.errors import UserError
from geocode.models.dgcnn import DGCNN, DGCNNReference
from geocode.models.module import GeoCodeModule
from geocode.timing import Stopwatch, seconds_per_call


def _train_step(model: torch.nn.Module, points: torch.Tensor):
    def step():
        model.zero_grad(set_to_none=True)
        model(points).square().mean().backward()

    return step


def surface_clouds(batch: int, n_points: int, seed: int = 0) -> torch.Tensor:
    """Clouds as the dataset has them (docs/paper-numbers.md#dataset-generation: farthest points +
    random ones of a dense
    surface sample), of a capsule, one sample per cloud. Shapes: -> (B, N, 3)."""
    import trimesh  # only the benchmark needs meshes

    from geocode.points import make_clouds

    mesh = trimesh.creation.capsule(height=1.2, radius=0.4)
    fps = n_points * 15 // 23  # 1500 of 2300, as in docs/paper-numbers.md#dataset-generation
    out = []
    for i in range(batch):
        cl = make_clouds(mesh, surface=30000, fps=fps, random=n_points - fps, rng=np.random.default_rng(seed + i))
        out.append(np.concatenate([cl["fps"], cl["random"]]))
    return torch.from_numpy(np.stack(out))


def bench_train(batch: int = 33, n_points: int = 2300, repeats: int = 3, n_heads: int = 39, seed: int = 0) -> dict:
    """Samples/s of forward+backward (train mode) of DGCNNReference and DGCNN on one batch
    of surface clouds, and eval-mode latency of the whole joint model for one point cloud
    and one sketch (inference_ms: the slower of the two), plus per-sample time of a batched
    prediction. Times are the best of `repeats` runs (the least disturbed on a busy
    machine)."""
    torch.manual_seed(seed)
    points = surface_clouds(batch, n_points, seed)  # (B, N, 3)
    ref = DGCNNReference().train()
    fast = DGCNN().train()
    fast.load_state_dict(ref.state_dict())
    t_fast = seconds_per_call(_train_step(fast, points), repeats, best=True)
    t_ref = seconds_per_call(_train_step(ref, points), max(1, repeats - 1), best=True)
    heads = [{"name": f"p{i}", "n_classes": 5 + i % 3, "continuous": True, "existence": i % 4 == 0}
             for i in range(n_heads)]
    model = GeoCodeModule(heads).eval()
    one_cloud = points[:1]
    one_sketch = torch.rand(1, 1, 224, 224)
    with torch.inference_mode():
        pc_s = seconds_per_call(lambda: model.predict_classes(points=one_cloud), 30, best=True)
        sk_s = seconds_per_call(lambda: model.predict_classes(sketches=one_sketch), 30, best=True)
        batch_s = seconds_per_call(lambda: model.predict_classes(points=points), 2, best=True)
    return {
        "reference_samples_per_s": batch / t_ref,
        "fast_samples_per_s": batch / t_fast,
        "speedup": t_ref / t_fast,
        "inference_ms": 1000 * max(pc_s, sk_s),
        "inference_points_ms": 1000 * pc_s,
        "inference_sketch_ms": 1000 * sk_s,
        "batched_points_ms_per_sample": 1000 * batch_s / batch,
        "threads": torch.get_num_threads(),
    }


def bench_epoch(clouds: int = 9330, sketches: int = 18660, batch: int = 33, device: str = "auto",
                n_points: int = 2300, n_heads: int = 39, seed: int = 0, variant: str = "joint",
                max_steps: int | None = None, sketch_bfloat16: bool = False) -> dict:
    """Seconds of one training epoch of a model variant at a dataset size (default: the
    paper-scale vase, 9330 clouds and 18660 sketches), on random tensors of the inputs'
    shapes kept on the device (data loading not included): ceil(clouds / batch) Adam
    steps, each on `batch` clouds (for a variant that reads them) and the matching share
    of the sketches. With `max_steps`, only the first max_steps are timed and the epoch's
    time is their mean times the epoch's steps ("timed_steps" says how many were timed)."""
    dev = _device(device)
    torch.manual_seed(seed)
    heads = [{"name": f"p{i}", "n_classes": 5 + i % 3, "continuous": True, "existence": i % 4 == 0}
             for i in range(n_heads)]
    model = GeoCodeModule(heads, variant=variant, sketch_bfloat16=sketch_bfloat16).to(dev).train()
    opt = torch.optim.Adam(model.parameters(), lr=1e-3)
    steps = -(-clouds // batch)
    per_step = max(1, round(batch * sketches / clouds))
    points = torch.rand(batch, n_points, 3, device=dev) * 2 - 1
    sketch = torch.rand(per_step, 1, 224, 224, device=dev)
    labels = {m: torch.stack([torch.randint(h["n_classes"], (n,), device=dev) for h in heads], dim=1)
              for m, n in (("points", batch), ("sketch", per_step))}

    inputs = {"points": points if "points" in model.modalities else None, "sketches": sketch}

    def step():
        out = model(**inputs)
        loss = sum(model._loss(out[m], labels[m], m) for m in out)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    step()  # warm-up (kernels, caches)
    _sync(dev)
    timed = min(steps, max_steps or steps)
    with Stopwatch() as clock:
        for _ in range(timed):
            step()
        _sync(dev)
    return {"epoch_s": clock.seconds * steps / timed, "steps": steps, "timed_steps": timed,
            "step_s": clock.seconds / timed, "variant": variant,
            "clouds": steps * batch if inputs["points"] is not None else 0, "sketches": steps * per_step,
            "device": torch.cuda.get_device_name(dev) if dev.type == "cuda" else "cpu",
            "threads": torch.get_num_threads(), "sketch_bfloat16": sketch_bfloat16}


def _device(name: str) -> torch.device:
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name not in ("cpu", "cuda"):
        raise UserError(f"--device {name}", "unknown device", "use auto, cpu or cuda")
    if name == "cuda" and not torch.cuda.is_available():
        raise UserError("--device cuda", "torch sees no CUDA GPU here", "use --device cpu or auto")
    return torch.device(name)


def _sync(dev: torch.device) -> None:
    if dev.type == "cuda":
        torch.cuda.synchronize(dev)
