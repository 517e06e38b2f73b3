"""Test conditions: the kinds of input a model is tested on (docs/paper-numbers.md#robustness).

Clean point clouds, sketches from each camera, noisy and sparse clouds, and point clouds and
sketches of simplified test meshes (source `s<factor>`). The conditions named in `eval.fit`
come twice: as predicted, and as fitted (`<condition>-fit`, modality "pc+fit" or
"sketch+fit": the prediction refined against its input, the cloud by `geocode.reconstruct.fit`, the
sketch by `geocode.reconstruct.sketchfit`).
"""

from __future__ import annotations

from omegaconf import DictConfig

MODALITY_NAMES = {"points": "pc", "sketch": "sketch"}  # the model's inputs -> metrics' modality
FITTED = "pc+fit"       # the modality of a cloud's prediction refined by `geocode.reconstruct.fit`
SKETCH_FITTED = "sketch+fit"   # ... of a sketch's, refined by `geocode.reconstruct.sketchfit`
FITS = {"pc": FITTED, "sketch": SKETCH_FITTED}   # modality -> its fitted modality


def robustness(variant: str) -> bool:
    """Whether a variant gets the full evaluation: the robustness inputs, the mean-shape
    baseline and the drop tests belong to the joint model's tables; the baselines and
    ablations are compared on clean inputs only."""
    return variant == "joint"


def conditions(cfg: DictConfig, modalities=("pc", "sketch"), full: bool = True) -> list[dict]:
    """The test inputs of one domain, as records {condition, modality, source, camera, noise,
    sparse}: the clean ones of `modalities` (pc, sketch), and with `full` the robustness inputs."""
    cams = list(cfg.data.sketch.cameras)
    trained = [c.name for c in cams if c.train]

    def cond(modality, source="test", camera="", noise=0.0, sparse=0):
        parts = [modality, source if source != "test" else "", camera,
                 f"noise{noise:g}" if noise else "", f"sparse{sparse}" if sparse else ""]
        return dict(condition="-".join(p for p in parts if p), modality=modality, source=source,
                    camera=camera, noise=float(noise), sparse=int(sparse))

    out = [cond("pc")] + [cond("sketch", camera=c.name) for c in cams]
    if not full:
        return [c for c in out if c["modality"] in modalities]
    out += [cond("pc", noise=s) for s in cfg.eval.noise]
    out += [cond("pc", sparse=n) for n in cfg.eval.sparse]
    for f in cfg.eval.simplify:
        out += [cond("pc", source=f"s{f}")] + [cond("sketch", source=f"s{f}", camera=c) for c in trained]
    return out + [fitted(c) for c in out if c["condition"] in cfg.eval.fit]


def fitted(cond: dict) -> dict:
    """The condition of a condition's predictions refined by the fit."""
    return {**cond, "condition": f"{cond['condition']}-fit", "modality": FITS[cond["modality"]]}


def unfitted(cond: dict) -> dict:
    """The inverse of `fitted`: the condition whose inputs the fit matches."""
    modality = next(m for m, f in FITS.items() if f == cond["modality"])
    return {**cond, "condition": cond["condition"].removesuffix("-fit"), "modality": modality}
