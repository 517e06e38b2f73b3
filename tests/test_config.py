"""The settings models of `geocode.settings`: one idiom for every group, the YAML owning the
defaults, the model variants derived from joint."""

import pytest
from omegaconf import OmegaConf

from geocode.config import ConfigError, compose, settings, sketch_fit_budget, sketch_fit_searches
from geocode.settings import MAPPINGS, Settings, check, documented_keys


def test_every_key_of_every_profile_is_a_field_of_the_models():
    for profile in ("mini", "smoke", "paper"):
        s = settings(compose([f"profile={profile}"]))
        assert isinstance(s, Settings) and s.profile_name == profile


def test_the_models_give_every_key_a_meaning_and_valid_values():
    keys = documented_keys()
    assert {"seed", "paths.runs", "data.points.fps", "model._target_", "train.lr", "eval.fit"} <= set(keys)
    assert all(meaning and valid for meaning, valid in keys.values())
    assert MAPPINGS == {"data.domain_variations", "train.domain_epochs", "train.variant_epochs",
                        "eval.sketch_fit_branches", "eval.sketch_fit_orders", "eval.sketch_fit_domain_budget"}


def test_a_domain_s_drawing_fit_budget_overrides_the_default_for_it_alone():
    cfg = compose(["eval.sketch_fit_budget=300", "eval.sketch_fit_domain_budget={chair: 900}"])
    assert sketch_fit_budget(cfg, "chair") == 900 and sketch_fit_budget(cfg, "cabinet") == 300
    smoke = compose(["profile=smoke"])
    assert sketch_fit_budget(smoke, "chair") == smoke.eval.sketch_fit_budget


def test_a_domain_s_drawing_fit_searches_come_from_its_branches_and_orders():
    cfg = compose(["eval.sketch_fit_branches=null", "+eval.sketch_fit_orders.table=2"])
    assert sketch_fit_searches(cfg, "table") == {"branches": 1, "orders": 2}
    assert sketch_fit_searches(cfg, "chair") == {"branches": 1, "orders": 1}
    assert sketch_fit_searches(compose([]), "vase") == {"branches": 3, "orders": 2}


def test_a_key_the_models_do_not_know_is_refused():
    plain = OmegaConf.to_container(compose([]), resolve=True)
    plain["train"]["max_epoch"] = 3                        # a typo in a profile, say
    with pytest.raises(ConfigError, match=r"^train.max_epoch: unknown key; see `geocode config --keys`"):
        check(plain)


def test_typed_values_come_back():
    t = settings(compose(["profile=smoke", "train.limit_train_batches=2"])).train
    assert t.limit_train_batches == 2 and isinstance(t.lr, float) and t.augment.flip == 0.5


@pytest.mark.parametrize("variant, differs", [("regression", {}), ("separate", {}),
                                              ("huang", {"embedding_norm": False})])
def test_the_variants_are_joint_but_for_what_they_set(variant, differs):
    joint = dict(compose(["model=joint"]).model)
    other = dict(compose([f"model={variant}"]).model)
    assert other == {**joint, "variant": variant, **differs}


def test_the_fits_search_settings_are_keys_with_ranges():
    """conf/fit/: the fits' tuning a user may change, each key documented and bounded."""
    keys = documented_keys()
    assert {"fit.cloud.sigma", "fit.cloud.trim", "fit.cloud.restarts", "fit.cloud.sweep_steps", "fit.cloud.polish",
            "fit.cloud.feedback", "fit.drawing.camera_guesses", "fit.drawing.azimuth_span", "fit.drawing.prior",
            "fit.drawing.sweep_steps", "fit.drawing.branch_budget"} <= set(keys)
    fit = settings(compose(["fit.drawing.prior=0.5", "fit.cloud.sweep_steps=[0.1]"])).fit
    assert fit.drawing.prior == 0.5 and fit.cloud.sweep_steps == [0.1] and fit.cloud.restarts == 2
    for override, message in (("fit.cloud.trim=0.9", "out of range; give a number >= 0 and <= 0.5"),
                              ("fit.cloud.restarts=0", "out of range; give a whole number >= 1"),
                              ("fit.drawing.camera_sigma=[0.1]", "not valid; give 6 numbers > 0"),
                              ("fit.drawing.max_elevation=0", "out of range; give a number > 0")):
        with pytest.raises(ConfigError) as error:
            compose([override])
        assert str(error.value).startswith(f"{override}: {message}") and "\n" not in str(error.value)
