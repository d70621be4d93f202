"""Simulated time: the lockstep every robot shares (the firmware loop and physics periods) and a
fixed-priority scheduler with FreeRTOS's rules for the IARRC car's tasks."""
