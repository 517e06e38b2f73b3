"""The programs keep their meshes: vertex hashes of fixed parameter settings (defaults, the
all-min and all-max corners, seeded random draws) against a committed fixture.

Record the fixture again only when a shape change is intended:
`PYTHONPATH=src python tests/test_program_meshes.py`.
"""

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from geocode.program import Program

pytestmark = pytest.mark.blender

FIXTURE = Path(__file__).parent / "data" / "program_mesh_hashes.json"
DOMAINS = ("vase", "chair", "table", "ceiling_lamp", "cabinet")
SEEDS = range(12)


def mesh_digest(mesh) -> dict:
    """Counts and a hash of the vertices rounded to 1e-5, the faces and the part labels."""
    vertices = np.round(mesh.vertices, 5) + 0.0  # + 0.0 turns -0.0 into 0.0
    data = vertices.tobytes() + mesh.faces.astype(np.int64).tobytes() \
        + np.asarray(mesh.metadata["part"], dtype=np.int64).tobytes()
    return {"vertices": len(mesh.vertices), "faces": len(mesh.faces),
            "sha256": hashlib.sha256(data).hexdigest()}


def _settings(program: Program) -> dict[str, dict]:
    settings = {"defaults": program.check({}),
                "all_min": {p.name: p.min for p in program.parameters},
                "all_max": {p.name: p.max for p in program.parameters}}
    for seed in SEEDS:
        settings[f"random_{seed}"] = program.random_values(np.random.default_rng(seed))
    return settings


def record() -> None:
    fixture = {}
    for domain in DOMAINS:
        program = Program.load(domain)
        fixture[domain] = {name: {"values": values, **mesh_digest(program.evaluate(values))}
                           for name, values in _settings(program).items()}
    FIXTURE.write_text(json.dumps(fixture, indent=1, sort_keys=True) + "\n")


@pytest.mark.parametrize("domain", DOMAINS)
def test_meshes_match_the_recorded_hashes(domain):
    expected = json.loads(FIXTURE.read_text())[domain]
    program = Program.load(domain)
    for name, case in expected.items():
        got = mesh_digest(program.evaluate(case["values"]))
        assert got == {k: case[k] for k in got}, f"{domain} {name}"


if __name__ == "__main__":
    sys.exit(record())
