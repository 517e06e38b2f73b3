"""Freestyle line drawings of unit-sphere meshes: 224x224 grayscale, black strokes on white.

One `SketchRenderer` per process owns a dedicated scene (Cycles on the CPU, Freestyle on),
one mesh object whose data is swapped between shapes, and one camera moved between views.

Framing: an orthographic camera with `ortho_scale = 2 * MARGIN` looking at the origin.
A unit-sphere mesh projects into a disc of radius 1 from any direction, so every shape
fits every view at the same scale, and distances on the image are comparable across
shapes and cameras (a perspective camera would change the apparent size with the view).

Speed (measured on vase meshes of ~6K faces, one core): ~0.11-0.13 s per view, of which
Cycles ~0.03 s; the rest is Freestyle. What it takes: Cycles on the CPU, 1 sample, no
denoising, adaptive sampling, compositing or sequencer, persistent data, one render thread,
the mesh invisible to all Cycles rays, Freestyle in parameter-editor mode with one line set
(visible silhouette, border and crease edges; culling on; plain chaining), and mesh data
swapped in place with foreach_set (~3 ms). Dropping hidden-line removal made it slower (more
strokes to draw); the crease angle changes little.

Cameras: azimuth in degrees about +z, 0 = looking from -y (Blender's front view), positive
towards +x; elevation in degrees above the horizon. Meshes are z-up.
"""

from __future__ import annotations

import hashlib
import logging
import math
import struct
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geocode import meshio
from geocode.blender.progress import Progress, quiet_stdout
from geocode.errors import UserError, signals_deferred

log = logging.getLogger(__name__)

MARGIN = 1.05          # image half-width in unit-sphere radii
DISTANCE = 3.0         # camera distance from the origin (outside the unit sphere)
CREASE_ANGLE = 134.43  # degrees; Freestyle's default, keeps the drawings close to the paper's
DEFAULT_ELEVATION = 30.0


@dataclass(frozen=True)
class Camera:
    name: str
    azimuth: float
    elevation: float = DEFAULT_ELEVATION


# Trained views at 35 and 55 degrees, a novel view at 15 degrees (SPEC §3).
DEFAULT_CAMERAS = (Camera("az35", 35.0), Camera("az55", 55.0), Camera("az15", 15.0))


def cameras_from_config(items: Iterable[Mapping], elevation: float = DEFAULT_ELEVATION) -> list[Camera]:
    """[{name, azimuth, elevation?}] -> cameras; a missing elevation takes `elevation`."""
    cams = []
    for item in items:
        try:
            cams.append(Camera(str(item["name"]), float(item["azimuth"]),
                               float(item.get("elevation", elevation))))
        except KeyError as exc:
            raise ValueError(f"sketch camera {dict(item)}: missing key {exc}; give name and azimuth") from None
    if len({c.name for c in cams}) != len(cams):
        raise ValueError(f"sketch cameras: duplicate names in {[c.name for c in cams]}")
    return cams


def jittered(camera: Camera, seed: int, shape_id: str, amount: float) -> Camera:
    """The camera turned by a uniform offset in [-amount, amount] degrees on both angles,
    drawn from (seed, shape id, camera name) alone, so a rerun gives the same view."""
    if amount <= 0:
        return camera
    key = hashlib.sha256(f"{seed}/{shape_id}/{camera.name}".encode()).digest()
    rng = np.random.default_rng(int.from_bytes(key[:8], "little"))
    d_az, d_el = rng.uniform(-amount, amount, size=2)
    return Camera(camera.name, camera.azimuth + d_az, camera.elevation + d_el)


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


def png_pixels_only(data: bytes) -> bytes:
    """The PNG with only its critical chunks (IHDR, PLTE, IDAT, IEND): Cycles stamps render
    times into tEXt chunks whatever the stamp settings, which would make bytes differ."""
    keep, pos = [data[:8]], 8
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        end = pos + 12 + length
        if data[pos + 4:pos + 8] in (b"IHDR", b"PLTE", b"IDAT", b"IEND"):
            keep.append(data[pos:end])
        pos = end
    return b"".join(keep)


