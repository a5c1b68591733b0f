"""``track-bench recorder``: the recorder against ``ros2 bag record``."""
