"""`geocode addon build`: the building blocks as a Blender extension (the paper's add-on).

The zip holds Blender's extension manifest, the add-on in `geocode/blender/extension/`, a
`.blend` library with every block's node group (nested groups included) and the menu's
categories. Install it in Blender (Edit > Preferences > Get Extensions > Install from Disk);
the blocks then appear under Add > GeoCode in the Geometry Nodes editor.
"""

from __future__ import annotations

import json
import tempfile
import zipfile
from importlib.metadata import version
from pathlib import Path

from geocode import meshio

EXTENSION_ID = "geocode_nodes"
SOURCE = Path(__file__).with_name("extension") / "__init__.py"
# catalogue module -> the Add menu's category (the paper's names for them)
CATEGORIES = {"curves": "Curves", "profiles": "Profiles", "styles": "Styles", "shells": "Styles",
              "surfaces": "Surfaces", "attachment": "Sampling", "symmetry": "Symmetry",
              "meshes": "Meshes", "utils": "Utilities"}
MANIFEST = """schema_version = "1.0.0"
id = "{id}"
version = "{version}"
name = "GeoCode building blocks"
tagline = "Curves, profiles, styles, sampling, symmetry and ready-made meshes for shape programs"
maintainer = "geocode developers"
type = "add-on"
tags = ["Geometry Nodes", "Node"]
blender_version_min = "4.2.0"
license = ["SPDX:GPL-3.0-or-later"]
"""


def block_categories() -> dict[str, list[str]]:
    """Category -> the node-group names of its blocks, sorted."""
    from geocode import nodes

    found: dict[str, list[str]] = {}
    for name, block in sorted(nodes.BLOCKS.items()):
        module = block.build.__module__.rsplit(".", 1)[-1]
        found.setdefault(CATEGORIES[module], []).append(name)
    return {c: found[c] for c in CATEGORIES.values() if c in found}


def build_addon(out_zip: str | Path) -> dict:
    """Write the extension zip; returns the counts of blocks per category."""
    import bpy

    from geocode import nodes

    bpy.ops.wm.read_factory_settings(use_empty=True)
    groups = {block.tree() for block in nodes.BLOCKS.values()}
    categories = block_categories()
    with tempfile.TemporaryDirectory() as tmp:
        library = Path(tmp) / "blocks.blend"
        bpy.data.libraries.write(str(library), groups, fake_user=True, compress=True)
        with meshio.atomic_path(out_zip) as partial, zipfile.ZipFile(partial, "w") as z:
            z.writestr("blender_manifest.toml",
                       MANIFEST.format(id=EXTENSION_ID, version=version("geocode")))
            z.write(SOURCE, "__init__.py")
            z.write(library, "blocks.blend")
            z.writestr("blocks.json", json.dumps(categories, indent=1))
    return {category: len(names) for category, names in categories.items()}
