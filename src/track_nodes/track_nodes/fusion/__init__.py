"""Track-to-track association by geofeasibility scores, and covariance-intersection fusion."""
