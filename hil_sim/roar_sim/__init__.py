"""Software-in-the-loop: the firmware's own logic, built for the host, driving simulated cars."""
