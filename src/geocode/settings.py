"""The settings groups of `conf/` as pydantic models (no bpy, no torch): every key's meaning
and valid values in one place, as the recipes' schemas are in `geocode.recipe`.

    check(cfg) -> Settings          # the composed config validated; ConfigError (one line) otherwise
    documented_keys() -> {key: (meaning, valid values)}   # what `geocode config --keys` prints
    MAPPINGS                        # keys whose value is a whole mapping (its keys are domains or variants)

The YAML files own every default; a model only says what a key means and which values it
takes (the one default here is a model key that a variant may leave to the network).
"""

import math
import re
import types
import typing
from typing import Annotated, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from geocode.errors import UserError
from geocode.paths import SPLITS

NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")  # stays one path component: no /, not . or ..


class ConfigError(UserError):
    """A bad override or config value; the message is one line naming the key and the fix."""


class Expect(str):
    """The valid values of a type, in words ("a whole number >= 1"), carried in its Annotated."""


# ---------------------------------------------------------------- value types


def words(kind) -> str:
    """The Expect of an Annotated type."""
    return next(str(m) for m in getattr(kind, "__metadata__", ()) if isinstance(m, Expect))


def whole(low: int, high: float = math.inf):
    text = f"a whole number >= {low}" + (f" and <= {high:g}" if high < math.inf else "")
    return Annotated[int, Field(ge=low), Field(le=high if high < math.inf else None), Expect(text)]


def number(low: float, high: float = math.inf, above: bool = False):
    bound = Field(gt=low) if above else Field(ge=low)
    text = f"a number {'>' if above else '>='} {low:g}" + (f" and <= {high:g}" if high < math.inf else "")
    return Annotated[float, bound, Field(le=high if high < math.inf else None), Expect(text)]


def optional(kind):
    return Annotated[kind | None, Expect(f"null or {words(kind)}")]


def each(kind):
    return Annotated[list[kind], Expect(f"a list, each {words(kind)}")]


def one_of(*choices: str):
    return Annotated[Literal[choices], Expect(" or ".join(choices) if len(choices) < 3
                                              else f"{', '.join(choices[:-1])} or {choices[-1]}")]


Name = Annotated[str, Field(pattern=rf"^{NAME.pattern}$"), Expect("a name of letters, digits, _, - and .")]
Text = Annotated[str, Field(min_length=1), Expect("a text")]
Flag = Annotated[bool, Expect("true or false")]
Fraction = number(0, 1)
Shapes = optional(whole(1))


def per_domain(value, expect: str):
    """null or a mapping {<domain>: value}."""
    return Annotated[dict[Name, value] | None, Expect(f"null or a mapping {{<domain>: {expect}}}")]


def key(meaning: str, **kwargs):
    """A settings key: its meaning (shown by `geocode config --keys`); no default unless given."""
    return Field(description=meaning, **kwargs)


# ---------------------------------------------------------------- groups


