"""Floor 5, the simulated rig: scenes (scene, scenefile, layouts, presets, objects), ray casting
through the mirrors (render), the Kinect v1 sensor model (sensor), the simulator of frames
(simulator), sessions and truth written from a scene (export, placement) and the errors against the
truth (truth)."""
from mirrorcore.sim.export import true_rig, write_session
from mirrorcore.sim.layouts import arc_scene, kaleidoscope_scene, paper_scene
from mirrorcore.sim.render import GroundTruth, Renderer
from mirrorcore.sim.scene import Scene
from mirrorcore.sim.scenefile import load_scene, save_scene
from mirrorcore.sim.sensor import SensorModel
from mirrorcore.sim.simulator import SimFrame, Simulator
from mirrorcore.sim.truth import plane_errors, surface_error

__all__ = ["GroundTruth", "Renderer", "Scene", "SensorModel", "SimFrame", "Simulator",
           "arc_scene", "kaleidoscope_scene", "load_scene", "paper_scene", "plane_errors",
           "save_scene", "surface_error", "true_rig", "write_session"]
