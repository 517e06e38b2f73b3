# A collection of a user's own files -> <paths.results>/reconstruct/<name>/, as
# `geocode reconstruct <folder> -o` writes it (the same names), by the domain's joint model:
#   snakemake -j2 results/reconstruct/scans --config reconstruct='{scans: {domain: chair, inputs: scans/}}'
# Optional per collection: batch (inputs per job, 8), budget (the fit's evaluations; null:
# eval.reconstruct_budget), recursive. One job per batch, each writing its record last, then the
# page job gathers them (geocode.reconstruct.collection): a rerun redoes the batches without a record.
# The real-shape table of the paper, for folders of real meshes, one per domain:
#   snakemake -j2 results/real_shapes --config real='{chair: coseg/chairs, vase: coseg/vases}'
# each folder a collection real_shapes-<domain> (its page in results/reconstruct/real_shapes-<domain>/).


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


rule real_shapes:
    """The real-shape table (geocode.steps.real_shapes) of every folder of --config real."""
    input:
        pages=lambda w: [str(paths.collection_dir(CFG, name)) for name in REAL],
        records=lambda w: [r for name in REAL for r in collection_batches(name)],
    output:
        directory(str(paths.real_shapes_dir(CFG))),
    log:
        log_path(CFG.paths.results, "real_shapes"),
    params:
        records=lambda w: real_shapes_records(),
        overrides=" ".join(shlex.quote(o) for o in OVERRIDES),
    threads: 1
    resources:
        mem_mb=2000,
    shell:
        "geocode real-shapes -o {output} {params.overrides} {params.records} > {log} 2>&1"
