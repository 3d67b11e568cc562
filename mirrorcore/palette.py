"""The one palette of source colours (viewer, exports, plots): 0 = direct view, j = through mirror j."""
from __future__ import annotations

from typing import Sequence

import numpy as np

# Direct view first, then one colour per mirror (Okabe-Ito, readable by colour-blind users); repeats past 8 mirrors.
SOURCE_COLOURS = np.array([
    [150, 150, 150],   # 0: direct, grey
    [230, 159, 0],     # mirror 1: orange
    [86, 180, 233],    # mirror 2: sky blue
    [0, 158, 115],     # mirror 3: green
    [204, 121, 167],   # mirror 4: pink
    [213, 94, 0],      # mirror 5: vermilion
    [0, 114, 178],     # mirror 6: blue
    [240, 228, 66],    # mirror 7: yellow
], dtype=np.uint8)


def source_colour(source: int, mirror_ids: Sequence[int] | None = None) -> np.ndarray:
    """(3,) uint8 RGB of one source (see source_colours)."""
    return source_colours(np.array([source]), mirror_ids)[0]


def source_colours(sources: np.ndarray, mirror_ids: Sequence[int] | None = None) -> np.ndarray:
    """sources : (n,) integer labels -> (n, 3) uint8 RGB. A mirror's colour follows its label j, or, given the ids of
    the mirrors in session order (mirror_ids[j - 1] for label j), its id: a mirror keeps its colour when another one
    is removed."""
    sources = np.asarray(sources, dtype=np.int64)
    if mirror_ids is not None and len(sources):
        sources = np.concatenate([[0], np.asarray(mirror_ids, np.int64)])[sources]
    idx = np.where(sources == 0, 0, 1 + (sources - 1) % (len(SOURCE_COLOURS) - 1))
    return SOURCE_COLOURS[idx]


def source_name(source: int) -> str:
    """'direct' or 'mirror j'."""
    return "direct" if source == 0 else f"mirror {source}"
