"""The model variants and the inputs each takes (docs/paper-numbers.md#tables): plain Python,
read by the config (a variant's epochs) and by the networks."""

from __future__ import annotations

from collections.abc import Sequence

VARIANTS = ("joint", "separate", "regression", "huang")
MODALITIES = ("points", "sketch")
# The inputs a variant can take: Huang et al. 2017 read sketches only.
VARIANT_MODALITIES = {"huang": ("sketch",)}


def variant_modalities(variant: str, modalities: Sequence[str] = MODALITIES) -> list[str]:
    """The asked-for modalities that the variant takes, in MODALITIES order."""
    allowed = VARIANT_MODALITIES.get(variant, MODALITIES)
    kept = [m for m in MODALITIES if m in modalities and m in allowed]
    if not kept:
        raise ValueError(f"model.variant={variant} takes {', '.join(allowed)}: "
                         f"modalities={list(modalities)} leaves it no input")
    return kept
