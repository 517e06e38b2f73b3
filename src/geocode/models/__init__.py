"""Networks (docs/paper-numbers.md#network): DGCNN and VGG encoders, per-parameter decoders, the
network and its LightningModule (imported on first use: inference needs no Lightning)."""

from geocode.models.dgcnn import (
    DGCNN,
    DGCNNReference,
    edge_conv_fast,
    gather_neighbours,
)
from geocode.models.heads import Decoders, head_specs
from geocode.models.neighbours import knn, knn_cells, knn_chunked, nearest_neighbours
from geocode.models.network import VARIANTS, GeoCodeNet
from geocode.models.vgg import VGGSketchEncoder

__all__ = [
    "DGCNN", "DGCNNReference", "Decoders", "GeoCodeModule", "GeoCodeNet", "VARIANTS", "VGGSketchEncoder",
    "edge_conv_fast", "gather_neighbours", "head_specs", "knn", "knn_cells", "knn_chunked",
    "nearest_neighbours",
]


def __getattr__(name: str):
    if name == "GeoCodeModule":   # Hydra's `_target_: geocode.models.GeoCodeModule`
        from geocode.models.module import GeoCodeModule

        return GeoCodeModule
    raise AttributeError(f"module 'geocode.models' has no attribute {name!r}")
