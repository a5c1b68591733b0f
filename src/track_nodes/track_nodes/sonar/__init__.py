"""Smart-target sonar: the observer AUV with the SS-PF and covariance-control scheduling."""
