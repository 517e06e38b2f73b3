"""`geocode timings`: job times of a workflow run, from Snakemake's records of its outputs."""

import base64
import json

from geocode.cli import main
from geocode.timing import run_summary, run_times


def record(folder, output, rule, start, end, log=None, job=1):
    name = base64.b64encode(output.encode()).decode()
    (folder / name).write_text(json.dumps({"rule": rule, "log": [log] if log else [], "job_hash": job,
                                           "starttime": start, "endtime": end}))


def test_job_times_per_stage_and_domain(tmp_path, capsys):
    export, train = "logs/data/mini/export/vase-train", "logs/runs/mini/train/chair-joint.log"
    record(tmp_path, "data/mini/vase/train/done/export-0.txt", "export", 100, 160, f"{export}-0.log")
    record(tmp_path, "data/mini/vase/train/done/export-1.txt", "export", 100, 130, f"{export}-1.log", 2)
    record(tmp_path, "runs/mini/chair/joint/checkpoints/best.ckpt", "train", 160, 400, train, 3)
    record(tmp_path, "runs/mini/chair/joint/checkpoints/last.ckpt", "train", 160, 400, train, 3)
    record(tmp_path, "build/programs/vase.blend", "program", 50, 55, "logs/build/program/vase.log", 4)
    record(tmp_path, "results/tables", "tables", 400, 460, "logs/runs/mini/tables.log", 5)
    record(tmp_path, "data/smoke/vase/train/done/export-0.txt", "export", 0, 9,
           "logs/data/smoke/export/vase-train-0.log", 6)
    (tmp_path / "not-base64!").write_text("{}")
    jobs = run_times(tmp_path, "mini", ["vase", "chair"], ["joint", "huang"])
    assert len(jobs) == 4           # one job per hash; smoke's and the shared program build left out
    per = jobs.groupby(["rule", "domain"]).seconds.sum()
    assert per[("export", "vase")] == 90 and per[("train", "chair")] == 240 and per[("tables", "-")] == 60
    text = run_summary(jobs)
    assert "6.0 min over 4 jobs" in text and "joint 4.0" in text    # 100 .. 460 s
    assert main(["timings", "--metadata", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["wall_min"] == 6.0 and out["minutes"]["train"]["chair"] == 4.0
    assert out["variant_minutes"] == {"-": 2.5, "joint": 4.0}


def test_no_records_is_one_line(tmp_path, capsys):
    assert main(["timings", "--metadata", str(tmp_path / "none")]) == 2
    assert "no Snakemake records" in capsys.readouterr().err
    assert "no finished jobs" in run_summary(run_times(tmp_path, "mini", ["vase"], ["joint"]))


def test_the_profile_is_chosen_by_an_override_as_everywhere_else(tmp_path, capsys):
    record(tmp_path, "data/mini/vase/train/done/export-0.txt", "export", 100, 160, "logs/data/mini/export/vase-train-0.log")  # noqa: E501  (a table row)
    record(tmp_path, "data/smoke/vase/train/done/export-0.txt", "export", 0, 9, "logs/data/smoke/export/vase-train-0.log", 2)  # noqa: E501  (a table row)
    assert main(["timings", "profile=smoke", "--metadata", str(tmp_path), "--json"]) == 0
    smoke = capsys.readouterr()
    assert json.loads(smoke.out)["jobs"] == 1 and json.loads(smoke.out)["minutes"]["export"]["vase"] == 0.15
    assert smoke.err == ""
    assert main(["timings", "--profile", "smoke", "--metadata", str(tmp_path), "--json"]) == 0
    old = capsys.readouterr()
    assert old.out == smoke.out
    assert old.err == "geocode: --profile is now profile=<name>; the old name goes in the next release\n"
    assert main(["timings", "profile=huge", "--metadata", str(tmp_path)]) == 2
    assert "profile" in capsys.readouterr().err
