"""Seeded randomness from keys (no bpy): every random draw of a pipeline step comes from
`generator(seed, *keys)`, with `seed` the config's `seed` and the keys naming the draw (a stage,
a shape id, a camera). A draw thus depends on what it is for, never on the order in which
shapes, shards or processes run, and changing `seed` changes every draw."""

from __future__ import annotations

import hashlib

import numpy as np


def key_word(*keys) -> int:
    """A 64-bit number from `keys` (their text), the same in every process and Python version
    (unlike hash(), which is salted per process)."""
    text = "\x1f".join(map(str, keys)).encode()
    return int.from_bytes(hashlib.blake2b(text, digest_size=8).digest(), "little")


def generator(seed: int, *keys) -> np.random.Generator:
    """The generator of the draw named by `keys` under `seed`."""
    return np.random.default_rng(key_word(int(seed), *keys))
