"""Shared fixtures."""

import pytest


@pytest.fixture
def blender():
    """A fresh, empty Blender session for one test (factory settings, no data)."""
    bpy = pytest.importorskip("bpy")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy


@pytest.fixture(scope="module")
def program(request):
    """The program of the test module's `DOMAIN`, built in a fresh Blender session."""
    bpy = pytest.importorskip("bpy")
    from geocode.program import Program

    bpy.ops.wm.read_factory_settings(use_empty=True)
    return Program.load(request.module.DOMAIN)


@pytest.fixture(scope="module")
def label(program):
    """The part label constants of that program's module (TOP, LEGS, ...)."""
    return program._module