class SketchRenderer:
    """Cycles + Freestyle in a scene of its own; create once per process, then call
    `set_mesh` per shape and `render` per view."""

    def __init__(self, size: int = 224, line_thickness: float = 1.0,
                 crease_angle: float = CREASE_ANGLE):
        import bpy

        self.bpy = bpy
        self.size = size
        self.scene = bpy.data.scenes.new("geocode_sketch")
        self._setup_render(line_thickness)
        self._setup_freestyle(crease_angle)
        self._setup_world()
        self.mesh = bpy.data.meshes.new("geocode_sketch_shape")
        self.obj = bpy.data.objects.new("geocode_sketch_shape", self.mesh)
        # Cycles need not see the mesh at all: the white world is the whole picture. Freestyle
        # still reads the geometry, so the strokes (and their hidden-line removal) stay, and
        # Cycles skips shading it (same bytes, ~10% faster per view).
        for ray in ("camera", "diffuse", "glossy", "transmission", "volume_scatter", "shadow"):
            setattr(self.obj, f"visible_{ray}", False)
        self.scene.collection.objects.link(self.obj)
        self.camera = self._setup_camera()

    def _setup_render(self, line_thickness: float) -> None:
        r = self.scene.render
        r.engine = "CYCLES"
        r.resolution_x = r.resolution_y = self.size
        r.resolution_percentage = 100
        r.use_persistent_data = True        # keep Cycles' scene between views
        r.threads_mode, r.threads = "FIXED", 1
        r.use_compositing = r.use_sequencer = False
        r.use_freestyle = True
        r.line_thickness_mode, r.line_thickness = "ABSOLUTE", line_thickness
        r.film_transparent = False
        r.dither_intensity = 0.0            # dither noise would make white 254 and bytes random
        for name in dir(r):                 # no date/time/render-time text: identical bytes
            if name.startswith("use_stamp"):
                setattr(r, name, False)
        img = r.image_settings
        img.file_format, img.color_mode, img.color_depth = "PNG", "BW", "8"
        img.compression = 15                # Blender's default, fixed so bytes never drift
        c = self.scene.cycles
        c.device, c.samples, c.use_denoising = "CPU", 1, False
        c.use_adaptive_sampling = False
        c.max_bounces = 0
        self.scene.view_settings.view_transform = "Standard"   # white stays 255
        self.scene.view_settings.look = "None"

    def _setup_freestyle(self, crease_angle: float) -> None:
        bpy = self.bpy
        layer = self.scene.view_layers[0]
        layer.use_freestyle = True
        fs = layer.freestyle_settings
        fs.mode = "EDITOR"
        fs.crease_angle = math.radians(crease_angle)
        fs.use_culling = True
        fs.use_smoothness = False
        for ls in list(fs.linesets):
            fs.linesets.remove(ls)
        lineset = fs.linesets.new("strokes")
        lineset.select_by_visibility = True
        lineset.visibility = "VISIBLE"
        lineset.select_by_edge_types = True
        lineset.select_by_collection = lineset.select_by_face_marks = False
        lineset.select_by_image_border = False
        for edge in ("silhouette", "border", "crease"):
            setattr(lineset, f"select_{edge}", True)
        for edge in ("contour", "external_contour", "ridge_valley", "suggestive_contour",
                     "material_boundary", "edge_mark"):
            setattr(lineset, f"select_{edge}", False)
        style = bpy.data.linestyles.new("geocode_sketch_style")
        style.color = (0.0, 0.0, 0.0)
        style.alpha = 1.0
        style.thickness = 1.0
        style.use_chaining, style.chaining = True, "PLAIN"
        lineset.linestyle = style

    def _setup_world(self) -> None:
        world = self.bpy.data.worlds.new("geocode_sketch_white")   # 5.0: comes with nodes
        bg = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
        bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        bg.inputs["Strength"].default_value = 1.0
        self.scene.world = world

    def _setup_camera(self):
        cam_data = self.bpy.data.cameras.new("geocode_sketch_camera")
        cam_data.type = "ORTHO"
        cam_data.ortho_scale = 2 * MARGIN
        cam_data.clip_start, cam_data.clip_end = 0.1, 2 * DISTANCE
        cam = self.bpy.data.objects.new("geocode_sketch_camera", cam_data)
        self.scene.collection.objects.link(cam)
        self.scene.camera = cam
        return cam

    def alive(self) -> bool:
        """False once a factory reset (e.g. between tests) has removed our scene."""
        try:
            return self.scene.name in self.bpy.data.scenes
        except ReferenceError:
            return False

    def set_mesh(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        set_mesh_data(self.mesh, vertices, faces)

    def aim(self, camera: Camera) -> None:
        from mathutils import Vector

        loc = Vector(camera_location(camera))
        self.camera.location = loc
        # -Z of a Blender camera looks along the view direction; +Y stays up (z-up world).
        self.camera.rotation_mode = "QUATERNION"
        self.camera.rotation_quaternion = (-loc).to_track_quat("-Z", "Y")

    def render(self, camera: Camera, out_path: str | Path) -> None:
        """Render one view to `out_path` (written to a temporary name, then renamed)."""
        self.aim(camera)
        with meshio.atomic_path(out_path) as tmp:
            png = render_still(self.scene, tmp)
            try:
                Path(tmp).write_bytes(png_pixels_only(png.read_bytes()))
            finally:
                png.unlink(missing_ok=True)


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


_RENDERERS: dict[tuple, SketchRenderer] = {}


def renderer(size: int = 224, line_thickness: float = 1.0) -> SketchRenderer:
    """The process's renderer for these settings (built on first use, then reused)."""
    key = (size, line_thickness)
    if key not in _RENDERERS or not _RENDERERS[key].alive():
        _RENDERERS[key] = SketchRenderer(size, line_thickness)
    return _RENDERERS[key]


def sketch_mesh(mesh, out_paths: Mapping[str, str | Path], cameras: Sequence[Camera],
                shape_id: str = "", seed: int = 0, jitter: float = 0.0, size: int = 224) -> None:
    """Render one mesh (vertices/faces attributes) from every camera to out_paths[camera.name]."""
    r = renderer(size)
    r.set_mesh(mesh.vertices, mesh.faces)
    for cam in cameras:
        r.render(jittered(cam, seed, shape_id, jitter), out_paths[cam.name])


def read_ids(path: str | Path) -> list[str]:
    """The shape ids a stage's done file lists (the export step writes the one others read)."""
    path = Path(path)
    if not path.is_file():
        raise UserError(path, "missing", "run the export step for this shard first")
    return [line.strip() for line in path.read_text().splitlines() if line.strip()]


def is_sketch(path: Path) -> bool:
    """Whether `path` holds a decodable PNG: a rerun redoes empty or broken views."""
    from PIL import Image

    try:
        with Image.open(path) as image:
            image.verify()
    except (OSError, SyntaxError, ValueError):  # PIL's verify() raises SyntaxError on bad chunks
        return False
    return True


def sketch_shard(split_dir: str | Path, shard: int, cameras: Sequence[Camera | Mapping] = DEFAULT_CAMERAS,
                 size: int = 224, seed: int = 0, jitter: float = 0.0,
                 elevation: float = DEFAULT_ELEVATION) -> Path:
    """Sketch every shape that `done/export-<shard>.txt` lists; skip finished views; write
    `done/sketch-<shard>.txt` last. Cameras are `Camera`s or config items {name, azimuth,
    elevation?}; `elevation` fills a missing one. Returns the done file."""
    split_dir = Path(split_dir)
    cameras = [c if isinstance(c, Camera) else cameras_from_config([c], elevation)[0]
               for c in cameras]
    ids = read_ids(split_dir / "done" / f"export-{shard}.txt")
    out_dir = split_dir / "sketches"
    progress = Progress(f"sketch shard {shard}", len(ids) * len(cameras), log)
    for shape_id in ids:
        paths = {c.name: out_dir / f"{shape_id}_{c.name}.png" for c in cameras}
        todo = [c for c in cameras if not is_sketch(paths[c.name])]
        if todo:
            mesh = meshio.read_obj(split_dir / "shapes" / f"{shape_id}.obj", meshio.REDO_EXPORT)
            sketch_mesh(mesh, paths, todo, shape_id, seed, jitter, size)
        progress.step(len(cameras))
    progress.finish()
    done = split_dir / "done" / f"sketch-{shard}.txt"
    meshio.write_text(done, "".join(f"{i}\n" for i in ids))
    return done
