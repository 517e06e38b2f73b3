"""Trained models for inference: reading, checking and loading checkpoints, and predicting
classes, without Lightning (so `geocode reconstruct` and `predict` start fast).

    load_model(checkpoint) -> GeoCodeNet  # eval mode, weights_only loading
    predict_classes(model, points=... | sketches=...) -> (N, P) int64
    predict(checkpoint, points=None, sketches=None) -> {"points": (N, P), "sketch": (N, P)}
    predict_values(model, recipe, modality, inputs, decode) -> [{parameter: raw value}]
    ranked_prediction(model, recipe, modality, data, decode) -> (values, {parameter: top classes' values})
    reader(model, recipe, modality)(inputs) -> [{continuous parameter: expected value}]
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import torch

from geocode import paths
from geocode.errors import UserError, one_line
from geocode.models.network import GeoCodeNet

TOP_CLASSES = 3   # discrete options the fit may choose among, per parameter


class CheckpointError(UserError):
    """A checkpoint that cannot be read or does not fit; one line naming the file."""


def recipe_stamp(recipe) -> dict:
    """What a model was trained to predict: each parameter's class values ("hidden" for the
    existence class), and a hash of the whole recipe. Checkpoints record it; prediction
    decodes only on the same grid."""
    grid = {p.name: [float(c) for c in p.classes] + (["hidden"] if p.has_existence else [])
            for p in recipe.parameters}
    text = json.dumps(recipe.to_dict(), sort_keys=True, default=str)
    return {"hash": hashlib.sha1(text.encode()).hexdigest()[:10], "grid": grid}


def read_checkpoint(path: str | Path, map_location="cpu") -> dict:
    """torch.load(weights_only=True) of a geocode checkpoint; CheckpointError otherwise."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(path, "checkpoint not found", "train first")
    try:
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
    except Exception as exc:  # torch raises many types for a broken file
        raise CheckpointError(path, f"not a readable checkpoint ({one_line(exc)})",
                              "retrain or pick another file") from None
    if not isinstance(ckpt, Mapping) or "state_dict" not in ckpt or "heads" not in ckpt.get("hyper_parameters", {}):
        raise CheckpointError(path, "not a geocode model checkpoint (no state_dict / heads)",
                              "pick a best.ckpt or last.ckpt")
    return dict(ckpt)


RETRAIN = "retrain (`snakemake -j2 results/tables` sets a stale run aside and trains afresh)"


def check_recipe(ckpt: Mapping, recipe, path) -> None:
    """Refuse to decode a checkpoint's classes on another class grid than it was trained on."""
    from geocode.models.heads import head_specs

    if "recipe" in ckpt:
        mine, theirs = recipe_stamp(recipe)["grid"], ckpt["recipe"]["grid"]
    else:  # a checkpoint from before the stamp: the class counts of its heads
        mine = {h["name"]: h["n_classes"] for h in head_specs(recipe)}
        theirs = {h["name"]: h["n_classes"] for h in ckpt["hyper_parameters"]["heads"]}
    if set(mine) != set(theirs):
        raise CheckpointError(path, "trained for other parameters than this recipe's (another program, "
                              "or an older version of this one)", f"pass a checkpoint of this program, or {RETRAIN}")
    for name in sorted(set(mine) | set(theirs)):
        if mine.get(name) != theirs.get(name):
            # a program or recipe changed since training (its classes now mean other values)
            raise CheckpointError(path, f"trained on another recipe ({name}: classes {theirs.get(name)}, "
                                  f"the recipe gives {mine.get(name)})",
                                  f"predict with the recipe it was trained on, or {RETRAIN}")


def load_model(checkpoint: str | Path, map_location="cpu", recipe=None) -> GeoCodeNet:
    """A trained network in eval mode, rebuilt from the checkpoint's hyperparameters (no
    Lightning); with `recipe`, only if it was trained on that recipe's class grid."""
    ckpt = read_checkpoint(checkpoint, map_location)
    if recipe is not None:
        check_recipe(ckpt, recipe, checkpoint)
    try:
        model = GeoCodeNet(**ckpt["hyper_parameters"])
        model.load_state_dict(ckpt["state_dict"])
    except (TypeError, ValueError, RuntimeError, KeyError) as exc:
        raise CheckpointError(checkpoint, f"checkpoint does not fit the model ({one_line(exc)})",
                              "retrain or pick another file") from None
    return model.eval()


