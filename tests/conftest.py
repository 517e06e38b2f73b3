"""Shared fixtures."""

import pytest


@pytest.fixture
def blender():
    """A fresh, empty Blender session for one test (factory settings, no data)."""
    bpy = pytest.importorskip("bpy")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy
