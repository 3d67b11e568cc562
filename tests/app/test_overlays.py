"""The depth frame as the tabs see it (mirrorscan.overlays): the shared depth layer (grey by depth,
the object tinted, no reading dark) and a tab's overlay over it, checked pixel by pixel against the
plain definitions."""
import cv2
import numpy as np
from mirrorscan.overlays import (
    NO_READING,
    OBJECT_TINT,
    MarkerMark,
    MirrorMarks,
    Overlay,
    _overlap,
    depth_layer,
)


def test_the_depth_layer_is_grey_by_depth_with_the_object_tinted_and_no_reading_dark():
    rng = np.random.default_rng(0)
    depth = rng.uniform(1.0, 4.0, (48, 64)).astype(np.float32)
    depth[5:9, 10:30] = 0
    mask = np.zeros(depth.shape, bool)
    mask[20:40, 5:50] = True
    # the object's mask never outranks "no reading"
    mask[6, 12] = True
    rgb = depth_layer(depth, mask, 1.0, 4.0)
    grey = np.clip(np.rint(235 - (depth - 1.0) * 215 / 3.0), 0, 255)
    expected = np.repeat(grey[..., None], 3, axis=2)
    expected[mask] = np.rint(0.45 * grey[mask][:, None] + 0.55 * OBJECT_TINT)
    expected[depth <= 0] = NO_READING
    # rounding of the scale only
    assert np.abs(rgb.astype(int) - expected).max() <= 1
    # no reading outranks the mask; a warm tint on the object
    assert tuple(rgb[6, 12]) == NO_READING and rgb[30, 20, 0] > rgb[30, 20, 2]


def test_the_overlay_covers_the_depth_layer_exactly_where_it_is_drawn():
    overlay = Overlay((120, 160))
    base = np.random.default_rng(1).integers(0, 256, (120, 160, 3), dtype=np.uint8)
    # nothing drawn yet
    assert np.array_equal(overlay.over(base), base)
    overlay.draw([MirrorMarks((255, 0, 0), ((10, 10), (150, 10), (150, 110), (10, 110)), True,
                              (MarkerMark((40.0, 50.0), "1.1", "good"),))], None)
    out = overlay.over(base)
    drawn = overlay.image[..., 3] > 0
    assert 500 < drawn.sum() < 0.5 * drawn.size
    assert np.array_equal(out[drawn], overlay.image[..., :3][drawn])
    assert np.array_equal(out[~drawn], base[~drawn])
    # redrawn with nothing: the base again
    overlay.draw([], None)
    assert np.array_equal(overlay.over(base), base)
    assert cv2.countNonZero(overlay.image[..., 3]) == 0


def test_labels_cover_no_other_label_and_no_marker_where_there_is_room():
    """Two mirrors' markers at a hinge, a few pixels apart: every label finds a place that covers
    no other label and no marker."""
    left = tuple(MarkerMark((100.0 - 25 * (k % 2), 20.0 + 30 * k), f"1.{k + 1}", "good")
                 for k in range(6))
    right = tuple(MarkerMark((112.0 + 25 * (k % 2), 36.0 + 30 * k), f"2.{k + 1}", "fair")
                  for k in range(6))
    overlay = Overlay((200, 240))
    overlay.draw([MirrorMarks((255, 0, 0), (), True, left),
                  MirrorMarks((0, 0, 255), (), True, right)], None)
    markers, labels = overlay._labels[:12], overlay._labels[12:]
    assert len(labels) == 12
    for k, box in enumerate(labels):
        assert not any(_overlap(box, other) for other in markers + labels[:k] + labels[k + 1:]), k
