"""The project's own fuzzer: malformed messages for every topic a node subscribes to.

- ``generate``: seeded bad messages of named classes, made from a valid template of each type;
- ``table``: the node configurations to fuzz (scenario, nodes, target, topics that must stay alive);
- ``harness``: one case in-process (warm-up, attack, recovery) and its ``FuzzResult``;
- ``experiment``: ``track-experiment fuzz --set node=NAME --set messages=N`` (``node=all`` runs all).

Not a node module: nothing here is an executable, and node classes are looked up in the registry.
"""
