# Each program's graph as a .blend (open it in Blender's node editor) and its manifest.


rule program:
    input:
        program=str(paths.program_path("{domain}")),
        recipe=str(paths.recipe_path("{domain}")),
    output:
        blend=str(paths.blend_path(CFG, "{domain}")),
        manifest=manifest("{domain}"),
    log:
        log_path(CFG.paths.build, "program", "{domain}"),
    priority: data_priority   # the longest-training domain's first: its data follows
    threads: 1
    resources:
        mem_mb=2000,
    shell:
        "geocode program build {wildcards.domain} -o {output.blend} --manifest {output.manifest} > {log} 2>&1"
