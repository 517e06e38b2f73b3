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

import logging
import math
import struct
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from geocode import meshio, paths
from geocode.blender.scene import (  # noqa: F401 (Camera, MARGIN re-exported for callers)
    DEFAULT_ELEVATION,
    MARGIN,
    Camera,
    RenderScene,
    render_still,
    set_mesh_data,
)
from geocode.errors import UserError
from geocode.seeds import generator
from geocode.timing import Progress

log = logging.getLogger(__name__)

CREASE_ANGLE = 134.43  # degrees; Freestyle's default, keeps the drawings close to the paper's


# Trained views at 35 and 55 degrees, a novel view at 15 degrees (docs/paper-numbers.md#dataset-generation).
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
    d_az, d_el = generator(seed, "sketch-jitter", shape_id, camera.name).uniform(-amount, amount, 2)
    return Camera(camera.name, camera.azimuth + d_az, camera.elevation + d_el)


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


class SketchRenderer(RenderScene):
    """Cycles + Freestyle in a scene of its own; create once per process, then call
    `set_mesh` per shape and `render` per view."""

    def __init__(self, size: int = 224, line_thickness: float = 1.0,
                 crease_angle: float = CREASE_ANGLE):
        super().__init__("geocode_sketch", size, samples=1)
        self.size = size
        self._setup_lines(line_thickness, crease_angle)
        # Cycles need not see the mesh at all: the white world is the whole picture. Freestyle
        # still reads the geometry, so the strokes (and their hidden-line removal) stay, and
        # Cycles skips shading it (same bytes, ~10% faster per view).
        for ray in ("camera", "diffuse", "glossy", "transmission", "volume_scatter", "shadow"):
            setattr(self.obj, f"visible_{ray}", False)

    def _setup_lines(self, line_thickness: float, crease_angle: float) -> None:
        r = self.scene.render
        r.use_persistent_data = True        # keep Cycles' scene between views
        r.threads_mode, r.threads = "FIXED", 1
        r.use_freestyle = True
        r.line_thickness_mode, r.line_thickness = "ABSOLUTE", line_thickness
        r.film_transparent = False
        img = r.image_settings
        img.file_format, img.color_mode, img.color_depth = "PNG", "BW", "8"
        img.compression = 15                # Blender's default, fixed so bytes never drift
        self.scene.cycles.use_adaptive_sampling = False
        self.scene.cycles.max_bounces = 0
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
        style = self.bpy.data.linestyles.new("geocode_sketch_style")
        style.color = (0.0, 0.0, 0.0)
        style.alpha = 1.0
        style.thickness = 1.0
        style.use_chaining, style.chaining = True, "PLAIN"
        lineset.linestyle = style

    def set_mesh(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        set_mesh_data(self.mesh, vertices, faces)

    def render(self, camera: Camera, out_path: str | Path) -> None:
        """Render one view to `out_path` (written to a temporary name, then renamed)."""
        self.aim(camera)
        with meshio.atomic_path(out_path) as tmp:
            png = render_still(self.scene, tmp)
            try:
                Path(tmp).write_bytes(png_pixels_only(png.read_bytes()))
            finally:
                png.unlink(missing_ok=True)


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
                 elevation: float = DEFAULT_ELEVATION,
                 only: Callable[[list[str]], list[str]] | None = None) -> Path:
    """Sketch every shape that `done/export-<shard>.txt` lists (those `only` keeps of them, where given);
    skip finished views; write `done/sketch-<shard>.txt`, the shapes drawn, last. Cameras are
    `Camera`s or config items {name, azimuth, elevation?}; `elevation` fills a missing one.
    Returns the done file."""
    split_dir = Path(split_dir)
    cameras = [c if isinstance(c, Camera) else cameras_from_config([c], elevation)[0]
               for c in cameras]
    ids = read_ids(paths.done_file(split_dir, "export", shard))
    ids = ids if only is None else only(ids)
    progress = Progress(f"sketch shard {shard}", len(ids) * len(cameras), log)
    for shape_id in ids:
        views = {c.name: paths.sketch_file(split_dir, shape_id, c.name) for c in cameras}
        todo = [c for c in cameras if not is_sketch(views[c.name])]
        if todo:
            mesh = meshio.read_obj(paths.shape_file(paths.shapes_dir(split_dir), shape_id), meshio.REDO_EXPORT)
            sketch_mesh(mesh, views, todo, shape_id, seed, jitter, size)
        progress.step(len(cameras))
    progress.finish()
    done = paths.done_file(split_dir, "sketch", shard)
    meshio.write_text(done, "".join(f"{i}\n" for i in ids))
    return done
