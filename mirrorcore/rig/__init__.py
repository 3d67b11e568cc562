"""Floor 4, the rig of one camera and its mirrors: the model (Rig, Mirror), the paths of rays
through several mirrors (raypaths), the paper's Algorithm 1 (reconstruct), a frame prepared and
reconstructed (pipeline), the merged, source-labelled cloud (cloud) and its colours with the
mirrors' colour gains undone (colour)."""
from mirrorcore.rig.cloud import Cloud
from mirrorcore.rig.colour import (check_colour_image, correction_table, point_colours,
                                    rgb_words, view_gain)
from mirrorcore.rig.model import Mirror, Rig, calibrated_rig
from mirrorcore.rig.pipeline import object_cloud, object_masks, prepare_frame
from mirrorcore.rig.raypaths import VirtualCamera, trace_chains
from mirrorcore.rig.reconstruct import reconstruct_raw

__all__ = ["Cloud", "Mirror", "Rig", "VirtualCamera", "calibrated_rig", "check_colour_image",
           "correction_table", "object_cloud", "object_masks", "point_colours", "prepare_frame",
           "reconstruct_raw", "rgb_words", "trace_chains", "view_gain"]
