"""Networks (docs/paper-numbers.md#network): DGCNN and VGG encoders, per-parameter decoders, the LightningModule."""

from geocode.models.dgcnn import (
    DGCNN,
    DGCNNReference,
    edge_conv_fast,
    gather_neighbours,
)
from geocode.models.heads import Decoders, head_specs
from geocode.models.module import VARIANTS, GeoCodeModule
from geocode.models.neighbours import knn, knn_cells, knn_chunked, nearest_neighbours
from geocode.models.vgg import VGGSketchEncoder

__all__ = [
    "DGCNN", "DGCNNReference", "Decoders", "GeoCodeModule", "VARIANTS", "VGGSketchEncoder",
    "edge_conv_fast", "gather_neighbours", "head_specs", "knn", "knn_cells", "knn_chunked",
    "nearest_neighbours",
]
