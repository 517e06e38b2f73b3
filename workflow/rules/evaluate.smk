# Test inputs (clean, noisy, sparse, simplified, every camera) -> predictions -> meshes rebuilt
# by the program -> Chamfer distances and drop tests, per domain and model variant.


rule simplify:
    """A copy of the test split decimated to 1/factor of the faces: split test-s<factor>."""
    input:
        lambda w: done_files("export", w.domain, ["test"]),
    output:
        recipes=str(paths.recipes_file(split_folder("{domain}", paths.simplified_split("{factor}")))),
        done=[str(paths.done_file(split_folder("{domain}", paths.simplified_split("{factor}")), "export", shard))
              for shard in SHARDS],
    log:
        log_path(CFG.paths.data, "simplify", "{domain}-{factor}"),
    params:
        args=lambda w: step_args(w.domain),
    priority: data_priority
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode simplify --factor {wildcards.factor} {params.args} > {log} 2>&1"


rule predict:
    input:
        checkpoint=best_checkpoint("{domain}", "{variant}"),
        data=lambda w: eval_inputs(w.domain),
    output:
        predictions("{domain}", "{variant}"),
    log:
        log_path(CFG.paths.runs, "predict", "{domain}-{variant}"),
    params:
        args=lambda w: step_args(w.domain),
    threads: 1
    resources:
        mem_mb=6000,
    shell:
        "geocode predict --checkpoint {input.checkpoint} -o {output} {params.args} > {log} 2>&1"


rule rebuild:
    input:
        predictions("{domain}", "{variant}"),
    output:
        rebuilt_done("{domain}", "{variant}", "{shard}"),
    log:
        log_path(CFG.paths.runs, "rebuild", "{domain}-{variant}-{shard}"),
    params:
        args=lambda w: step_args(w.domain),
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode rebuild --predictions {input} --shard {wildcards.shard} {params.args} > {log} 2>&1"


rule metrics:
    input:
        predictions=predictions("{domain}", "{variant}"),
        rebuilt=[rebuilt_done("{domain}", "{variant}", shard) for shard in SHARDS],
        manifest=lambda w: manifest(w.domain),  # says whether the shapes hang (no drop test)
    output:
        metrics("{domain}", "{variant}"),
    log:
        log_path(CFG.paths.runs, "metrics", "{domain}-{variant}"),
    params:
        args=lambda w: step_args(w.domain),
    threads: 1
    resources:
        mem_mb=4000,
    shell:
        "geocode metrics --predictions {input.predictions} -o {output} {params.args} model={wildcards.variant} > {log} 2>&1"
