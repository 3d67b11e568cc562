"""The depth frame as the tabs see it (mirrorscan.overlays): the shared depth layer (grey by depth
in shaded relief, the object tinted, no reading dark) and a tab's overlay over it, checked pixel
by pixel against the plain definitions; a crease between two floors of the same grey shows, and
the outline's handles stand out on black and on white."""
import cv2
import numpy as np
from mirrorscan.overlays import (
    HANDLE_RADIUS,
    NO_READING,
    OBJECT_TINT,
    RELIEF_GAIN,
    MarkerMark,
    MirrorMarks,
    Overlay,
    _overlap,
    depth_layer,
    relief,
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
    grey = np.clip(np.rint(235 - (depth - 1.0) * 215 / 3.0 + RELIEF_GAIN * relief(depth)), 0, 255)
    expected = np.repeat(grey[..., None], 3, axis=2)
    expected[mask] = np.rint(0.45 * grey[mask][:, None] + 0.55 * OBJECT_TINT)
    expected[depth <= 0] = NO_READING
    # rounding of the scale only
    assert np.abs(rgb.astype(int) - expected).max() <= 1
    # no reading outranks the mask; a warm tint on the object
    assert tuple(rgb[6, 12]) == NO_READING and rgb[30, 20, 0] > rgb[30, 20, 2]


def floors(tilt: float) -> np.ndarray:
    """(480, 640) metres: two floors meeting along row 240 at 2 m, one rising, one falling with
    the row by `tilt` metres a row; rows the same distance from 240 have the same depth."""
    rows = np.arange(480, dtype=np.float32)[:, None] - 240
    return np.repeat(2.0 + tilt * np.abs(rows), 640, axis=1).astype(np.float32)


def test_the_relief_of_a_surface_square_to_the_camera_is_nothing_and_holes_leave_no_rim():
    depth = np.full((120, 160), 2.5, np.float32)
    depth[40:60, 50:90] = 0
    shade = relief(depth)
    # under half a grey level
    assert np.abs(shade).max() * RELIEF_GAIN < 0.5


def test_a_crease_between_two_floors_of_the_same_grey_shows():
    """A mirror's foot: the floor and its reflection meet with the same depth on either side of
    the crease; without relief the two sides are the same grey row for row."""
    depth = floors(0.004)
    mask = np.zeros(depth.shape, bool)
    rgb = depth_layer(depth, mask, 1.5, 3.5).astype(int)[..., 0]
    above, below = rgb[200:235, 100:540], rgb[246:281, 100:540][::-1]
    # the grey of depth alone is equal, row for row mirrored about the crease
    flat = 235 - (depth - 1.5) * 215 / 2.0
    assert np.allclose(flat[200:235], flat[246:281][::-1])
    assert abs(above.mean() - below.mean()) > 30


def test_a_step_in_depth_shows_as_a_rim_where_the_grey_would_not():
    """Two walls at 3.00 and 3.05 m on a scale of 0.5 to 10 m: one grey level apart, a rim between
    them."""
    depth = np.full((120, 160), 3.0, np.float32)
    depth[:, 80:] = 3.05
    rgb = depth_layer(depth, np.zeros(depth.shape, bool), 0.5, 10.0).astype(int)[..., 0]
    assert abs(rgb[60, 20] - rgb[60, 140]) <= 2
    assert np.abs(rgb[60, 70:90] - rgb[60, 20]).max() > 15


def test_outline_handles_stand_out_on_black_and_on_white():
    overlay = Overlay((120, 160))
    corners = ((30.0, 30.0), (130.0, 30.0), (130.0, 90.0), (30.0, 90.0))
    overlay.draw([MirrorMarks((40, 90, 220), corners, True)], None)
    for background in (0, 255):
        out = overlay.over(np.full((120, 160, 3), background, np.uint8)).astype(int)
        handle = out[30 - HANDLE_RADIUS - 3:30 + HANDLE_RADIUS + 4,
                     30 - HANDLE_RADIUS - 3:30 + HANDLE_RADIUS + 4]
        # a ring of the opposite lightness around each handle, whatever the background
        contrast = np.abs(handle - background).max(axis=2)
        assert (contrast > 200).sum() >= 12, background


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
