"""Floor 6, the mirrors' planes: fits from markers, a region or pairs (fit, markers); the search
without markers and its rounds (search, scene); the refinement from the agreement of the views
(refine, with residuals, fixing, gaussnewton, planestep, glass and its results) and from a
sphere's centres (spheretarget)."""
from mirrorcore.calibration.agreement import frame_views
from mirrorcore.calibration.fit import (Calibration, calibrate_from_markers, calibrate_from_pairs,
                                        calibrate_from_region, calibrate_session)
from mirrorcore.calibration.glass import marker_offset
from mirrorcore.calibration.refine import REFINE_WITH, Leash, refine_planes, refine_session
from mirrorcore.calibration.residuals import ViewAgreement, view_agreement
from mirrorcore.calibration.results import MirrorRefinement, Refinement
from mirrorcore.calibration.scene import calibrate_scene
from mirrorcore.calibration.search import Found, search_plane
from mirrorcore.calibration.spheretarget import NotASphere, SpherePlanes, sphere_planes

__all__ = ["Calibration", "Found", "Leash", "MirrorRefinement", "NotASphere", "REFINE_WITH",
           "Refinement", "SpherePlanes", "ViewAgreement", "calibrate_from_markers",
           "calibrate_from_pairs", "calibrate_from_region", "calibrate_scene", "calibrate_session",
           "frame_views", "marker_offset", "refine_planes", "refine_session", "search_plane",
           "sphere_planes", "view_agreement"]
