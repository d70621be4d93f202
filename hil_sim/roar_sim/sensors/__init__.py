"""What the robots sense: lidar rays, the TFmini, the HC-SR04's cone, cameras and their noise."""
