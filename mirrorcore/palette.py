"""The one palette of source colours (viewer, exports, plots): 0 = direct view, j = through mirror j; and the heat map
of a calibration (points coloured by their distance to the direct surface)."""
from __future__ import annotations

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


def source_colour(source: int) -> np.ndarray:
    """(3,) uint8 RGB of one source."""
    return source_colours(np.array([source]))[0]


def source_colours(sources: np.ndarray) -> np.ndarray:
    """sources : (n,) integer labels -> (n, 3) uint8 RGB."""
    sources = np.asarray(sources, dtype=np.int64)
    idx = np.where(sources == 0, 0, 1 + (sources - 1) % (len(SOURCE_COLOURS) - 1))
    return SOURCE_COLOURS[idx]


def source_name(source: int) -> str:
    """'direct' or 'mirror j'."""
    return "direct" if source == 0 else f"mirror {source}"


HEAT_NEGATIVE = np.array([33, 102, 172])    # inside the direct surface: blue
HEAT_ZERO = np.array([247, 247, 247])       # on it: white
HEAT_POSITIVE = np.array([178, 24, 43])     # outside it: red


def heat_colours(values: np.ndarray, limit: float, missing=SOURCE_COLOURS[0]) -> np.ndarray:
    """values : (n,) float signed distances (any unit, NaN for none) -> (n, 3) uint8 RGB: white at 0, blue at
    -limit and below, red at +limit and above, linear between; `missing` (3,) for NaN (the direct grey)."""
    t = np.clip(np.nan_to_num(np.asarray(values, dtype=np.float64), nan=0.0) / limit, -1.0, 1.0)[:, None]
    rgb = np.where(t < 0, HEAT_ZERO + (HEAT_ZERO - HEAT_NEGATIVE) * t, HEAT_ZERO + (HEAT_POSITIVE - HEAT_ZERO) * t)
    rgb[np.isnan(np.asarray(values, dtype=np.float64))] = missing
    return np.round(rgb).astype(np.uint8)
