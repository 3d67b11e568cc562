"""The Kinect v1's disparity counts to metres and back (Burrus' calibration)."""
import numpy as np

from mirrorcore.depth.kinect import DISPARITY_INVALID, depth_to_disparity, disparity_to_depth


def test_burrus_disparity_round_trip_within_quantisation():
    z = np.linspace(0.5, 4.5, 10001)
    counts = depth_to_disparity(z)
    assert counts.dtype == np.uint16 and counts.max() < 2047
    back = disparity_to_depth(counts)
    # rounding moves 1/z by at most half a disparity step |A| / 2, so |back - z| <= |A| / 2 * z *
    # back
    assert np.all(np.abs(back - z) <= 0.5 * 0.0030711016 * z * back * 1.0001 + 1e-6)
    np.testing.assert_array_equal(depth_to_disparity(disparity_to_depth(counts)), counts)
    assert depth_to_disparity(np.array([0.0, 0.1,
                                        np.nan]).tolist()).tolist() == [DISPARITY_INVALID] * 3
    assert disparity_to_depth(np.array([DISPARITY_INVALID, 1200])).tolist() == [0.0, 0.0]