class Group(BaseModel):
    """A settings group: no unknown keys, no type coercion (1.5 is not a whole number)."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, populate_by_name=True)

    @model_validator(mode="before")
    @classmethod
    def _subgroups_are_mappings(cls, data):
        """A subgroup replaced by a value (train.augment=3, data.points=null) reads as an empty
        group, so that the message names its first missing key."""
        if not isinstance(data, dict):
            return data
        replaced = {name: {} for name, f in fields(cls).items()
                    if group_of(f.annotation) and name in data and not isinstance(data[name], dict)}
        return {**data, **replaced}


class Item(Group):
    """An entry of a list (a camera): a message names the entry, what it is and how to write one."""

    WHAT: typing.ClassVar[str]
    FORM: typing.ClassVar[str]


class Splits(Group):
    train: whole(1) = key("train shapes per parameter class")
    val: whole(1) = key("val shapes per parameter class")
    test: whole(1) = key("test shapes per parameter class")


class MaxShapes(Group):
    train: Shapes = key("keep at most this many train shapes (an even spread)")
    val: Shapes = key("keep at most this many val shapes (an even spread)")
    test: Shapes = key("keep at most this many test shapes (an even spread)")


class Points(Group):
    surface: whole(1) = key("area-weighted surface samples before farthest point sampling")
    fps: whole(1) = key("farthest-point-sampled points per cloud (<= surface)")
    random: whole(1) = key("uniform random points per cloud")
    train_random: whole(0) = key("random points added to the FPS points of a training item (<= random)")

    @model_validator(mode="after")
    def _within_the_samples(self):
        if not (self.fps <= self.surface and self.train_random <= self.random):
            raise ValueError("need fps <= surface and train_random <= random; lower fps or train_random")
        return self


class Camera(Item):
    WHAT = "a camera"
    FORM = "{name: <a plain name>, azimuth: <degrees>, train: true|false}"
    name: Name = key("the camera's name (in sketch file names)")
    azimuth: number(-360, 360) = key("degrees around the vertical axis")
    train: Flag = key("true: a training view")


class Sketch(Group):
    size: whole(8) = key("sketch width and height in pixels")
    elevation: number(-90, 90) = key("camera elevation, degrees above the horizon")
    jitter: number(0, 45) = key("+- degrees of seeded camera jitter")
    cameras: Annotated[list[Camera], Expect("a list of {name, azimuth, train}")] = key(
        "cameras: {name, azimuth in degrees, train: true for the training views}")

    @field_validator("cameras")
    @classmethod
    def _unique_with_a_training_view(cls, cameras: list[Camera]) -> list[Camera]:
        names = [c.name for c in cameras]
        if len(set(names)) != len(names) or not any(c.train for c in cameras):
            raise ValueError("camera names repeat or none has train: true; "
                             "give unique names and at least one training camera")
        return cameras


DomainSplits = Annotated[dict[Name, dict[Literal[SPLITS], whole(1)]] | None,
                         Expect("null or a mapping {<domain>: {train|val|test: a whole number >= 1}}")]


class Data(Group):
    variations: Splits
    domain_variations: DomainSplits = key("per-domain replacements of data.variations, {<domain>: {<split>: N}}: "
                                          "more shapes for the domains that need them")
    cloud_factor: whole(1) = key("training shapes per class as a multiple of variations.train; only the first "
                                 "variations.train of each class are drawn as sketches")
    max_shapes: MaxShapes
    shards: whole(1) = key("shards per split: the export, sketch and points jobs of each split")
    points: Points
    sketch: Sketch


class Model(Group):
    target: Text = key("the LightningModule class to build", alias="_target_")
    variant: Name = key("decoders: joint, separate, regression or huang (choose it with model=<variant>)")
    k: whole(1) = key("DGCNN neighbours per point")
    edge_channels: each(whole(1)) = key("channels of the EdgeConv layers")
    point_channels: whole(1) = key("DGCNN head width (embedding = 2 x this)")
    sketch_channels: Annotated[list[whole(1) | Literal["M"]],
                               Expect("a list of whole numbers >= 1 and M (2x2 max-pool)")] = key(
        "reduced VGG11 layers")
    sketch_pool: whole(1) = key("adaptive average pooling grid before the sketch encoder's linear layer")
    hidden: each(whole(1)) = key("widths of each decoder's hidden layers")
    dropout: number(0, 1) = key("decoder dropout probability")
    embedding_norm: Flag = key("a BatchNorm per modality on the encoders' embeddings")
    sketch_bfloat16: Flag = key("the sketch encoder's convolutions autocast to bfloat16")
    fast: Flag = key("the fast exact EdgeConv (false: the reference implementation)")


class PointAugment(Group):
    jitter: number(0, 0.1) = key("Gaussian jitter of training clouds (std, unit-sphere units)")
    scale: number(0, 0.5) = key("per-axis scaling of training clouds: factors in [1-s, 1+s]")
    dropout: number(0, 0.9) = key("share of a training cloud's points replaced by copies")


class SketchAugment(Group):
    flip: Fraction = key("probability of a horizontal flip of a training sketch")
    dilate: Fraction = key("probability of stroke dilation")
    erode: Fraction = key("probability of stroke erosion")
    kernel: whole(1) = key("dilation / erosion kernel size in pixels")


Batches = optional(number(0, above=True))


class Train(Group):
    max_epochs: whole(1) = key("training epochs")
    domain_epochs: per_domain(whole(1), "a whole number >= 1") = key(
        "per-domain replacements of train.max_epochs, {<domain>: N}: more epochs for the domains that need them")
    batch_size: whole(1) = key("items per batch")
    lr: number(0, above=True) = key("Adam learning rate")
    step_size: whole(1) = key("StepLR period, in epochs")
    gamma: number(0, 1, above=True) = key("StepLR factor")
    schedule: one_of("step", "cosine") = key(
        "learning-rate schedule: step (StepLR, the paper's) or cosine (warmup, then cosine decay)")
    warmup_epochs: whole(0) = key("epochs of linear warmup before the cosine decay")
    variant_epochs: Annotated[dict[Name, number(0, 1, above=True)],
                              Expect("a mapping {<variant>: a number > 0 and <= 1}")] = key(
        "each model variant's share of max_epochs, {<variant>: share}")
    accelerator: one_of("auto", "cpu", "gpu", "cuda", "mps") = key("Lightning accelerator")
    devices: Annotated[Literal["auto"] | whole(1), Expect("auto or a whole number >= 1")] = key(
        "Lightning devices: auto or a count")
    deterministic: Flag = key("deterministic torch algorithms (slower)")
    num_workers: whole(0) = key("data loader worker processes")
    limit_train_batches: Batches = key("null: all; a fraction (<= 1.0) or a count of batches per epoch")
    limit_val_batches: Batches = key("null: all; a fraction (<= 1.0) or a count of validation batches")
    log_every_n_steps: whole(1) = key("steps between logged training losses")
    progress_bar: Annotated[bool | None, Expect("null, true or false")] = key("null: only on an interactive terminal")
    out_dir: optional(Text) = key("run folder; null: <paths.runs>/<domain>/<model.variant>")
    eval_camera: optional(Name) = key("validation camera; null: the first training camera")
    modalities: Annotated[list[Literal["points", "sketch"]], Field(min_length=1),
                          Expect("a list of points and/or sketch")] = key(
        "the inputs trained on: points, sketch or both")
    augment_points: PointAugment
    augment: SketchAugment


class Eval(Group):
    chamfer_points: whole(1) = key("surface points per mesh for the Chamfer distance")
    simplify: each(whole(2)) = key("decimation factors of the test meshes (keep 1/f of the faces)")
    noise: each(number(0)) = key("Gaussian noise sigmas on the unit-sphere clouds")
    sparse: each(whole(1)) = key("point counts of the sparse random clouds")
    decode: one_of("argmax", "median", "mean") = key(
        "how a continuous parameter's value is read from its classification head: argmax (the paper's), "
        "median or mean (the expected value) of the predicted distribution")
    max_test_shapes: Shapes = key("evaluate on at most this many test shapes; null: all")
    variants: each(Name) = key("model variants the workflow trains and evaluates")
    ablations: each(Name) = key("decoder ablations trained for the ablation domains")
    ablation_domains: each(Name) = key("domains whose ablations are trained (the paper: the chair)")
    fit_budget: whole(0) = key("program evaluations of each test shape's fit (eval.fit)")
    reconstruct_budget: whole(0) = key("program evaluations of the fit of `geocode reconstruct` (--budget)")
    sketch_fit_budget: whole(0) = key("program evaluations of a drawing's fit: `geocode reconstruct` on a "
                                      "drawing, `bench fit --modality sketch`, eval.fit's sketch conditions")
    sketch_fit_domain_budget: per_domain(whole(0), "a whole number >= 0") = key(
        "per-domain sketch_fit_budget, {<domain>: N}, where a domain's fit gains from more "
        "(docs/design.md#drawing-fit)")
    sketch_fit_branches: per_domain(whole(1), "a whole number >= 1") = key(
        "per-domain searches of a drawing's fit, {<domain>: N}: one for each of the network's N likeliest options "
        "of its least sure discrete choice, the budget shared (docs/design.md#drawing-fit); other domains 1")
    sketch_fit_orders: per_domain(Annotated[int, Field(ge=1, le=2)], "1 or 2") = key(
        "per-domain sweep orders of a drawing's fit, {<domain>: 2}: each branch searched twice, its discrete "
        "switches judged before and after the continuous sweeps (docs/design.md#drawing-fit); other domains 1")
    max_fit_shapes: Shapes = key("fit the predictions of eval.fit's conditions on at most this many of the "
                                 "test shapes (an even spread); null: all")
    fit: each(Name) = key("test conditions (pc, pc-noise0.02, sketch-<camera>, ...) whose predictions are "
                          "also fitted: a '+ fit' row or column")


Steps = Annotated[list[number(0, 1, above=True)], Field(max_length=8),
                  Expect("a list of at most 8 numbers > 0 and <= 1")]


class CloudFit(Group):
    """`geocode.reconstruct.fit`: the search for the program's shape nearest a cloud."""

    sigma: number(0, 1, above=True) = key("CMA-ES's initial step, a share of each parameter's range")
    trim: number(0, 0.5) = key("share of each direction's largest point distances the fit ignores "
                               "(outliers, missing sides; 0: the plain Chamfer distance)")
    restarts: whole(1, 20) = key("CMA-ES runs, each from one of the best starts, sharing the budget")
    sweep_steps: Steps = key("one-parameter-at-a-time sweeps from the best start before CMA-ES, "
                             "one per step, each a share of every range")
    polish: whole(0, 100000) = key("evaluations kept back for sweeps from the best shape after CMA-ES (0: none)")
    polish_steps: Steps = key("the steps of those last sweeps, shares of every range")
    feedback: whole(0, 20) = key("rounds of the network's own correction of its answer to a reconstructed "
                                 "cloud, each round a start of the fit")


