"""What the car sees, from its camera frames (live or recorded): the camera's geometry and a
bird's-eye view of the road (geometry), lane lines in metres in the car's frame (lanes). Needs
OpenCV: pip install 'roar-platform[vision]'."""
