"""The identification engine: the objective over every configuration, mode pairing and peak
matching, the damped Gauss-Newton update loop and why it stops, parameters and ties,
statistics and uncertainty, and the result."""
