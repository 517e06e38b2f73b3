"""The model card (`geocode.card`): written from what a run folder holds."""

import json

import pandas as pd
import yaml

from geocode import paths
from geocode.card import write_card


def test_the_card_tells_the_data_the_numbers_and_the_limits(tmp_path):
    run = tmp_path / "chair" / "joint"
    (run / "eval").mkdir(parents=True)
    paths.run_config_file(run).write_text(yaml.safe_dump({
        "profile_name": "mini", "seed": 0, "domain": {"name": "chair"}, "model": {"variant": "joint"},
        "data": {"variations": {"train": 2}, "points": {"fps": 1024, "train_random": 512},
                 "sketch": {"cameras": [{"name": "az35"}]}},
        "train": {"max_epochs": 16, "batch_size": 33, "lr": 0.003}}))
    paths.summary_file(run).write_text(json.dumps(
        {"best_val_acc_points": 0.62, "best_val_acc_sketch": 0.61, "majority_val_acc": 0.47}))
    card = write_card(run).read_text()
    assert card.startswith("# chair / joint") and "points 0.620" in card and "not evaluated yet" in card
    rows = [dict(modality=m, chamfer=c, source="test", noise=0.0, sparse=0)
            for m, c in (("pc", 0.002), ("pc", 0.004), ("nearest", 0.005))]
    pd.DataFrame(rows).to_parquet(paths.metrics_file(run))
    paths.real_bench_file(run).write_text(json.dumps(
        {"shapes": 11, "median_network": 0.0052, "median_fit": 0.0031, "median_nearest": 0.0041,
         "median_defaults": 0.0172, "seconds_median": 21.5}))
    card = write_card(run).read_text()
    assert "point clouds 0.00300" in card and "the nearest training shape 0.00500" in card
    assert "11 files" in card and "network + fit 0.0031" in card and "## Where it fails" in card
