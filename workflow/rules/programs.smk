# Each program's graph as a .blend (open it in Blender's node editor) and its manifest.


rule program:
    input:
        program=f"{PROGRAMS}/{{domain}}.py",
        recipe=f"{PROGRAMS}/{{domain}}.yaml",
    output:
        blend=f"{BUILD}/programs/{{domain}}.blend",
        manifest=f"{BUILD}/programs/{{domain}}.manifest.json",
    log:
        f"logs/{BUILD}/program/{{domain}}.log",
    threads: 1
    resources:
        mem_mb=2000,
    shell:
        "geocode program build {wildcards.domain} -o {output.blend} --manifest {output.manifest} > {log} 2>&1"
