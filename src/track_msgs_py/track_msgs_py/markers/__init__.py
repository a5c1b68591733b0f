"""MarkerArray builders for RViz/Foxglove, one module per system."""
