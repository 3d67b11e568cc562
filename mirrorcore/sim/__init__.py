"""Simulated rig: scenes, ray casting, the Kinect v1 sensor model and a depth source."""
