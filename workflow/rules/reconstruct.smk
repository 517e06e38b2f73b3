# A collection of a user's own files -> <paths.results>/reconstruct/<name>/, as
# `geocode reconstruct <folder> -o` writes it (the same names), by the domain's joint model:
#   snakemake -j2 results/reconstruct/scans --config reconstruct='{scans: {domain: chair, inputs: scans/}}'
# Optional per collection: batch (inputs per job, 8), budget (the fit's evaluations; null:
# eval.reconstruct_budget), recursive. One job per batch, each writing its record last, then the
# page job gathers them (geocode.reconstruct.collection): a rerun redoes the batches without a record.


rule reconstruct_batch:
    """One batch of a collection's inputs, in its own folder under <paths.runs>/reconstruct/<name>/."""
    input:
        checkpoint=lambda w: best_checkpoint(COLLECTIONS[w.name].domain, "joint"),
        dataset=lambda w: str(paths.dataset_done(CFG, COLLECTIONS[w.name].domain)),  # the nearest training shapes
        files=lambda w: [str(job.path) for job in COLLECTIONS[w.name].batches()[int(w.batch)]],
    output:
        str(paths.collection_batch_file(collection_work("{name}"), "{batch}")),
    wildcard_constraints:
        name=COLLECTION_NAMES,
        batch=r"\d+",
    log:
        log_path(CFG.paths.runs, "reconstruct", "{name}-{batch}"),
    params:
        args=lambda w: collection_args(w.name),
        budget=lambda w: "" if COLLECTIONS[w.name].budget is None else f"--budget {COLLECTIONS[w.name].budget}",
        overrides=lambda w: step_args(COLLECTIONS[w.name].domain),
    threads: 1
    resources:
        mem_mb=4000,
    shell:
        "geocode reconstruct-batch {params.args} --batch {wildcards.batch} --checkpoint {input.checkpoint} "
        "-j {threads} {params.budget} {params.overrides} > {log} 2>&1"


rule reconstruct_page:
    """The collection's folder: every batch's files, the page, summary.csv."""
    input:
        lambda w: collection_batches(w.name),
    output:
        directory(str(paths.collection_dir(CFG, "{name}"))),
    wildcard_constraints:
        name=COLLECTION_NAMES,
    log:
        log_path(CFG.paths.results, "reconstruct", "{name}"),
    params:
        args=lambda w: collection_args(w.name),
    threads: 1
    resources:
        mem_mb=2000,
    shell:
        "geocode reconstruct-page {params.args} > {log} 2>&1"
