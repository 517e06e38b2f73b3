# One model per domain and variant (eval.variants and eval.ablations); accelerator=auto
# trains on a GPU where there is one.


rule train:
    input:
        dataset=str(paths.dataset_done(CFG, "{domain}")),
        manifest=lambda w: manifest(w.domain),
    output:
        best_checkpoint("{domain}", "{variant}"),
    log:
        log_path(CFG.paths.runs, "train", "{domain}-{variant}"),
    params:
        args=lambda w: step_args(w.domain),
        out=str(run_folder("{domain}", "{variant}")),
        settings=training_settings,
    threads: training_threads
    priority: training_priority
    resources:
        mem_mb=8000,
        gpu=GPUS,
    shell:
        "geocode train -o {params.out} {params.args} model={wildcards.variant} > {log} 2>&1"
