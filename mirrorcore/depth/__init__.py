"""Floor 2, depth images: 16-bit PNG files (files), the Kinect v1's disparity (kinect) and noise
(noise), per-pixel operations (ops), finding the object in a frame (selection) and smoothing over
neighbouring frames (temporal)."""
from mirrorcore.depth.files import read_depth_png, write_depth_png
from mirrorcore.depth.kinect import depth_to_disparity, disparity_to_depth
from mirrorcore.depth.noise import axial_sigma
from mirrorcore.depth.ops import median_depth, robust_mean_depth, smooth_depth
from mirrorcore.depth.selection import Selection, flying_pixels, object_mask, remove_specks
from mirrorcore.depth.temporal import frame_window, temporal_smooth

__all__ = ["Selection", "axial_sigma", "depth_to_disparity", "disparity_to_depth", "flying_pixels",
           "frame_window", "median_depth", "object_mask", "read_depth_png", "remove_specks",
           "robust_mean_depth", "smooth_depth", "temporal_smooth", "write_depth_png"]
