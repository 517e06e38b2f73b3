"""Shaded pictures of program shapes, for judging a program by eye: one mesh to a PNG, or a
grid of random shapes. Cycles on the CPU, a few samples, a sun and a grey world, faces
coloured by part label."""

from __future__ import annotations

import logging
import math
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from geocode import meshio
from geocode.blender.scene import Camera, RenderScene, render_still, set_mesh_data

log = logging.getLogger(__name__)

# Muted colours, one per part label (cycled); grey where a mesh has no part labels.
PALETTE = np.array([
    (0.80, 0.80, 0.80), (0.85, 0.45, 0.35), (0.40, 0.60, 0.85), (0.50, 0.75, 0.45),
    (0.90, 0.75, 0.35), (0.65, 0.50, 0.80), (0.40, 0.75, 0.75), (0.85, 0.55, 0.70),
])
VIEW = Camera("gallery", azimuth=35.0, elevation=25.0)
SHARP_ANGLE = math.radians(30)   # edges bent further than this are shaded sharp


class ShadedRenderer(RenderScene):
    """A scene of its own (so it never disturbs a program's objects), reused between meshes:
    a grey-lit white world, a sun, faces coloured by part label."""

    def __init__(self, size: int = 256, samples: int = 16):
        super().__init__("geocode_gallery", size, samples, strength=0.35)
        r = self.scene.render
        r.film_transparent = True           # background composed onto white by Pillow
        r.image_settings.file_format, r.image_settings.color_mode = "PNG", "RGBA"
        self.scene.cycles.max_bounces = 2
        self.material = self._part_material()
        self._add_sun()
        self.aim(VIEW)

    def _part_material(self):
        """Base colour from the per-face 'part_color' attribute."""
        mat = self.bpy.data.materials.new("geocode_gallery_parts")
        tree = mat.node_tree
        bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
        attr = tree.nodes.new("ShaderNodeAttribute")
        attr.attribute_type, attr.attribute_name = "GEOMETRY", "part_color"
        tree.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
        bsdf.inputs["Roughness"].default_value = 0.7
        self.mesh.materials.append(mat)
        return mat

    def _add_sun(self) -> None:
        sun = self.bpy.data.lights.new("geocode_gallery_sun", "SUN")
        sun.energy, sun.angle = 2.0, math.radians(10)
        obj = self.bpy.data.objects.new("geocode_gallery_sun", sun)
        # From the upper left of the camera: top, front and side faces get distinct shades.
        obj.rotation_euler = (math.radians(50), 0.0, math.radians(-20))
        self.scene.collection.objects.link(obj)

    def set_mesh(self, mesh, color=None) -> None:
        """`mesh`'s faces coloured by part label, or all in `color` (RGB, 0-1) if given."""
        set_mesh_data(self.mesh, mesh.vertices, mesh.faces)
        # smooth across gentle bends only: a box shaded smooth looks like a pillow
        self.mesh.set_sharp_from_angle(angle=SHARP_ANGLE)
        parts = np.asarray(mesh.metadata.get("part", np.zeros(len(mesh.faces))), dtype=int)
        rgba = np.ones((len(mesh.faces), 4), dtype=np.float32)
        rgba[:, :3] = PALETTE[parts % len(PALETTE)] if color is None else color
        attr = self.mesh.color_attributes.new("part_color", "FLOAT_COLOR", "FACE")
        attr.data.foreach_set("color", rgba.ravel())

    def render(self, mesh, out_png: str | Path, normalise: bool = True, color=None,
               size: int | None = None) -> None:
        """Render `mesh` to `out_png` (atomically): normalised to the unit sphere, or with
        `normalise=False` as it is (meshes already in one frame keep their relative scale);
        coloured by part, or all in `color`; `size` px square instead of the scene's size."""
        self.set_mesh(meshio.normalise_unit_sphere(mesh) if normalise else mesh, color)
        r = self.scene.render
        saved = r.resolution_x
        r.resolution_x = r.resolution_y = size or saved
        try:
            with meshio.atomic_path(out_png) as tmp:
                render_still(self.scene, tmp).replace(tmp)
        finally:
            r.resolution_x = r.resolution_y = saved


_RENDERER: ShadedRenderer | None = None


def shaded_renderer() -> ShadedRenderer:
    global _RENDERER
    if _RENDERER is None or not _RENDERER.alive():
        _RENDERER = ShadedRenderer()
    return _RENDERER


def render_mesh_png(mesh, out_png: str | Path, **options) -> None:
    """One shaded picture of a trimesh on white (part labels from mesh.metadata['part'] as
    colours); `options`: those of ShadedRenderer.render (normalise, color, size)."""
    renderer = shaded_renderer()
    renderer.render(mesh, out_png, **options)
    with Image.open(out_png) as img:
        flat = on_white(img)
    with meshio.atomic_path(out_png) as tmp:
        flat.save(tmp, format="PNG")


def on_white(img: Image.Image) -> Image.Image:
    sheet = Image.new("RGB", img.size, "white")
    sheet.paste(img, mask=img.getchannel("A"))
    return sheet


def grid(images: list[Image.Image], captions: list[str], columns: int = 4) -> Image.Image:
    w, h = images[0].size
    rows = math.ceil(len(images) / columns)
    sheet = Image.new("RGB", (columns * w, rows * h), "white")
    draw = ImageDraw.Draw(sheet)
    for i, (img, caption) in enumerate(zip(images, captions, strict=True)):
        x, y = (i % columns) * w, (i // columns) * h
        sheet.paste(img, (x, y))
        draw.text((x + 4, y + 4), caption, fill=(60, 60, 60))
    return sheet


def render_strip(meshes, out_png: str | Path) -> Path:
    """One row of shaded pictures of `meshes`, in order (an interpolation sequence)."""
    renderer = shaded_renderer()
    images = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, mesh in enumerate(meshes):
            renderer.render(mesh, Path(tmp) / f"{i}.png")
            images.append(on_white(Image.open(Path(tmp) / f"{i}.png")))
    with meshio.atomic_path(out_png) as tmp_png:
        grid(images, [str(i) for i in range(len(meshes))], columns=len(meshes)).save(tmp_png, format="PNG")
    return Path(out_png)


def render_gallery(domain: str, out_png: str | Path, n: int = 16, seed: int = 0, program=None) -> Path:
    """A 4-column grid of `n` shapes drawn with `program.random_values(rng)` from `seed`.
    A shape that fails to evaluate gets a caption saying so instead of stopping the grid."""
    if program is None:
        from geocode.program import Program

        program = Program.load(domain)
    rng = np.random.default_rng(seed)
    renderer = shaded_renderer()
    images, captions = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(n):
            values = program.random_values(rng)
            try:
                mesh = program.evaluate(values)
            except ValueError as exc:
                log.warning("gallery %s shape %d: %s", domain, i, exc)
                images.append(Image.new("RGB", (renderer.scene.render.resolution_x,) * 2, "white"))
                captions.append(f"{i}: failed")
                continue
            renderer.render(mesh, Path(tmp) / f"{i}.png")
            images.append(on_white(Image.open(Path(tmp) / f"{i}.png")))
            captions.append(f"{i}: {len(mesh.faces)} faces")
    with meshio.atomic_path(out_png) as tmp_png:
        grid(images, captions).save(tmp_png, format="PNG")
    return Path(out_png)
