# Every domain's metrics -> results/tables/ (CSV, Markdown, LaTeX; an index README.md).


rule tables:
    input:
        expand(f"{RUNS}/{{domain}}/{{variant}}/eval/metrics.parquet", domain=DOMAINS, variant=VARIANTS),
    output:
        directory("results/tables"),
    log:
        f"{LOGS}/tables.log",
    params:
        args=" ".join(shlex.quote(o) for o in OVERRIDES),
    threads: 1
    resources:
        mem_mb=2000,
    shell:
        "geocode tables -o {output} --metrics {input} {params.args} > {log} 2>&1"
