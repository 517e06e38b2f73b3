"""Batched Blender work, one process per shard: export, sketch rendering, rebuilding
predictions, galleries. Every module here imports bpy (lazily where it can)."""
