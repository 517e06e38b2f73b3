"""The on-disk layout (geocode.paths): results keyed by profile, splits from the known set."""

import pytest

from geocode import paths
from geocode.config import compose
from geocode.errors import UserError


def test_only_the_default_profile_writes_results_at_the_top():
    assert str(paths.tables_dir(compose([]))) == "results/tables"
    assert str(paths.report_index(compose([]))) == "results/report/index.html"
    for profile in ("smoke", "paper"):
        assert str(paths.tables_dir(compose([f"profile={profile}"]))) == f"results/{profile}/tables"


def test_a_split_outside_the_known_set_is_refused():
    cfg = compose(["profile=smoke"])
    assert paths.check_split(cfg, "test-s10") == "test-s10"
    with pytest.raises(UserError, match="split '../test': unknown; use one of train, val, test, test-s10"):
        paths.check_split(cfg, "../test")


def test_wildcards_pass_through_for_the_workflow():
    cfg = compose([])
    done = paths.done_file(paths.split_dir(cfg, "{domain}", "{split}"), "export", "{shard}")
    assert str(done) == "data/mini/{domain}/{split}/done/export-{shard}.txt"


def test_logs_stay_under_logs_for_an_absolute_data_folder():
    assert str(paths.log_file("/tmp/data", "sample", "vase")) == "logs/tmp/data/sample/vase.log"
    assert str(paths.log_file("runs/mini", "tables")) == "logs/runs/mini/tables.log"
