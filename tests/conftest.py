"""Shared fixtures; and Blender is required: without a `bpy` that imports, the suite stops here."""

import pytest


def pytest_configure(config):
    try:
        import bpy  # noqa: F401
    except ImportError as error:
        reason = (str(error).splitlines() or [type(error).__name__])[0]
        pytest.exit(f"bpy does not import ({reason}): run bash scripts/setup.sh, which installs bpy==5.0.1 "
                    "into .venv, and test with .venv/bin/python -m pytest", returncode=pytest.ExitCode.USAGE_ERROR)


@pytest.fixture
def blender():
    """A fresh, empty Blender session for one test (factory settings, no data)."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy


@pytest.fixture(scope="module")
def program(request):
    """The program of the test module's `DOMAIN`, built in a fresh Blender session."""
    import bpy

    from geocode.program import Program

    bpy.ops.wm.read_factory_settings(use_empty=True)
    return Program.load(request.module.DOMAIN)


@pytest.fixture(scope="module")
def label(program):
    """The part label constants of that program's module (TOP, LEGS, ...)."""
    return program._module


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory):
    """A finished smoke run of the workflow (results/smoke/tables: vases made, a model trained
    and evaluated), shared by the test files that read it; copy it before running more."""
    from test_workflow import SMOKE, snakemake

    work = tmp_path_factory.mktemp("smoke")
    snakemake(work, "-j2", "results/smoke/tables", *SMOKE)
    return work