def _as_tensor(x: np.ndarray, device) -> torch.Tensor:
    t = torch.as_tensor(np.asarray(x))
    if t.dtype == torch.uint8:
        t = t.float() / 255.0
    return t.to(device=device, dtype=torch.float32)


def predict_classes(model: GeoCodeNet, points=None, sketches=None, batch_size: int = 64,
                    decode: str = "argmax") -> np.ndarray:
    """Class indices (N, P) int64 for one modality, in model.parameter_names order
    (`decode`: how continuous parameters are read, eval.decode).

    Shapes: points (N, M, 3) (any M >= 1), or sketches (N, 1, H, W) / (N, H, W) float in
    [0, 1] (white background) or uint8.
    """
    if (points is None) == (sketches is None):
        raise ValueError("predict_classes: give exactly one of points= or sketches=")
    modality, inputs = ("points", points) if points is not None else ("sketch", sketches)
    inputs = np.asarray(inputs)
    if modality == "points" and (inputs.ndim != 3 or inputs.shape[-1] != 3):
        raise ValueError(f"points: expected (N, M, 3), got {inputs.shape}")
    if modality == "sketch":
        inputs = inputs[:, None] if inputs.ndim == 3 else inputs
        if inputs.ndim != 4 or inputs.shape[1] != 1:
            raise ValueError(f"sketches: expected (N, 1, H, W), got {inputs.shape}")
    model.eval()
    device = next(model.parameters()).device
    out = []
    for s in range(0, len(inputs), batch_size):
        x = _as_tensor(inputs[s : s + batch_size], device)
        kw = {"points": x} if modality == "points" else {"sketches": x}
        out.append(model.predict_classes(**kw, decode=decode)[modality].cpu().numpy())
    n_params = len(model.parameter_names)
    return np.concatenate(out) if out else np.zeros((0, n_params), dtype=np.int64)


def predict(checkpoint: str | Path, points=None, sketches=None, batch_size: int = 64,
            device: str | None = None) -> dict:
    """{"names": parameter names, "points": (N, P), "sketch": (N, P)} for the inputs given."""
    model = load_model(checkpoint)
    if device:
        model = model.to(device)
    result: dict = {"names": list(model.parameter_names)}
    if points is not None:
        result["points"] = predict_classes(model, points=points, batch_size=batch_size)
    if sketches is not None:
        result["sketch"] = predict_classes(model, sketches=sketches, batch_size=batch_size)
    return result


def predicted_values(model, recipe, outputs: Mapping[str, torch.Tensor], modality: str,
                     decode: str) -> list[dict[str, float]]:
    """Raw values per input from the head outputs of one modality (`decode`: eval.decode). The
    mean read takes each continuous parameter that the network sees as present at the expected
    value of its distribution over the value classes: the value nearest the truth in squared
    distance, as the Chamfer distance counts it (docs/design.md#decoding)."""
    classes = model.classes(outputs, modality, decode).tolist()
    rows = [recipe.values_from_classes(dict(zip(model.parameter_names, c, strict=True))) for c in classes]
    if decode != "mean":
        return rows
    column = {name: j for j, name in enumerate(model.parameter_names)}
    for p in recipe.parameters:
        if p.kind != "float" or outputs[p.name].shape[1] != p.n_classes:   # discrete, or regressed
            continue
        expected = expected_values(outputs[p.name], p)
        for row, c, value in zip(rows, classes, expected.tolist(), strict=True):
            if c[column[p.name]] < p.n_values:                              # not the existence class
                row[p.name] = value
    return rows


def expected_values(logits: torch.Tensor, parameter) -> np.ndarray:
    """The expected raw value of a continuous parameter under the predicted distribution over
    its value classes (the existence class left out). Shapes: (B, n_classes) -> (B,)."""
    shown = torch.softmax(logits.float(), dim=1)[:, :parameter.n_values].numpy()
    return shown @ np.asarray(parameter.classes, dtype=np.float64) / np.maximum(shown.sum(axis=1), 1e-12)


