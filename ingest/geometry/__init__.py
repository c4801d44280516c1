"""Geometry of the image: the camera, points to angles, the sling's circle."""
