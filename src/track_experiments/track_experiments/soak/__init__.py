"""``track-experiment soak``: the package set operated the way users operate it, at once, then stopped.

Three parts by default, run one after the other, each ended by SIGTERM (what ``timeout``, systemd, docker stop
and CI cancellation send), each reporting what survived, what was lost and how long it took:

- ``concurrent``: three launcher runs (``demo``, ``sonar``, ``slam_sim``) with ``--record`` started
  together on one machine and one ``ROS_DOMAIN_ID``; each bag must hold only its own scenario's
  topics (no mixing), be readable by two independent readers, and report no lost message.
- ``loop``: a recorded demo bag played with ``track-play --loop`` into a ``demo_tracker`` process on
  sim time; every loop (each restart sends /clock back) must still turn the reports into tracks.
- ``bringup``: an IDSQ field of ``sensors`` nodes (100; ``--quick``: 24) in one launcher process comes
  up (time to the first /clock), runs, and stops with its bag closed.

``--set parts=long`` (not in the default: an hour of data or more) runs the maritime scenario for
``data`` seconds of data in one process and with ``--processes`` and reports each process's RSS
slope per data hour and the outputs' pace in the last quarter against the first (``long``).

``--set busy=N`` runs N CPU-bound processes beside the whole soak (a loaded laptop).
"""
