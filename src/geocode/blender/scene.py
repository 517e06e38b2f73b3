"""What the sketch and gallery renderers share: a Cycles scene of their own with one mesh
object (its data swapped between shapes), a world of one colour, and an orthographic camera
that frames the unit sphere from any direction; plus quiet, interrupt-safe still renders.

Cameras: azimuth in degrees about +z, 0 = looking from -y (Blender's front view), positive
towards +x; elevation in degrees above the horizon. Meshes are z-up.
"""

from __future__ import annotations

import math
import os
import sys
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geocode.errors import signals_deferred

MARGIN = 1.05          # image half-width in unit-sphere radii
DISTANCE = 3.0         # camera distance from the origin (outside the unit sphere)
DEFAULT_ELEVATION = 30.0


@dataclass(frozen=True)
class Camera:
    name: str
    azimuth: float
    elevation: float = DEFAULT_ELEVATION


def camera_location(camera: Camera, distance: float = DISTANCE) -> tuple[float, float, float]:
    az, el = math.radians(camera.azimuth), math.radians(camera.elevation)
    return (distance * math.cos(el) * math.sin(az),
            -distance * math.cos(el) * math.cos(az),
            distance * math.sin(el))


def set_mesh_data(mesh, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Replace a bpy mesh's geometry with a triangle mesh through foreach_set (no Python loops)."""
    vertices = np.ascontiguousarray(vertices, dtype=np.float32)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    mesh.clear_geometry()
    mesh.vertices.add(len(vertices))
    mesh.vertices.foreach_set("co", vertices.ravel())
    mesh.loops.add(faces.size)
    mesh.loops.foreach_set("vertex_index", faces.ravel())
    mesh.polygons.add(len(faces))
    mesh.polygons.foreach_set("loop_start", np.arange(0, faces.size, 3, dtype=np.int32))
    mesh.update(calc_edges=True)


class RenderScene:
    """A scene named `name` (so it never disturbs a program's objects): Cycles on the CPU at
    `size` x `size` with `samples` samples, no denoising, compositing, dithering or stamps; a
    world of `background` at `strength`; one mesh object; an orthographic camera."""

    def __init__(self, name: str, size: int, samples: int, background=(1.0, 1.0, 1.0),
                 strength: float = 1.0):
        import bpy

        self.bpy = bpy
        self.scene = bpy.data.scenes.new(name)
        self._setup_render(size, samples)
        self._setup_world(name, background, strength)
        self.mesh = bpy.data.meshes.new(f"{name}_shape")
        self.obj = bpy.data.objects.new(f"{name}_shape", self.mesh)
        self.scene.collection.objects.link(self.obj)
        self.camera = self._setup_camera(name)

    def _setup_render(self, size: int, samples: int) -> None:
        r = self.scene.render
        r.engine = "CYCLES"
        r.resolution_x = r.resolution_y = size
        r.resolution_percentage = 100
        r.use_compositing = r.use_sequencer = False
        r.dither_intensity = 0.0            # dither noise would make white 254 and bytes random
        for name in dir(r):                 # no date/time/render-time text: identical bytes
            if name.startswith("use_stamp"):
                setattr(r, name, False)
        c = self.scene.cycles
        c.device, c.samples, c.use_denoising = "CPU", samples, False
        self.scene.view_settings.view_transform = "Standard"   # white stays 255
        self.scene.view_settings.look = "None"

    def _setup_world(self, name: str, background, strength: float) -> None:
        world = self.bpy.data.worlds.new(f"{name}_world")   # 5.0: comes with nodes
        bg = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
        bg.inputs["Color"].default_value = (*background, 1.0)
        bg.inputs["Strength"].default_value = strength
        self.scene.world = world

    def _setup_camera(self, name: str):
        data = self.bpy.data.cameras.new(f"{name}_camera")
        data.type, data.ortho_scale = "ORTHO", 2 * MARGIN
        data.clip_start, data.clip_end = 0.1, 2 * DISTANCE
        camera = self.bpy.data.objects.new(f"{name}_camera", data)
        self.scene.collection.objects.link(camera)
        self.scene.camera = camera
        return camera

    def aim(self, camera: Camera) -> None:
        from mathutils import Vector

        loc = Vector(camera_location(camera))
        self.camera.location = loc
        # -Z of a Blender camera looks along the view direction; +Y stays up (z-up world).
        self.camera.rotation_mode = "QUATERNION"
        self.camera.rotation_quaternion = (-loc).to_track_quat("-Z", "Y")

    def alive(self) -> bool:
        """False once a factory reset (e.g. between tests) has removed our scene."""
        try:
            return self.scene.name in self.bpy.data.scenes
        except ReferenceError:
            return False


@contextmanager
def quiet_stdout():
    """Silence C-level stdout (Blender's per-render 'Fra:'/'Saved:' lines) for the block,
    so shard logs hold only our progress lines; stderr, where errors go, stays."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def render_still(scene, tmp: Path) -> Path:
    """Render `scene` to a PNG beside `tmp` and return its path (the caller removes it)."""
    import bpy

    png = Path(str(tmp) + ".png")   # Blender appends the extension it wants
    scene.render.filepath = str(png)
    scene.render.use_file_extension = False
    try:
        with quiet_stdout(), signals_deferred():
            result = bpy.ops.render.render(write_still=True, scene=scene.name)
        if result != {"FINISHED"}:
            raise KeyboardInterrupt(f"render of {scene.name} ended {sorted(result)}")
    except BaseException:
        png.unlink(missing_ok=True)
        raise
    return png
