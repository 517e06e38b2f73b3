# Recipes -> shapes (OBJ + YAML + part labels) -> sketches and point clouds, one job per shard.
# Each shard job skips the shapes it finished before and writes its done-file last.


rule sample:
    input:
        manifest=lambda w: manifest(w.domain),
        recipe=f"{PROGRAMS}/{{domain}}.yaml",
    output:
        expand(f"{DATA}/{{{{domain}}}}/{{split}}/recipes.parquet", split=SPLITS),
    log:
        f"logs/{DATA}/sample/{{domain}}.log",
    params:
        args=lambda w: step_args(w.domain),
    threads: 1
    resources:
        mem_mb=2000,
    shell:
        "geocode sample {params.args} > {log} 2>&1"


rule export:
    input:
        recipes=f"{DATA}/{{domain}}/{{split}}/recipes.parquet",
        manifest=lambda w: manifest(w.domain),
    output:
        f"{DATA}/{{domain}}/{{split}}/done/export-{{shard}}.txt",
    wildcard_constraints:
        split="train|val|test",  # test-s<factor> copies come from rule simplify
    log:
        f"logs/{DATA}/export/{{domain}}-{{split}}-{{shard}}.log",
    params:
        args=lambda w: step_args(w.domain),
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode export --split {wildcards.split} --shard {wildcards.shard} {params.args} > {log} 2>&1"


rule sketch:
    input:
        f"{DATA}/{{domain}}/{{split}}/done/export-{{shard}}.txt",
    output:
        f"{DATA}/{{domain}}/{{split}}/done/sketch-{{shard}}.txt",
    log:
        f"logs/{DATA}/sketch/{{domain}}-{{split}}-{{shard}}.log",
    params:
        args=lambda w: step_args(w.domain),
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode sketch --split {wildcards.split} --shard {wildcards.shard} {params.args} > {log} 2>&1"


rule points:
    input:
        f"{DATA}/{{domain}}/{{split}}/done/export-{{shard}}.txt",
    output:
        f"{DATA}/{{domain}}/{{split}}/done/points-{{shard}}.txt",
    log:
        f"logs/{DATA}/points/{{domain}}-{{split}}-{{shard}}.log",
    params:
        args=lambda w: step_args(w.domain),
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
        touch(f"{DATA}/{{domain}}/dataset.done"),