Views = Annotated[list[Annotated[list[number(-360, 360)], Field(min_length=2, max_length=2)]],
                  Field(min_length=1, max_length=64),
                  Expect("a list of 1 to 64 [azimuth, elevation] pairs in degrees")]


class DrawingFit(Group):
    """`geocode.reconstruct.sketchfit`: the search for the parameters and camera whose line drawing is
    nearest a drawing."""

    camera_guesses: Views = key("the views [azimuth, elevation] every start is drawn from, each framed twice")
    view_margin: number(0, 100) = key("px by which a start from a view more than 20 degrees from the "
                                      "dataset's trained ones must beat theirs")
    azimuth_span: number(0, 180) = key("degrees either side of a start's azimuth that the search may turn")
    max_elevation: number(0, 90, above=True) = key("the searched elevations: 0 to this many degrees")
    max_roll: number(0, 45) = key("degrees of image roll either way")
    scale_span: number(1, 4) = key("the scale searched within [s / span, s * span] of a start's s")
    shift_span: number(0, 112) = key("px of image shift either way of a start's (a wider span lets the fit "
                                     "trade shape for shift)")
    branch_budget: whole(1, 100000) = key("evaluations a branch (eval.sketch_fit_branches) needs at least")
    feedback: whole(0, 20) = key("rounds of the network's own correction of its answer on the best start")
    sweep_steps: Steps = key("one-coordinate-at-a-time sweeps before CMA-ES, one per step, each a share "
                             "of every range")
    sigma: number(0, 1, above=True) = key("CMA-ES's initial step on a parameter, a share of its range")
    camera_sigma: Annotated[list[number(0, 1, above=True)], Field(min_length=6, max_length=6),
                            Expect("6 numbers > 0 and <= 1")] = key(
        "... on the camera's azimuth, elevation, roll, scale, shift x, shift y, shares of their spans")
    prior: number(0, 100) = key("px added per squared unit-box move of the parameters from the start: where "
                                "the drawing does not tell, the network's answer stands")
    camera_prior: number(0, 100) = key("... of the camera's coordinates from the start's view")