def predict_values(model, recipe, modality: str, inputs: np.ndarray, decode: str,
                   batch_size: int = 64) -> list[dict[str, float]]:
    """`predicted_values` of a batch of inputs of one modality ("points": (N, M, 3); "sketch":
    (N, 1, H, W) or (N, H, W)), in eval mode."""
    key = "points" if modality == "points" else "sketches"
    inputs = np.asarray(inputs)
    if modality == "sketch" and inputs.ndim == 3:
        inputs = inputs[:, None]
    model.eval()
    device = next(model.parameters()).device
    rows = []
    with torch.inference_mode():
        for s in range(0, len(inputs), batch_size):
            outputs = model(**{key: _as_tensor(inputs[s : s + batch_size], device)})[modality]
            rows += predicted_values(model, recipe, {k: v.cpu() for k, v in outputs.items()}, modality, decode)
    return rows


def default_checkpoint(cfg, domain: str) -> Path:
    """The domain's joint model of the run in `cfg`: what `geocode reconstruct` uses."""
    return paths.checkpoint_file(paths.run_dir(cfg, domain, "joint"))


def ranked_prediction(model, recipe, modality: str, data: np.ndarray, decode: str, k: int = TOP_CLASSES):
    """(raw values of the predicted classes (`decode`: eval.decode), {discrete parameter: its
    k most probable raw values}, the parameters the network is least sure of first: by the
    entropy of its distribution over the values) for one input of a modality (points (N, 3) or sketch (1, H, W))."""
    return ranked_predictions(model, recipe, modality, data[None], decode, k)[0]


def ranked_predictions(model, recipe, modality: str, batch: np.ndarray, decode: str,
                       k: int = TOP_CLASSES) -> list[tuple[dict, dict]]:
    """`ranked_prediction` for each input of a batch (B, N, 3) or (B, 1, H, W), in one pass."""
    x = torch.as_tensor(batch, dtype=torch.float32)
    with torch.inference_mode():
        outputs = model(**{"points" if modality == "points" else "sketches": x})[modality]
    out = []
    for b, start in enumerate(predicted_values(model, recipe, outputs, modality, decode)):
        options, doubt = {}, {}
        for p in recipe.parameters:
            logits = outputs[p.name][b]
            if p.kind == "float" or len(logits) != p.n_classes:   # continuous, or regressed
                continue
            ranked = torch.argsort(logits, descending=True)[:k].tolist()
            values = [float(p.classes[c]) if c < len(p.classes) else float(p.default) for c in ranked]
            options[p.name] = list(dict.fromkeys(values))   # the existence class may repeat one
            shown = torch.softmax(logits, dim=0)[:p.n_values]
            shown = shown / shown.sum().clamp_min(1e-12)
            doubt[p.name] = -float((shown * torch.log(shown.clamp_min(1e-12))).sum())
        out.append((start, {name: options[name] for name in sorted(options, key=lambda n: -doubt[n])}))
    return out


def reader(model, recipe, modality: str):
    """A function of a batch of inputs of `modality` ("points": (B, N, 3); "sketch": (B, 1, H, W))
    giving, per input, the network's reading of each continuous parameter that it sees as
    present: the expected raw value under its distribution over the value classes (smooth in
    the input, where the median and the argmax step from class to class). The fits' feedback
    (`fit.network_feedback`) compares the readings of the input and of a candidate."""
    heads = [p for p in recipe.parameters if p.kind == "float"]
    key = "points" if modality == "points" else "sketches"

    def read(batch: np.ndarray) -> list[dict[str, float]]:
        with torch.inference_mode():
            outputs = model(**{key: torch.as_tensor(batch, dtype=torch.float32)})[modality]
        out = [{} for _ in range(len(batch))]
        for p in heads:
            if outputs[p.name].shape[1] != p.n_classes:   # a regression head
                continue
            hidden = torch.softmax(outputs[p.name], dim=1)[:, -1].numpy() > 0.5
            value = expected_values(outputs[p.name], p)
            for b in range(len(out)):
                if not (p.has_existence and hidden[b]):
                    out[b][p.name] = float(value[b])
        return out

    return read
