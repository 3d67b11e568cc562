"""Source labels and their one palette (viewer, exports, plots): 0 = direct view, j = through mirror
j, and labels from FIRST_MULTI_LABEL up for views through several mirrors in turn (docs/DESIGN.md,
Conventions).

A multi-bounce source is the sequence of mirrors its camera ray meets, in the order it meets them
(the pixel lies in the first one's outline; the last one faces the object). Labels
FIRST_MULTI_LABEL.. enumerate the sequences of 2 and 3 mirrors (no mirror twice in a row) grouped by
their highest mirror, then by length, then in lexicographic order: 33 = (1, 2), 34 = (2, 1), 35 =
(1, 2, 1), 36 = (2, 1, 2), 37 = (1, 3), ... The order does not depend on the rig, so a label reads
the same in every file; whole groups are numbered while they fit under 255 (NO_SOURCE in dense
grids): every sequence of 2 mirrors among mirrors 1-7 and of 3 mirrors among mirrors 1-6.

The heat map of a calibration (points coloured by their distance to the direct surface) is here too.
"""
from __future__ import annotations

from functools import lru_cache
from itertools import pairwise, product
from typing import Sequence

import numpy as np

MAX_MIRRORS = 32            # labels 1..32 name single mirrors
FIRST_MULTI_LABEL = MAX_MIRRORS + 1
MAX_ORDER = 3               # the most mirrors a label can name in turn
LAST_LABEL = 254            # 255 is reserved (dense grids' NO_SOURCE)

# Direct view first, then one colour per mirror (Okabe-Ito, readable by colour-blind users); repeats
# past 7 mirrors.
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
UNKNOWN_COLOUR = (60, 60, 60)   # a label that names no source (a file from elsewhere)


def _multi_sequences() -> tuple[tuple[int, ...], ...]:
    """The sequences of labels FIRST_MULTI_LABEL.. in order (see the module docstring)."""
    out: list[tuple[int, ...]] = []
    for top in range(2, MAX_MIRRORS + 1):
        for length in range(2, MAX_ORDER + 1):
            group = [s for s in product(range(1, top + 1), repeat=length)
                     if max(s) == top and all(a != b for a, b in pairwise(s))]
            if FIRST_MULTI_LABEL + len(out) + len(group) - 1 > LAST_LABEL:
                return tuple(out)
            out.extend(group)
    return tuple(out)


MULTI_SEQUENCES = _multi_sequences()
_LABEL_OF = {s: FIRST_MULTI_LABEL + i for i, s in enumerate(MULTI_SEQUENCES)}


def source_sequence(source: int) -> tuple[int, ...]:
    """Return the mirrors a label names, in the order the camera's ray meets them.

    Parameters
    ----------
    source : int
        A source label.

    Returns
    -------
    tuple of int
        1-based mirrors: () direct, (j,) mirror j, (a, b, ...) a multi-bounce view.

    Raises
    ------
    ValueError
        The label names no source.
    """
    source = int(source)
    if 0 <= source <= MAX_MIRRORS:
        return (source,) if source else ()
    if FIRST_MULTI_LABEL <= source < FIRST_MULTI_LABEL + len(MULTI_SEQUENCES):
        return MULTI_SEQUENCES[source - FIRST_MULTI_LABEL]
    raise ValueError(f"source label {source} names no view")


def sequence_label(sequence) -> int | None:
    """Return the label of a sequence of mirrors.

    Parameters
    ----------
    sequence : iterable of int
        1-based mirrors in ray order.

    Returns
    -------
    int or None
        0 for (), j for (j,), FIRST_MULTI_LABEL.. for longer ones; None when the encoding has no
        label for it (more than MAX_ORDER mirrors, a mirror twice in a row, or a mirror beyond what
        the labels cover).
    """
    sequence = tuple(int(j) for j in sequence)
    if len(sequence) <= 1:
        return (sequence[0] if 1 <= sequence[0] <= MAX_MIRRORS else None) if sequence else 0
    return _LABEL_OF.get(sequence)


def _order(source: int) -> int:
    """The number of mirrors a label looks through in turn, -1 if it names no view."""
    try:
        return len(source_sequence(source))
    except ValueError:
        return -1


_ORDERS = np.array([_order(s) for s in range(256)], np.int8)


def source_orders(sources: np.ndarray) -> np.ndarray:
    """Count how many mirrors each view looks through in turn.

    Parameters
    ----------
    sources : (n,) integer array
        Labels 0..255.

    Returns
    -------
    (n,) int8 array
        0 direct, 1 a mirror, 2 or 3 a sequence, -1 for a label that names no view.
    """
    return _ORDERS[np.asarray(sources, dtype=np.int64)]


def source_name(source: int, names: Sequence[str] | None = None) -> str:
    """Name a source: 'direct', 'mirror j', or 'mirror a then b[ then c]'.

    Parameters
    ----------
    source : int
        A source label.
    names : sequence of str, optional
        The mirrors' names in label order (a session's): gives 'left', 'left then right' (a label
        beyond them keeps its number).

    Returns
    -------
    str
        The name; 'source N' for a label that names no view.
    """
    try:
        sequence = source_sequence(source)
    except ValueError:
        return f"source {int(source)}"
    if not sequence:
        return "direct"
    if names is not None and max(sequence) <= len(names):
        return " then ".join(names[j - 1] for j in sequence)
    return "mirror " + " then ".join(map(str, sequence))


