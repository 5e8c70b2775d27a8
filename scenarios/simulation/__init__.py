"""The simulated world around the robot: the pymunk room, the humans in it and the sensors
that report them to the pipeline."""
