"""GeoCode building blocks in the Geometry Nodes editor: Add > GeoCode > <category> > <block>.

This file is the add-on that `geocode addon build` packs, beside `blocks.blend` (every block's
node group) and `blocks.json` (the categories). Choosing a block appends its node group from
`blocks.blend` (once per file) and adds a group node at the cursor.
"""

import json
from pathlib import Path

import bpy

HERE = Path(__file__).parent


def categories() -> dict[str, list[str]]:
    """Category -> block names, in menu order."""
    return json.loads((HERE / "blocks.json").read_text())


def load_block(name: str) -> bpy.types.GeometryNodeTree:
    """The block's node group in this file, appended from blocks.blend on first use."""
    group = bpy.data.node_groups.get(name)
    if group is None:
        with bpy.data.libraries.load(str(HERE / "blocks.blend"), link=False) as (_, into):
            into.node_groups = [name]
        group = bpy.data.node_groups[name]
    return group


class GEOCODE_OT_add_block(bpy.types.Operator):
    """Add a GeoCode building block as a group node"""

    bl_idname = "geocode.add_block"
    bl_label = "Add GeoCode Block"
    bl_options = {"REGISTER", "UNDO"}

    block: bpy.props.StringProperty(name="Block")

    @classmethod
    def poll(cls, context):
        space = context.space_data
        return getattr(space, "tree_type", "") == "GeometryNodeTree" and space.edit_tree is not None

    def execute(self, context):
        tree = context.space_data.edit_tree
        node = tree.nodes.new("GeometryNodeGroup")
        node.node_tree = load_block(self.block)
        node.location = context.space_data.cursor_location
        for other in tree.nodes:
            other.select = other == node
        tree.nodes.active = node
        return {"FINISHED"}


def _category_menu(category: str, names: list[str]) -> type:
    def draw(self, context):
        for name in names:
            self.layout.operator(GEOCODE_OT_add_block.bl_idname, text=name).block = name

    ident = "NODE_MT_geocode_" + "".join(ch for ch in category.lower() if ch.isalnum())
    return type(ident, (bpy.types.Menu,), {"bl_idname": ident, "bl_label": category,
                                           "draw": draw})


class NODE_MT_geocode(bpy.types.Menu):
    bl_idname = "NODE_MT_geocode"
    bl_label = "GeoCode"

    def draw(self, context):
        for menu in _MENUS:
            self.layout.menu(menu.bl_idname)


def draw_add_menu(self, context):
    if getattr(context.space_data, "tree_type", "") == "GeometryNodeTree":
        self.layout.separator()
        self.layout.menu(NODE_MT_geocode.bl_idname)


_MENUS: list[type] = []


def register():
    _MENUS[:] = [_category_menu(c, names) for c, names in categories().items()]
    for cls in (GEOCODE_OT_add_block, *_MENUS, NODE_MT_geocode):
        bpy.utils.register_class(cls)
    bpy.types.NODE_MT_add.append(draw_add_menu)


def unregister():
    bpy.types.NODE_MT_add.remove(draw_add_menu)
    for cls in reversed((GEOCODE_OT_add_block, *_MENUS, NODE_MT_geocode)):
        bpy.utils.unregister_class(cls)
    _MENUS.clear()
