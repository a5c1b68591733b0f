"""The launcher's tuning constants, each once: wall-time waits and deadlines, watch periods, domain ids.

None of them changes what a run computes (lock-step time fixes that); they decide how long a run
waits for a busy machine before it goes on or gives up. Deadlines are generous on purpose: this
package set runs on 2 cores next to other work. ``[wall s]`` is wall time; node time never appears here.
"""

from __future__ import annotations

# --- the /clock's steps and the waits around them (pacing, clock, launcher) ----------------------------
CLOCK_TICK = 0.01  # [wall s] per /clock step at the nominal rate ...
MAX_CLOCK_STEP = 0.05  # ... but never more than this many node seconds per step (bounded bursts)
SETTLE = 1.0  # [wall s] for discovery to settle before the clock starts ...
SETTLE_PROCESSES = 3.0  # ... with one process per node (seen: a reader matched after 1 s lost step 0)
GRACE = 1.0  # [wall s] for messages in flight after the clock stops
QUIET = 2.0  # [wall s] other processes: the graph is drained once no watched topic delivered for this long ...
DRAIN_MAX = 120.0  # ... waiting at most this long after the clock stopped [wall s]
HOLD_MAX = 5.0  # [wall s] the longest the clock waits for one topic; then that topic no longer holds it
LAG_PERIODS = 3  # the clock waits for a periodic topic whose latest stamp L is this many periods old (Cadence)
SAME_GAP_NS = 1_000  # [ns] two stamp gaps within this are the same period
WATCH_EVERY = 50  # clock steps between looks for new topics to watch and for a second /clock publisher

# --- the ready deadline (a deadline, not a wait): READY_TIMEOUT plus, per node, ... (graph) -------------
READY_TIMEOUT = 60.0  # [wall s]
READY_PER_NODE = 1.0  # ... in one process (built already: discovery and matching of its endpoints) ...
READY_PER_PROCESS = 4.0  # ... or per process (each imports numpy, scipy and rclpy: seconds of CPU on 2 cores)

# --- the lock-step watchdog (lockstep) -------------------------------------------------------------------
IDLE_POLL = 0.001  # [wall s] without a ready callback that count as idle
STALL_MIN = 60.0  # [wall s] the watchdog's deadline is at least this ...
STALL_PER_NODE = 2.0  # ... and this much per node (one step can run every node's callbacks) ...
STALL_STEPS = 50.0  # ... and this many times the slowest of the recent steps
STOP_GRACE = 60.0  # [wall s] after a stall, the run must have stopped within this, or the process exits

# --- stopping child processes (processes) ----------------------------------------------------------------
STOP_WAIT = 10.0  # [wall s] after the SIGINT, a child that does not work towards its exit is killed ...
STOP_IDLE = 3.0  # ... "does not work": its main thread took no CPU time for this long (Linux /proc)
STOP_MAX = 60.0  # [wall s] a child still running this long after the SIGINT is killed, working or not

# --- isolation and simulated hosts (isolation, hosts) -----------------------------------------------------
FOREIGN_EVERY = 1.0  # [wall s] between looks for publishers that are not the run's
DOMAIN_FIRST = 101  # the launcher's own domain ids start above the tests' 1..100 (test/conftest.py) ...
MAX_DOMAIN_ID = 232  # ... and Fast DDS's default port mapping (7400 + 250 d + ...) leaves the UDP range above this
LINK_UP_MAX = 10.0  # [wall s] at most this long for every veth of a new run to report its carrier
