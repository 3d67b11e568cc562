"""The browser's PLY of a cloud (mirrorscan.exports.cloud_ply): red, green, blue the scene's
colours when the cloud has them, the labels in source; the source colours without."""
import numpy as np

from mirrorcore.base.palette import source_colours
from mirrorcore.io.ply import encode_ply
from mirrorcore.rig.cloud import Cloud
from mirrorscan.exports import cloud_ply

RNG = np.random.default_rng(5)
POINTS = RNG.normal(size=(30, 3)).astype(np.float32)
SOURCES = np.repeat([0, 1, 2], 10).astype(np.uint8)
PIXELS = np.arange(30, dtype=np.int64)


def test_a_cloud_with_colour_is_exported_in_its_colours_and_keeps_its_labels():
    rgba = RNG.integers(0, 256, (30, 4), dtype=np.uint8)
    cloud = Cloud(POINTS, SOURCES, PIXELS, 640, rgba[:, :3])
    assert cloud_ply(cloud) == encode_ply(POINTS, SOURCES, colours=rgba[:, :3].copy())
    assert cloud_ply(cloud) != encode_ply(POINTS, SOURCES)


def test_a_cloud_without_colour_is_exported_in_the_source_colours():
    plain = cloud_ply(Cloud(POINTS, SOURCES, PIXELS, 640))
    assert plain == encode_ply(POINTS, SOURCES, colours=source_colours(SOURCES))