class Fit(Group):
    cloud: CloudFit
    drawing: DrawingFit


class Domain(Group):
    name: Name = key("the domain a step works on (choose it with domain=<name>)")


class Paths(Group):
    data: Text = key("datasets: <data>/<domain>/<split>/")
    runs: Text = key("trained models and evaluations: <runs>/<domain>/<variant>/")
    build: Text = key("built programs (.blend) and their manifests")
    results: Text = key("tables and the report")


class Settings(Group):
    """The whole composed config (conf/config.yaml with its groups and profile)."""

    seed: whole(0) = key("seed of every random draw: sampling, clouds, sketch jitter, training")
    profile_name: Name = key("the profile in use; names the data and runs folders")
    domains: Annotated[list[Name] | None, Expect("null or a list of domains")] = key(
        "domains the workflow fans out over; null: every program with a recipe")
    domain: Domain
    paths: Paths
    data: Data
    model: Model
    train: Train
    eval: Eval
    fit: Fit

    @model_validator(mode="after")
    def _eval_camera_trains(self):
        camera = self.train.eval_camera
        if camera is not None and camera not in [c.name for c in self.data.sketch.cameras if c.train]:
            raise ValueError(f"train.eval_camera={camera}: not a training camera; name one with train: true, or null")
        return self


# ---------------------------------------------------------------- reading the models


