"""Source labels (docs/DESIGN.md, Conventions): 0 direct and j mirror j unchanged, multi-bounce
sequences from 33 in a fixed order, their names and colours."""
from itertools import pairwise

import numpy as np
import pytest

from mirrorcore.base.palette import (
    FIRST_MULTI_LABEL,
    MULTI_SEQUENCES,
    SOURCE_COLOURS,
    sequence_label,
    source_colour,
    source_colours,
    source_name,
    source_orders,
    source_sequence,
)


def test_direct_and_single_mirrors_keep_their_labels_names_and_colours():
    assert source_name(0) == "direct" and source_name(1) == "mirror 1" and source_name(
        32) == "mirror 32"
    assert sequence_label(()) == 0 and sequence_label((1,)) == 1 and sequence_label((7,)) == 7
    assert source_sequence(0) == () and source_sequence(5) == (5,)
    np.testing.assert_array_equal(source_colours(np.arange(9)),
                                  SOURCE_COLOURS[[0, 1, 2, 3, 4, 5, 6, 7, 1]])


def test_the_first_multi_bounce_labels_by_hand():
    """Two mirrors: 33 = 1 then 2, 34 = 2 then 1, 35 = 1 then 2 then 1, 36 = 2 then 1 then 2; a
    third mirror follows."""
    assert [source_sequence(s) for s in range(33, 38)] == [(1, 2), (2, 1), (1, 2, 1), (2, 1, 2),
                                                           (1, 3)]
    assert source_name(34) == "mirror 2 then 1" and source_name(36) == "mirror 2 then 1 then 2"
    assert sequence_label((2, 1)) == 34 and sequence_label((1, 3)) == 37


def test_views_are_named_with_the_mirrors_names_when_given():
    names = ["left", "right"]
    assert [source_name(s, names) for s in (0, 1, 2, 33, 36)] == [
        "direct", "left", "right", "left then right", "right then left then right"]
    # beyond them
    assert source_name(37, names) == "mirror 1 then 3" and source_name(250, names) == "source 250"


def test_labels_and_sequences_are_inverse_and_fit_a_uchar():
    # 255 is the dense grids' NO_SOURCE
    assert FIRST_MULTI_LABEL + len(MULTI_SEQUENCES) - 1 <= 254
    for i, sequence in enumerate(MULTI_SEQUENCES):
        assert sequence_label(sequence) == FIRST_MULTI_LABEL + i
        assert source_sequence(FIRST_MULTI_LABEL + i) == sequence
        assert all(a != b for a, b in pairwise(sequence))
    # every sequence of two mirrors among 1-7 and of three among 1-6, and nothing beyond
    assert sum(len(s) == 2 for s in MULTI_SEQUENCES) == 7 * 6
    assert sum(len(s) == 3 for s in MULTI_SEQUENCES) == 6 * 5 * 5


@pytest.mark.parametrize("sequence", [(1, 1), (1, 8), (1, 2, 1, 2), (7, 1, 2), (0, 1), (33,)])
def test_sequences_without_a_label(sequence):
    assert sequence_label(sequence) is None


def test_labels_that_name_no_view():
    assert source_name(250) == "source 250" and source_name(255) == "source 255"
    with pytest.raises(ValueError, match="names no view"):
        source_sequence(250)
    assert source_colour(255).tolist() == source_colour(250).tolist()


def test_multi_bounce_colours_are_shades_of_the_last_mirror_and_distinct():
    """Mirror 1 then 2 is bluish (mirror 2's sky blue, darker), 2 then 1 orange-ish; every label of
    a two-mirror rig has its own colour."""
    blue_ish, orange_ish = source_colour(33).astype(int), source_colour(34).astype(int)
    assert blue_ish[2] > blue_ish[0] and orange_ish[0] > orange_ish[2]
    # a shade: darker than mirror 2
    assert blue_ish.sum() < SOURCE_COLOURS[2].astype(int).sum()
    colours = source_colours(np.array([0, 1, 2, 33, 34, 35, 36])).astype(int)
    distance = np.linalg.norm(colours[:, None] - colours[None], axis=2) + 1000 * np.eye(7)
    assert distance.min() > 30


def test_orders_count_the_mirrors_of_each_label():
    assert source_orders(np.array([0, 1, 32, 33, 34, 35, 36, 37, 224, 225, 255])).tolist() == \
        [0, 1, 1, 2, 2, 3, 3, 2, 2, -1, -1]


def test_colours_follow_the_mirror_ids_when_given():
    """Ids (3, 1) in session order: label 1 takes mirror colour 3, label 2 colour 1; 'mirror 1 then
    2' is then a shade of colour 1 (the last mirror's id), just as 'mirror 2 then 1' is without
    ids."""
    np.testing.assert_array_equal(source_colours(np.array([0, 1, 2]), (3, 1)),
                                  SOURCE_COLOURS[[0, 3, 1]])
    assert source_colour(33, (2, 1)).tolist() == source_colour(34).tolist()
    assert source_colour(33, (1, 2)).tolist() == source_colour(33).tolist()
