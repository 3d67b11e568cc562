"""Geometry of the camera frame: the pinhole camera (camera), planes and reflection (plane), image
polygons (polygon), and RANSAC's stopping rule (ransac)."""
