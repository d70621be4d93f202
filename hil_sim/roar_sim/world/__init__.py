"""The world robots drive in: PyBullet (quietly imported), the scene (ground, walls, painted floor),
tracks and their files, boxes, start lights, and headless plots of tracks and paths."""
