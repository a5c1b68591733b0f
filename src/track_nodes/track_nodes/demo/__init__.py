"""The foundation demo: a Kalman tracker of a constant-velocity target."""
