"""Evaluate a geometry node tree on an object and read back its mesh (or curve points).

One `Evaluator` holds one object with one Geometry Nodes modifier; setting inputs and reading
the result reuses them, which is what makes thousands of evaluations per process cheap.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import bpy
import numpy as np
import trimesh

from geocode.nodes.graph import LABEL_ATTRIBUTE


class Evaluator:
    """An object carrying `tree` as its Geometry Nodes modifier."""

    def __init__(self, tree: bpy.types.GeometryNodeTree, name: str | None = None):
        name = name or f"geocode:{tree.name}"
        mesh = bpy.data.meshes.new(name)
        obj = bpy.data.objects.new(name, mesh)
        self.object_name = obj.name  # Blender appends .001 when the name is taken
        bpy.context.scene.collection.objects.link(obj)
        modifier = obj.modifiers.new("GeometryNodes", "NODES")
        modifier.node_group = tree
        self.identifiers = {item.name: item.identifier for item in _inputs(tree)}

    @property
    def object(self) -> bpy.types.Object:
        return bpy.data.objects[self.object_name]

    def alive(self) -> bool:
        """False after a factory reset removed the object."""
        return bpy.data.objects.get(self.object_name) is not None

    def set_inputs(self, values: Mapping[str, Any]) -> None:
        """Set group inputs by name; vectors as 3-sequences."""
        modifier = self.object.modifiers[0]
        for name, value in values.items():
            modifier[self.identifiers[name]] = value

    def mesh(self, values: Mapping[str, Any] | None = None) -> trimesh.Trimesh:
        """Triangle mesh of the current inputs, `metadata['part']` one label per triangle."""
        if values:
            self.set_inputs(values)
        obj = self.object
        # without the tag the depsgraph keeps returning the previous evaluation
        obj.update_tag()
        depsgraph = bpy.context.evaluated_depsgraph_get()
        evaluated = obj.evaluated_get(depsgraph)
        data = evaluated.to_mesh()
        try:
            return _triangles(data)
        finally:
            evaluated.to_mesh_clear()


def _inputs(tree: bpy.types.NodeTree):
    return [item for item in tree.interface.items_tree
            if item.item_type == "SOCKET" and item.in_out == "INPUT"]


def _triangles(data: bpy.types.Mesh) -> trimesh.Trimesh:
    data.calc_loop_triangles()
    vertices = np.empty(len(data.vertices) * 3, dtype=np.float64)
    data.vertices.foreach_get("co", vertices)
    n = len(data.loop_triangles)
    faces = np.empty(n * 3, dtype=np.int64)
    data.loop_triangles.foreach_get("vertices", faces)
    polygon = np.empty(n, dtype=np.int64)
    data.loop_triangles.foreach_get("polygon_index", polygon)
    mesh = trimesh.Trimesh(vertices.reshape(-1, 3), faces.reshape(-1, 3), process=False)
    mesh.metadata["part"] = _face_parts(data)[polygon]
    return mesh


def _face_parts(data: bpy.types.Mesh) -> np.ndarray:
    attribute = data.attributes.get(LABEL_ATTRIBUTE)
    labels = np.zeros(len(data.polygons), dtype=np.int64)
    if attribute is not None and attribute.domain == "FACE" and len(labels):
        buffer = np.empty(len(labels), dtype=np.int32)
        attribute.data.foreach_get("value", buffer)
        labels[:] = buffer
    return labels