def fields(model: type[BaseModel]) -> dict:
    """A group's fields by the key they are written with (`_target_`, not `target`)."""
    return {f.alias or name: f for name, f in model.model_fields.items()}


def group_of(annotation) -> type[Group] | None:
    return annotation if isinstance(annotation, type) and issubclass(annotation, Group) else None


def item_of(annotation) -> type[Item] | None:
    """The entry model of a list of entries (list[Camera] -> Camera)."""
    args = typing.get_args(annotation)
    origin = typing.get_origin(annotation)
    if origin is list and args and isinstance(args[0], type) and issubclass(args[0], Item):
        return args[0]
    return None


def expect(field) -> str:
    return next(str(m) for m in field.metadata if isinstance(m, Expect))


def documented_keys(model: type[Group] = Settings, prefix: str = "") -> dict[str, tuple[str, str]]:
    """Every key by its dotted name: (meaning, valid values), in the models' order."""
    out = {}
    for name, f in fields(model).items():
        if sub := group_of(f.annotation):
            out.update(documented_keys(sub, f"{prefix}{name}."))
        else:
            out[f"{prefix}{name}"] = (f.description, expect(f))
    return out


def _is_mapping(annotation) -> bool:
    kinds = typing.get_args(annotation) if typing.get_origin(annotation) in (Union, types.UnionType) else (annotation,)
    return any(typing.get_origin(k) is dict for k in kinds)


def _mappings(model: type[Group] = Settings, prefix: str = "") -> set[str]:
    out = set()
    for name, f in fields(model).items():
        if sub := group_of(f.annotation):
            out |= _mappings(sub, f"{prefix}{name}.")
        elif _is_mapping(f.annotation):
            out.add(f"{prefix}{name}")
    return out


MAPPINGS = _mappings()


# ---------------------------------------------------------------- validating


def check(data: dict) -> Settings:
    """The settings of a resolved config (plain dicts and lists); the first problem as a
    one-line ConfigError: `<key>=<value>: <problem>; give <valid values>`."""
    try:
        return Settings.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(message(exc.errors()[0], data)) from None


BOUNDS = {"greater_than", "greater_than_equal", "less_than", "less_than_equal"}


def message(error: dict, data: dict) -> str:
    """One pydantic error as `<key>=<value>: <problem>; <fix>`, named by the settings key it is in."""
    where, value, f, entry = locate(error["loc"], data)
    if error["type"] == "value_error":          # a validator's own "<problem>; <fix>"
        text = str(error["ctx"]["error"])
        return f"{where}: {text}" if where else text
    if error["type"] == "extra_forbidden":
        return f"{where}: unknown key; see `geocode config --keys` for the keys of each group"
    if entry is not None:
        return f"{where}={show(value)}: not {entry.WHAT}; give {entry.FORM}"
    if error["type"] == "missing":
        return f"{where}: missing (its group was replaced by a value, or left out); give {expect(f)}"
    problem = "out of range" if error["type"] in BOUNDS else "not valid"
    return f"{where}={show(value)}: {problem}; give {expect(f)}"


def locate(loc: tuple, data) -> tuple[str, object, object, type[Item] | None]:
    """(dotted key, its value, its field, the list entry's model if the problem is in one) of
    the settings key an error location falls in; a group's own location has no field."""
    model, node, where, f = Settings, data, "", None
    for depth, part in enumerate(loc):
        f = fields(model).get(part)
        node = node.get(part) if isinstance(node, dict) else None
        where = f"{where}.{part}".lstrip(".")
        if f is None:                           # a key the group does not have
            break
        if sub := group_of(f.annotation):
            model, f = sub, None
            continue
        rest = loc[depth + 1:]
        if (entry := item_of(f.annotation)) and rest and isinstance(rest[0], int) and isinstance(node, list):
            return f"{where}[{rest[0]}]", node[rest[0]], f, entry
        for inner in rest:                      # into a mapping's entries (not a list's: it shows whole)
            if isinstance(node, dict) and inner in node:
                where, node = f"{where}.{inner}", node[inner]
        break
    return where, node, f, None


def show(value) -> str:
    """A value as it is written in YAML (null, true), for a message."""
    if value is None or isinstance(value, bool):
        return {None: "null", True: "true", False: "false"}[value]
    return str(value)
