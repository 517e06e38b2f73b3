"""Throughput and disk of a domain's dataset stages at a profile's settings, and the hours its
whole dataset takes (`geocode bench dataset`).

The dataset's size is counted as the sample step writes it (`steps.dataset.split_sizes`);
the domain's training recipes are sampled as that step draws them (pure Python, nothing
written), and a slice of them, spread over the forced parameters, then goes through the
export, sketch and points shard jobs of the workflow, one process, into a temporary folder.
Rates exclude each job's start-up (Blender, the program, the renderer: seconds a job, over
hundreds of shapes a shard)."""

from __future__ import annotations

import logging
import math
import tempfile
from pathlib import Path

from omegaconf import DictConfig

from geocode import meshio, paths
from geocode.blender import export, sketch
from geocode.config import split_variations
from geocode.points import make_clouds, points_shard
from geocode.recipe import save_recipes
from geocode.steps.dataset import assign_shards, sample_dataset, split_cameras, split_sizes, spread_subset
from geocode.timing import Stopwatch

log = logging.getLogger(__name__)

STAGE_FOLDERS = {"meshes": "shapes", "sketches": "sketches", "clouds": "points"}   # what a split's folder holds


def bench_dataset(cfg: DictConfig, n: int = 24, jobs: int = 1) -> dict:
    """Export shapes/s, sketch views/s and clouds/s on n training shapes of cfg.domain, MB per
    1000 shapes of each stage's files, and the domain's whole dataset at these settings: its
    shapes, views, disk and hours (job-hours; wall hours with `jobs` jobs at once)."""
    domain = cfg.domain.name
    program = export.load_program(domain)
    recipe = program.recipe()
    with Stopwatch() as sampling:
        train = sample_dataset(recipe, split_variations(cfg, domain), seed=cfg.seed, domain=domain)["train"]
        train = spread_subset(train, cfg.data.max_shapes.train)
    shapes = split_sizes(cfg, recipe, domain)
    drawn = split_sizes(cfg, recipe, domain, clouds=False)
    views = {s: drawn[s] * len(split_cameras(cfg.data.sketch.cameras, s)) for s in paths.SPLITS}
    with tempfile.TemporaryDirectory() as tmp:
        measured = measure_slice(cfg, program, recipe, spread_subset(train, n), Path(tmp) / "train")
    rates, disk = measured["rates"], measured["mb_per_1000_shapes"]
    hours = projected_hours(shapes, views, rates, sampling.seconds, jobs, cfg.data.shards)
    result = {
        "domain": domain, "profile": cfg.profile_name, "shapes_measured": measured["shapes"],
        **{k: round(v, 2) for k, v in rates.items()},
        **{f"{stage}_mb_per_1000_shapes": round(mb, 1) for stage, mb in disk.items()},
        "domain_shapes": sum(shapes.values()), "domain_views": sum(views.values()),
        "domain_split_shapes": shapes,
        "domain_disk_gb": round(disk_gb(shapes, views, disk, measured["views_per_shape"]), 2),
        "job_hours": round(hours["job"], 2), "jobs": jobs, "wall_hours": round(hours["wall"], 2),
        "epoch_size": f"--clouds {shapes['train']} --sketches {views['train']}",
    }
    log.info("bench dataset %s: %s", domain, result)
    return result


def measure_slice(cfg: DictConfig, program, recipe, frame, split_dir: Path) -> dict:
    """Run the export, sketch and points jobs on `frame`'s shapes as one shard of a training
    split in `split_dir`: {"shapes", "rates", "mb_per_1000_shapes", "views_per_shape"}."""
    s = cfg.data.sketch
    cameras = split_cameras(s.cameras, "train")
    save_recipes(assign_shards(frame, 1), paths.recipes_file(split_dir))
    with Stopwatch() as exporting:
        export.export_shard(split_dir, 0, cfg.domain.name, program, recipe)
    warm_up(split_dir, frame["id"].iloc[0], s.size)
    with Stopwatch() as sketching:
        sketch.sketch_shard(split_dir, 0, cameras=cameras, size=s.size, seed=cfg.seed, jitter=s.jitter,
                            elevation=s.elevation)
    with Stopwatch() as clouding:
        points_shard(split_dir, 0, cfg.data.points, cfg.seed)
    n = len(frame)
    rates = {"export_shapes_per_s": n / exporting.seconds,
             "sketch_views_per_s": n * len(cameras) / sketching.seconds,
             "clouds_per_s": n / clouding.seconds}
    mb = {stage: 1000 * folder_bytes(split_dir / folder) / n / 1e6 for stage, folder in STAGE_FOLDERS.items()}
    return {"shapes": n, "rates": rates, "mb_per_1000_shapes": mb, "views_per_shape": len(cameras)}


def warm_up(split_dir: Path, shape_id: str, size: int) -> None:
    """Outside the clock, what a shard job does once: build the sketch renderer, draw a view,
    and load the compiled cloud sampling."""
    mesh = meshio.read_obj(paths.shape_file(paths.shapes_dir(split_dir), shape_id))
    with tempfile.TemporaryDirectory() as tmp:
        sketch.sketch_mesh(mesh, {"warm": Path(tmp) / "warm.png"}, [sketch.Camera("warm", 35.0)], size=size)
    make_clouds(mesh, surface=200, fps=20, random=20)


def folder_bytes(folder: Path) -> int:
    return sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())


def projected_hours(shapes: dict[str, int], views: dict[str, int], rates: dict[str, float],
                    sample_s: float, jobs: int, shards: int) -> dict[str, float]:
    """{"job", "wall"} hours of a domain's dataset: every shape exported and sampled into
    clouds, every view drawn, at the measured rates. The wall clock with `jobs` at once is the
    job time shared among them, but never below the longest chain: one training shard's
    export, then its sketches."""
    total_shapes, total_views = sum(shapes.values()), sum(views.values())
    job_s = (sample_s + total_shapes / rates["export_shapes_per_s"] + total_views / rates["sketch_views_per_s"]
             + total_shapes / rates["clouds_per_s"])
    shard_shapes = math.ceil(shapes["train"] / shards)
    chain_s = (sample_s + shard_shapes / rates["export_shapes_per_s"]
               + shard_shapes * views["train"] / max(1, shapes["train"]) / rates["sketch_views_per_s"])
    return {"job": job_s / 3600, "wall": max(job_s / jobs, chain_s) / 3600}


def disk_gb(shapes: dict[str, int], views: dict[str, int], mb_per_1000: dict[str, float],
            views_per_shape: int) -> float:
    """The domain's dataset on disk: meshes and clouds per shape, sketches per view."""
    total_shapes, total_views = sum(shapes.values()), sum(views.values())
    mb = (total_shapes * (mb_per_1000["meshes"] + mb_per_1000["clouds"])
          + total_views * mb_per_1000["sketches"] / views_per_shape) / 1000
    return mb / 1000
