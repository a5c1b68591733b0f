"""Bring your own sonar: a driver that feeds ``sonar_observer`` what a real sonar and navigation system give.

It stands in for your hardware: a ship sailing north-east at 5 m/s publishes its navigation at 10 Hz
(``sonar/observer/odom``, nav_msgs/Odometry the REP-105 way: heading in the pose, forward speed in the
body frame ``base_link``), and its sonar publishes a contact (``sonar/contacts``, track_msgs/SonarContact)
at irregular times, nothing at all between 14 s and 24 s, and a range whenever the observer's latest
request (``sonar/mode_command``) says ``ACTIVE``. Bearings are REP-103: counter-clockwise from the x
axis of the contact's frame, here ``map`` (a true bearing: east is 0, north is π/2).

    .venv/lib/track_nodes/sonar_observer --ros-args -p prior_mean:="[400.0, -3.0, 300.0, 2.0]" &
    .venv/bin/python3 docs/examples/sonar_driver.py

Replace the two ``_publish_*`` methods by your driver's callbacks; the messages stay the same.
"""

from __future__ import annotations

import math

import numpy as np
import rclpy
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from track_msgs.msg import SonarContact, SonarModeCommand

NAV_PERIOD = 0.1  # s
GAP = (14.0, 24.0)  # s after the start: the sonar hears nothing
BEARING_STD = math.radians(1.0)
RANGE_STD = 5.0


class SonarDriverExample(Node):
    """A simulated ship, its navigation and its sonar, publishing on the observer's input topics."""

    def __init__(self, duration: float = 40.0, seed: int = 7, **kw) -> None:
        super().__init__('sonar_driver_example', **kw)
        self.rng = np.random.default_rng(seed)
        gaps = self.rng.uniform(0.4, 1.6, size=80)  # irregular listens, about one a second
        times = np.cumsum(gaps)
        self.contact_times = [t for t in times if t <= duration and not GAP[0] < t < GAP[1]]
        self.duration = duration
        self.active = True  # the observer asks for a ping first
        self.t0: int | None = None  # node time of the start [ns]
        self.sent: list[int] = []  # stamps of the contacts published [ns]
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.pub_nav = self.create_publisher(Odometry, 'sonar/observer/odom', reliable)
        self.pub_contact = self.create_publisher(SonarContact, 'sonar/contacts', reliable)
        self.create_subscription(SonarModeCommand, 'sonar/mode_command', self._on_request, latched)
        self.create_timer(NAV_PERIOD / 2, self._tick)
        self._next_nav = 0.0

    # -- the world this example invents -----------------------------------------------------------
    @staticmethod
    def ship(t: float) -> tuple[np.ndarray, np.ndarray]:
        """Own ship at t [s]: position and velocity (north-east at 5 m/s from the origin)."""
        v = 5.0 * np.array([math.cos(math.pi / 4), math.sin(math.pi / 4)])
        return v * t, v

    @staticmethod
    def target(t: float) -> np.ndarray:
        """The contact's true position at t [s] (what your sonar hears; the observer never sees it)."""
        return np.array([400.0 - 3.0 * t, 300.0 + 2.0 * t])

    # -- the driver -----------------------------------------------------------------------------
    def _on_request(self, msg: SonarModeCommand) -> None:
        self.active = msg.mode == SonarModeCommand.ACTIVE

    def _tick(self) -> None:
        now = self.get_clock().now().nanoseconds
        if now == 0:
            return  # sim time: no /clock yet
        if self.t0 is None:
            self.t0 = now
        t = (now - self.t0) * 1e-9
        while self._next_nav <= min(t, self.duration):
            self._publish_navigation(self._next_nav)
            self._next_nav += NAV_PERIOD
        while self.contact_times and self.contact_times[0] <= t:
            self._publish_contact(self.contact_times.pop(0))

    def _stamp(self, t: float):
        return rclpy.time.Time(nanoseconds=self.t0 + round(t * 1e9)).to_msg()

    def _publish_navigation(self, t: float) -> None:
        xy, v = self.ship(t)
        msg = Odometry()
        msg.header.stamp, msg.header.frame_id, msg.child_frame_id = self._stamp(t), 'map', 'base_link'
        msg.pose.pose.position.x, msg.pose.pose.position.y = float(xy[0]), float(xy[1])
        heading = math.atan2(v[1], v[0])  # REP-103 yaw
        msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(heading / 2), math.cos(heading / 2)
        msg.twist.twist.linear.x = float(np.hypot(*v))  # forward, in base_link
        self.pub_nav.publish(msg)

    def _publish_contact(self, t: float) -> None:
        d = self.target(t) - self.ship(t)[0]
        msg = SonarContact()
        msg.header.stamp, msg.header.frame_id = self._stamp(t), 'map'
        msg.bearing = math.atan2(d[1], d[0]) + self.rng.normal(0.0, BEARING_STD)
        msg.bearing_std = BEARING_STD
        msg.mode = SonarContact.ACTIVE if self.active else SonarContact.PASSIVE
        msg.range = float(np.hypot(*d) + self.rng.normal(0.0, RANGE_STD)) if self.active else math.nan
        msg.range_std = RANGE_STD if self.active else math.nan
        self.pub_contact.publish(msg)
        self.sent.append(msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec)


def main() -> None:
    rclpy.init()
    node = SonarDriverExample()
    try:
        while rclpy.ok() and (node.contact_times or node.t0 is None):
            rclpy.spin_once(node, timeout_sec=0.1)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
