# Every domain's metrics -> results/tables/ (CSV, Markdown, LaTeX; an index README.md).


rule tables:
    input:
        metrics=[f"{RUNS}/{domain}/{variant}/eval/metrics.parquet" for domain, variant in RUNS_TRAINED],
        report="results/report/index.html",
    output:
        directory("results/tables"),
    log:
        f"logs/{RUNS}/tables.log",
    params:
        args=" ".join(shlex.quote(o) for o in OVERRIDES),
    threads: 1
    resources:
        mem_mb=2000,
    shell:
        "geocode tables {params.args} -o {output} --metrics {input.metrics} > {log} 2>&1"


rule report:
    """An HTML page with figures: inputs, ground truth and rebuilt predictions, side by side."""
    input:
        expand(f"{RUNS}/{{domain}}/joint/eval/metrics.parquet", domain=DOMAINS),
    output:
        "results/report/index.html",
    log:
        f"logs/{RUNS}/report.log",
    params:
        args=" ".join(shlex.quote(o) for o in OVERRIDES),
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode report {params.args} -o results/report --metrics {input} > {log} 2>&1"
