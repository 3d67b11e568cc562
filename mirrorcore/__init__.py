"""mirrorcore: 3D scanning with one depth camera and flat mirrors. Each mirror acts as another
depth camera; the library turns depth frames into a merged, source-labelled 3D cloud (Nguyen,
Huynh & Meunier 2018), calibrates the mirrors' planes and reconstructs dense surfaces.

Its subpackages stand in floors; each imports only from its own floor and those below
(docs/DESIGN.md, "Layout of the code"):

0. base: errors, atomic files, the memory budget, progress, colours
1. geometry: the pinhole camera, planes and reflection, polygons, sphere and cylinder fits
2. depth: depth images, the Kinect v1's disparity and noise, finding the object in a frame
3. io: the session folder (session.json), PLY files, the guard on outputs
4. rig: the rig model, ray paths through several mirrors, Algorithm 1, the merged cloud
5. sim: the simulated rig, its renderer and sensor model, sessions and truth written from a scene
6. calibration: mirror planes from markers, a region, pairs, a search and the refinement
7. dense: space carving and volumetric fusion with the mirrors' views as virtual cameras
8. sources: depth sources (files, recordings, devices, the simulator) behind one interface
9. batch: one PLY file per frame of a recording, on local cores or a Dask cluster

    from mirrorcore.io import load_session
    from mirrorcore.rig import Rig, object_cloud
"""
from mirrorcore.base.errors import CalibrationError, FileFormatError, MirrorscanError

__all__ = ["MirrorscanError", "CalibrationError", "FileFormatError"]