def _mirror_colour(j: int) -> np.ndarray:
    """(3,) float64 RGB of mirror colour number j >= 1 (a label, or a mirror's stable id)."""
    return SOURCE_COLOURS[1 + (j - 1) % (len(SOURCE_COLOURS) - 1)].astype(np.float64)


def _label_colour(source: int, mirror_ids: tuple[int, ...]) -> np.ndarray:
    """Return the (3,) float64 RGB of a label.

    A mirror's colour follows its label j, or its id mirror_ids[j - 1] when given. A multi-bounce
    view is a shade of its last mirror's colour (the mirror that faces the object), tinted by the
    mirrors before it (each weighing a quarter of the next), a quarter darker with each further
    mirror.
    """
    try:
        sequence = source_sequence(source)
    except ValueError:
        return np.array(UNKNOWN_COLOUR, np.float64)
    if not sequence:
        return SOURCE_COLOURS[0].astype(np.float64)
    colours = [_mirror_colour(mirror_ids[j - 1] if j <= len(mirror_ids) else j) for j in sequence]
    # last mirror 1, the one before 0.25, ...
    weights = 0.25 ** np.arange(len(sequence))[::-1]
    mix = sum(w * c for w, c in zip(weights, colours)) / weights.sum()
    return mix * 0.75 ** (len(sequence) - 1)


@lru_cache(maxsize=32)
def _lookup(mirror_ids: tuple[int, ...]) -> np.ndarray:
    """Return the (256, 3) uint8 RGB of every label, coloured by `mirror_ids` (() : by label)."""
    table = np.array([_label_colour(s, mirror_ids) for s in range(256)]).round().astype(np.uint8)
    table.flags.writeable = False
    return table


def source_colours(sources: np.ndarray, mirror_ids: Sequence[int] | None = None) -> np.ndarray:
    """Colour sources by label: the one colour lookup of the project.

    A mirror's colour follows its label j, or, given the ids of the mirrors, its id: a mirror keeps
    its colour when another one is removed. Views through several mirrors take shades of theirs.

    Parameters
    ----------
    sources : (n,) integer array
        Labels 0..255.
    mirror_ids : sequence of int, optional
        The ids of the mirrors in session order (mirror_ids[j - 1] for label j).

    Returns
    -------
    (n, 3) uint8 array
        RGB.
    """
    ids = () if mirror_ids is None else tuple(int(i) for i in mirror_ids)
    return _lookup(ids)[np.asarray(sources, dtype=np.int64)]


def source_colour(source: int, mirror_ids: Sequence[int] | None = None) -> np.ndarray:
    """Return the colour of one source (see `source_colours`).

    Parameters
    ----------
    source : int
        A source label.
    mirror_ids : sequence of int, optional
        The ids of the mirrors in session order.

    Returns
    -------
    (3,) uint8 array
        RGB.
    """
    return source_colours(np.array([source]), mirror_ids)[0]


HEAT_NEGATIVE = np.array([33, 102, 172])    # inside the direct surface: blue
HEAT_ZERO = np.array([247, 247, 247])       # on it: white
HEAT_POSITIVE = np.array([178, 24, 43])     # outside it: red
# a mirror's point with nothing to compare with: dark grey
HEAT_UNCOMPARED = np.array([70, 70, 70])


def heat_colours(values: np.ndarray, limit: float, missing=SOURCE_COLOURS[0]) -> np.ndarray:
    """Colour signed distances: white at 0, blue at -limit and below, red at +limit and above.

    Linear between.

    Parameters
    ----------
    values : (n,) float array
        Signed distances (any unit), NaN for none.
    limit : float
        The distance of full colour, in the unit of `values`.
    missing : (3,) array
        The colour of NaN (the direct grey).

    Returns
    -------
    (n, 3) uint8 array
        RGB.
    """
    t = np.clip(np.nan_to_num(np.asarray(values, dtype=np.float64), nan=0.0) / limit, -1.0,
                1.0)[:, None]
    rgb = np.where(t < 0, HEAT_ZERO + (HEAT_ZERO - HEAT_NEGATIVE) * t,
                   HEAT_ZERO + (HEAT_POSITIVE - HEAT_ZERO) * t)
    rgb[np.isnan(np.asarray(values, dtype=np.float64))] = missing
    return np.round(rgb).astype(np.uint8)


def heat_map_colours(distances: np.ndarray, sources: np.ndarray, limit: float) -> np.ndarray:
    """Colour the heat map of a cloud.

    Parameters
    ----------
    distances : (n,) float array
        mm to the direct surface, NaN for none.
    sources : (n,) integer array
        Source labels.
    limit : float
        mm of full colour.

    Returns
    -------
    (n, 3) uint8 array
        RGB: `heat_colours` for the mirrors' points compared, the direct grey for the camera's own
        points, HEAT_UNCOMPARED (dark grey) for the mirrors' points the camera does not see.
    """
    colours = heat_colours(distances, limit)
    colours[(np.asarray(sources) != 0) & np.isnan(np.asarray(
        distances, dtype=np.float64))] = HEAT_UNCOMPARED
    return colours
