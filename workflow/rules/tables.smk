# Every domain's metrics -> the tables (CSV, Markdown, LaTeX; an index README.md) and the report,
# under paths.results: results/ for the default profile, results/<profile>/ for the others.


rule tables:
    input:
        metrics=[metrics(domain, variant) for domain, variant in RUNS_TRAINED],
        report=REPORT,
    output:
        directory(TABLES),
    log:
        log_path(CFG.paths.runs, "tables"),
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
        [metrics(domain, "joint") for domain in DOMAINS],
    output:
        REPORT,
    log:
        log_path(CFG.paths.runs, "report"),
    params:
        args=" ".join(shlex.quote(o) for o in OVERRIDES),
        out=lambda w: str(paths.report_dir(CFG)),
    threads: 1
    resources:
        mem_mb=3000,
    shell:
        "geocode report {params.args} -o {params.out} --metrics {input} > {log} 2>&1"
