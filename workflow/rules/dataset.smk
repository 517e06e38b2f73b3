# Recipes -> shapes (OBJ + YAML + part labels) -> sketches and point clouds, one job per shard.
# Each shard job skips the shapes it finished before and writes its done-file last; rule sample
# first clears a split made from other recipes or by another version of the program.


rule sample:
    input:
        manifest=lambda w: manifest(w.domain),
        recipe=str(paths.recipe_path("{domain}")),
    output:
        [str(paths.recipes_file(split_folder("{domain}", s))) for s in paths.SPLITS],
    log:
        log_path(CFG.paths.data, "sample", "{domain}"),
    params:
        args=lambda w: step_args(w.domain),
    priority: data_priority
    threads: 1
    resources:
        mem_mb=2000,
    shell:
        "geocode sample {params.args} > {log} 2>&1"


rule export:
    input:
        recipes=str(paths.recipes_file(split_folder("{domain}", "{split}"))),
        manifest=lambda w: manifest(w.domain),
    output:
        str(paths.done_file(split_folder("{domain}", "{split}"), "export", "{shard}")),
    wildcard_constraints:
        split="train|val|test",  # test-s<factor> copies come from rule simplify
    log:
        log_path(CFG.paths.data, "export", "{domain}-{split}-{shard}"),
    params:
        args=lambda w: step_args(w.domain),
    priority: data_priority
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode export --split {wildcards.split} --shard {wildcards.shard} {params.args} > {log} 2>&1"


rule sketch:
    input:
        str(paths.done_file(split_folder("{domain}", "{split}"), "export", "{shard}")),
    output:
        str(paths.done_file(split_folder("{domain}", "{split}"), "sketch", "{shard}")),
    log:
        log_path(CFG.paths.data, "sketch", "{domain}-{split}-{shard}"),
    params:
        args=lambda w: step_args(w.domain),
    priority: data_priority
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode sketch --split {wildcards.split} --shard {wildcards.shard} {params.args} > {log} 2>&1"


rule points:
    input:
        str(paths.done_file(split_folder("{domain}", "{split}"), "export", "{shard}")),
    output:
        str(paths.done_file(split_folder("{domain}", "{split}"), "points", "{shard}")),
    log:
        log_path(CFG.paths.data, "points", "{domain}-{split}-{shard}"),
    params:
        args=lambda w: step_args(w.domain),
    priority: data_priority
    threads: 1
    resources:
        mem_mb=2000,
    shell:
        "geocode points --split {wildcards.split} --shard {wildcards.shard} {params.args} > {log} 2>&1"


rule dataset:
    """Every shard of every stage of one domain's dataset."""
    input:
        lambda w: done_files("sketch", w.domain) + done_files("points", w.domain),
    output:
        touch(str(paths.dataset_done(CFG, "{domain}"))),
    priority: dataset_priority   # instant, and the domain's trainings wait for it
