"""``python -m track_nodes.launch SCENARIO [...]``: see ``track_nodes.launch.launcher``."""

from track_nodes.launch.launcher import main

raise SystemExit(main())
