"""geocode: interpretable shape programs and parameter recovery from point clouds and sketches.

Only `geocode.nodes`, `geocode.program` and `geocode.blender` import bpy; importing this
package does not.
"""

__version__ = "0.1.0"
