# Test inputs (clean, noisy, sparse, simplified, every camera) -> predictions -> meshes rebuilt
# by the program -> Chamfer distances and drop tests, per domain and model variant.


rule simplify:
    """A copy of the test split decimated to 1/factor of the faces: split test-s<factor>."""
    input:
        lambda w: done_files("export", w.domain, ["test"]),
    output:
        recipes=f"{DATA}/{{domain}}/test-s{{factor}}/recipes.parquet",
        done=expand(f"{DATA}/{{{{domain}}}}/test-s{{{{factor}}}}/done/export-{{shard}}.txt", shard=SHARDS),
    log:
        f"logs/{DATA}/simplify/{{domain}}-{{factor}}.log",
    params:
        args=lambda w: step_args(w.domain),
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode simplify --factor {wildcards.factor} {params.args} > {log} 2>&1"


rule predict:
    input:
        checkpoint=f"{RUNS}/{{domain}}/{{variant}}/checkpoints/best.ckpt",
        data=lambda w: eval_inputs(w.domain),
    output:
        f"{RUNS}/{{domain}}/{{variant}}/eval/predictions.parquet",
    log:
        f"logs/{RUNS}/predict/{{domain}}-{{variant}}.log",
    params:
        args=lambda w: step_args(w.domain),
    threads: 2
    resources:
        mem_mb=6000,
    shell:
        "geocode predict --checkpoint {input.checkpoint} -o {output} {params.args} > {log} 2>&1"


rule rebuild:
    input:
        f"{RUNS}/{{domain}}/{{variant}}/eval/predictions.parquet",
    output:
        f"{RUNS}/{{domain}}/{{variant}}/eval/rebuilt/done-{{shard}}.txt",
    log:
        f"logs/{RUNS}/rebuild/{{domain}}-{{variant}}-{{shard}}.log",
    params:
        args=lambda w: step_args(w.domain),
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode rebuild --predictions {input} --shard {wildcards.shard} {params.args} > {log} 2>&1"


rule metrics:
    input:
        predictions=f"{RUNS}/{{domain}}/{{variant}}/eval/predictions.parquet",
        rebuilt=expand(f"{RUNS}/{{{{domain}}}}/{{{{variant}}}}/eval/rebuilt/done-{{shard}}.txt", shard=SHARDS),
        manifest=lambda w: manifest(w.domain),  # says whether the shapes hang (no drop test)
    output:
        f"{RUNS}/{{domain}}/{{variant}}/eval/metrics.parquet",
    log:
        f"logs/{RUNS}/metrics/{{domain}}-{{variant}}.log",
    params:
        args=lambda w: step_args(w.domain),
    threads: 1
    resources:
        mem_mb=4000,
    shell:
        "geocode metrics --predictions {input.predictions} -o {output} {params.args} > {log} 2>&1"
