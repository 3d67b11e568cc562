"""Floor 1, geometry of the camera frame: the pinhole camera (camera) and its files
(camerafiles), planes and reflection (plane), image polygons (polygon), RANSAC's stopping rule
(ransac), and the sphere and cylinder fits with their per-source errors (shapes, fitting, and
their shared LO-RANSAC and Gauss-Newton loops, loransac)."""
from mirrorcore.geometry.camera import (Intrinsics, project_points, reproject_depth,
                                        reproject_pixels)
from mirrorcore.geometry.fitting import estimate_normals, fit_cylinder, fit_sphere
from mirrorcore.geometry.plane import Plane, PlaneFit, fit_plane_ransac, fit_plane_svd
from mirrorcore.geometry.polygon import polygon_area, polygon_mask, validate_polygon
from mirrorcore.geometry.ransac import ransac_iterations
from mirrorcore.geometry.shapes import Cylinder, FitErrors, ShapeFit, Sphere

__all__ = ["Cylinder", "FitErrors", "Intrinsics", "Plane", "PlaneFit", "ShapeFit", "Sphere",
           "estimate_normals", "fit_cylinder", "fit_plane_ransac", "fit_plane_svd", "fit_sphere",
           "polygon_area", "polygon_mask", "project_points", "ransac_iterations",
           "reproject_depth", "reproject_pixels", "validate_polygon"]
