# One model per domain and variant (eval.variants and eval.ablations); accelerator=auto
# trains on a GPU where there is one.


rule train:
    input:
        dataset=f"{DATA}/{{domain}}/dataset.done",
        manifest=lambda w: manifest(w.domain),
    output:
        f"{RUNS}/{{domain}}/{{variant}}/checkpoints/best.ckpt",
    log:
        f"logs/{RUNS}/train/{{domain}}-{{variant}}.log",
    params:
        args=lambda w: step_args(w.domain),
        out=f"{RUNS}/{{domain}}/{{variant}}",
    threads: 2
    resources:
        mem_mb=8000,
        gpu=GPUS,
    shell:
        "geocode train --out {params.out} {params.args} model={wildcards.variant} > {log} 2>&1"
