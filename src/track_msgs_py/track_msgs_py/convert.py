"""Conversions between numpy (float seconds, arrays) and standard ROS 2 messages.

Nodes call these in callbacks (``from_msg → core step → to_msg``), so no Node is needed and
nothing here validates incoming data: ``*_to_*`` readers only extract numbers (even NaNs);
``track_msgs_py.validate`` says whether a message is usable.

The one mapping table (row-major 6×6 covariances: index ``6*i + j``, order x, y, z, rot x,
rot y, rot z; the x/y block is entries 0, 1, 6, 7):

=========================  ==========================================  ===============================================
data                       message type                                fields
=========================  ==========================================  ===============================================
time ``t`` [s], t ≥ 0      builtin_interfaces/Time                     ``sec``, ``nanosec`` (rounded to 1 ns)
CV state ``x=[x,ẋ,y,ẏ]``,  nav_msgs/Odometry                           ``header.stamp``, ``header.frame_id`` (``map``),
``P`` (4×4)                                                            ``child_frame_id`` (track id);
                                                                       ``pose.pose.position.x/y`` ← x, y (z = 0);
                                                                       ``pose.pose.orientation`` = identity;
                                                                       ``twist.twist.linear.x/y`` ← ẋ, ẏ (angular 0);
                                                                       ``pose.covariance`` x/y block ← P[[0,2],[0,2]];
                                                                       ``twist.covariance`` x/y block ← P[[1,3],[1,3]];
                                                                       z/roll/pitch entries ``PLANAR_VARIANCE`` (0),
                                                                       yaw and yaw rate ``NOT_ESTIMATED_VARIANCE``
position report ``z`` (2,)  geometry_msgs/PoseWithCovarianceStamped     ``pose.pose.position.x/y`` ← z (z = 0),
and ``R`` (2×2)                                                        orientation identity, ``pose.covariance`` x/y
                                                                       block ← R, z/roll/pitch 0, yaw not estimated
table of named columns     sensor_msgs/PointCloud2                     one ``FLOAT32`` PointField per column (dict
(each (n,))                                                            order, offset 4·i, count 1), height 1, width n,
                                                                       little-endian, ``point_step`` 4·k, ``is_dense``
                                                                       = all values finite; ``data`` = packed rows
points with named columns  sensor_msgs/PointCloud2                     ``points_to_pointcloud2``: the same with
(xy (n, 2|3) + columns)                                                float32 ``x``, ``y``, ``z`` first (offsets 0, 4,
                                                                       8; z = 0 when not given), the columns after
2σ ellipse of (μ, R)       visualization_msgs/Marker (LINE_STRIP)      ``points`` (closed loop), ``scale.x`` = width,
                                                                       ``color``, ``pose`` identity, ``lifetime``
health / named values      diagnostic_msgs/DiagnosticStatus            ``level``, ``name``, ``message``,
                                                                       ``hardware_id``, ``values`` (KeyValue, str)
IDSQ sensor layout         sensor_msgs/PointCloud2 (``/idsq/layout``)  ``FLOAT32`` ``x``, ``y``, ``z`` (0) at 0, 4,
(``SensorLayout``)                                                     8, 4 bytes padding, ``FLOAT64`` ``id``,
                                                                       ``x_f64``, ``y_f64``, ``type`` (0 acoustic, 1
                                                                       DOA) at 16, 24, 32, 40; ``point_step`` 48; one
                                                                       point per sensor (float64: positions exact)
IDSQ handoff bytes         std_msgs/UInt8MultiArray                    ``data`` = the bytes; one ``layout.dim``:
(``encode_handoff``)                                                   label ``idsq_handoff_v1``, size = stride = n
=========================  ==========================================  ===============================================

Deliberate deviations and losses:

- Odometry twist is expressed in ``child_frame_id`` (REP-105). Our tracks carry no heading, so
  the child frame is defined axis-aligned with ``map`` (orientation identity) and the twist is
  the map-frame velocity: ``twist.twist.linear.x`` is the east velocity, not a forward speed.
- Odometry has no slot for position–velocity cross-covariances: they are dropped on the way
  out, and ``odometry_to_cv_state`` returns ``P`` with zero cross blocks.
- Covariances of a planar track. The 6×6 entries fall in three classes, zero
  off-diagonals outside the estimated block:

  * estimated: the x/y block (and yaw for the SLAM pose): the filter's numbers. Fusion and every
    other consumer read the x/y block only (``xy_block``); it is the 2σ ellipse;
  * planar, ``PLANAR_VARIANCE`` = 0: z, roll, pitch of the pose and vertical, roll and pitch
    rates of the twist. The world is the map plane (REP-103), so these are fixed at 0, not
    unknown. 0 is the 2-D convention of RViz 2 (``CovarianceVisual`` switches to a flat x/y
    ellipse plus a yaw cone exactly when entries 14, 21 and 28 are ≤ 0), of Foxglove (its
    covariance sphere is scaled by √ of the x, y, z diagonal, so z = 0 draws a flat disc) and of
    nav2 AMCL's ``amcl_pose`` (only x, y, yaw filled). robot_localization's ``two_d_mode``
    overwrites these entries anyway (z/roll/pitch measured 0 with variance 1e-6). The former
    1e6 here made both viewers draw every ellipse as a column 1 km (Foxglove) or 2 km (RViz) tall;
  * not estimated, ``NOT_ESTIMATED_VARIANCE`` = 1e6: a quantity of the model that this estimator
    does not estimate: yaw and yaw rate of a CV track, the IDSQ estimate's velocity (x/y twist
    block), the SLAM pose's whole twist (the diff_drive_controller "do not trust" convention).
    A reader recognises it with ``not_estimated(variance)`` (variance ≥ 1e6): fusion holds such a
    track's position instead of predicting it with that velocity. RViz bounds the yaw cone it
    draws, Foxglove ignores orientation, so this value draws nothing huge.

  Every entry stays within the input policy's [0, 1e14] (``validate.InputPolicy``: the x/y
  block of an estimate in [1e-12, 1e14]; zero x/y blocks only on truth topics, which no node
  validates for variance). Validation checks only the x/y blocks. ``UNUSED_VARIANCE`` is the
  former name of ``NOT_ESTIMATED_VARIANCE``.
- PointCloud2 columns are float32: values lose precision beyond ~7 significant digits.
- Every cloud we publish carries float32 ``x``, ``y``, ``z`` first, at offsets 0, 4, 8 (RViz
  needs them to draw a cloud, Foxglove refuses one with fewer than two of them). A table
  without positions of its own gets them from its record (``records.slam.SlamScan``: the
  detection in the laser frame; ``records.rfid.RfidPhase``: where the reader was;
  ``records.idsq.IdsqBelief``: the cell centre). ``cloud_columns`` drops them again for a reader
  of the table's own columns.
- The IDSQ layout carries its positions twice: float32 ``x``, ``y`` for the viewers and float64
  ``x_f64``, ``y_f64`` that every sensor node reads: it checks its ``position`` parameter against
  them and builds its neighbour lists from them, so all must read the same exact positions. A
  layout without ``x_f64``/``y_f64`` (the older layout: float64 ``id``, ``x``, ``y``,
  ``type``) still reads.
  ``pointcloud2_to_layout`` imports ``track_core.idsq`` only when called (it loads scipy.stats,
  about 1 s, which the other users of this module need not pay).
"""

from __future__ import annotations

import array
import math
from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import TYPE_CHECKING

import numpy as np
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, Pose, PoseArray, PoseWithCovarianceStamped, TwistStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import ColorRGBA, Header, MultiArrayDimension, UInt8MultiArray
from visualization_msgs.msg import Marker

from track_core.filters.gaussian import covariance_problem
from track_core.filters.gaussian import ellipse_points as gaussian_ellipse_points
from track_msgs_py.topics import FRAME_BASE, FRAME_LASER, FRAME_MAP

if TYPE_CHECKING:
    from track_core.idsq.network import SensorLayout

#: Variance of what the planar model fixes (z, roll, pitch; vertical, roll and pitch rates): exactly 0.
PLANAR_VARIANCE = 0.0
#: Variance written for a quantity this estimator does not estimate (yaw of a CV track, the IDSQ velocity).
NOT_ESTIMATED_VARIANCE = 1e6
#: Former name of ``NOT_ESTIMATED_VARIANCE`` (earlier versions wrote it on z/roll/pitch too).
UNUSED_VARIANCE = NOT_ESTIMATED_VARIANCE

_NS_PER_S = 1_000_000_000
_INT32_MAX = 2**31 - 1
_POS = [0, 2]  # indices of x, y in the CV state [x, ẋ, y, ẏ]
_VEL = [1, 3]  # indices of ẋ, ẏ


# --- time -----------------------------------------------------------------------------------

def sec_to_stamp(t: float) -> Time:
    """Float seconds → ``builtin_interfaces/Time``, rounded to the nearest nanosecond.

    Rounds the float's exact value (``Fraction``), so it is exact for integer nanoseconds:
    ``sec_to_stamp(stamp_to_sec(s)) == s`` for every stamp below 2²² s (≈ 48 days, where a float
    still resolves 1 ns), and ``stamp_to_sec(sec_to_stamp(t)) == t`` for every ``t`` that is the
    float nearest to a whole number of nanoseconds there (1.5, 0.1, 12.375), and for every float
    from 2²³ s on (wall-clock epoch times). Finer fractions are rounded to 1 ns. Negative,
    non-finite or beyond-int32 seconds raise ``ValueError``.
    """
    t = float(t)
    if not math.isfinite(t) or t < 0.0:
        raise ValueError(f'stamp must be finite and >= 0 s, got {t!r}')
    sec, nanosec = divmod(round(Fraction(t) * _NS_PER_S), _NS_PER_S)
    if sec > _INT32_MAX:
        raise ValueError(f'stamp {t!r} s does not fit builtin_interfaces/Time.sec (int32)')
    return Time(sec=int(sec), nanosec=int(nanosec))


def stamp_to_ns(stamp) -> int:
    """``Time``/``Duration`` (anything with ``sec`` and ``nanosec``) → integer nanoseconds (bag time)."""
    return int(stamp.sec) * _NS_PER_S + int(stamp.nanosec)


def ns_to_stamp(ns: int) -> Time:
    """Integer nanoseconds → an exact ``builtin_interfaces/Time`` (no float on the way)."""
    sec, nanosec = divmod(int(ns), _NS_PER_S)
    if not 0 <= sec <= _INT32_MAX:
        raise ValueError(f'stamp {ns} ns does not fit builtin_interfaces/Time')
    return Time(sec=sec, nanosec=nanosec)


def stamp_to_sec(stamp) -> float:
    """``Time``/``Duration`` → float seconds, correctly rounded (integer true division)."""
    return stamp_to_ns(stamp) / _NS_PER_S


def _header(t: float, frame_id: str) -> Header:
    return Header(stamp=sec_to_stamp(t), frame_id=frame_id)


# --- covariance blocks ----------------------------------------------------------------------

_PLANAR_IDX = (2, 3, 4)  # z, roll, pitch (pose) or vz, ωx, ωy (twist) of a 6×6 covariance
_YAW = 5


def _planar_cov(C: np.ndarray, yaw_variance: float = NOT_ESTIMATED_VARIANCE) -> np.ndarray:
    """2×2 x/y block → 36 row-major entries: z/roll/pitch ``PLANAR_VARIANCE``, yaw ``yaw_variance``."""
    full = _PLANAR_TEMPLATE.copy()
    full[_YAW, _YAW] = yaw_variance
    full[:2, :2] = C
    return full.reshape(36)


_PLANAR_TEMPLATE = np.zeros((6, 6))
_PLANAR_TEMPLATE[_PLANAR_IDX, _PLANAR_IDX] = PLANAR_VARIANCE


def not_estimated(variance) -> np.ndarray:
    """True where a variance (scalar or array) carries the "not estimated" convention (≥ ``NOT_ESTIMATED_VARIANCE``)."""
    return np.asarray(variance, dtype=float) >= NOT_ESTIMATED_VARIANCE


def xy_block(covariance) -> np.ndarray:
    """The x/y 2×2 block of a 36-entry row-major covariance (a copy, float64)."""
    return np.asarray(covariance, dtype=float).reshape(6, 6)[:2, :2].copy()


def _as_shape(a, shape: tuple[int, ...], name: str) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.shape != shape:
        raise ValueError(f'{name} must have shape {shape}, got {a.shape}')
    return a


# --- CV state ⇄ Odometry --------------------------------------------------------------------

def cv_state_to_odometry(t: float, x: np.ndarray, P: np.ndarray, frame_id: str = FRAME_MAP,
                         child_frame_id: str = '') -> Odometry:
    """CV state ``x=[x, ẋ, y, ẏ]`` with covariance ``P`` (4×4) at ``t`` → ``nav_msgs/Odometry``.

    See the module table; position–velocity cross-covariances are dropped.
    """
    x = _as_shape(x, (4,), 'x')
    P = _as_shape(P, (4, 4), 'P')
    msg = Odometry(header=_header(t, frame_id), child_frame_id=child_frame_id)
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(x[0]), float(x[2])
    msg.pose.pose.orientation.w = 1.0
    msg.twist.twist.linear.x, msg.twist.twist.linear.y = float(x[1]), float(x[3])
    msg.pose.covariance = _planar_cov(P[0::2, 0::2])   # rows/columns _POS = [0, 2] (a slice: no fancy index)
    msg.twist.covariance = _planar_cov(P[1::2, 1::2])  # _VEL = [1, 3]
    return msg


def odometry_to_cv_state(msg: Odometry) -> tuple[float, np.ndarray, np.ndarray]:
    """``nav_msgs/Odometry`` → ``(t, x=[x, ẋ, y, ẏ], P)``; P's position–velocity blocks are zero."""
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    x = np.array([p.x, v.x, p.y, v.y], dtype=float)
    P = np.zeros((4, 4))
    P[np.ix_(_POS, _POS)] = xy_block(msg.pose.covariance)
    P[np.ix_(_VEL, _VEL)] = xy_block(msg.twist.covariance)
    return stamp_to_sec(msg.header.stamp), x, P


# --- position report ⇄ PoseWithCovarianceStamped --------------------------------------------

def position_to_pose_cov(t: float, z: np.ndarray, R: np.ndarray,
                         frame_id: str = FRAME_MAP) -> PoseWithCovarianceStamped:
    """Position ``z`` (2,) with covariance ``R`` (2×2) → ``geometry_msgs/PoseWithCovarianceStamped``."""
    z = _as_shape(z, (2,), 'z')
    R = _as_shape(R, (2, 2), 'R')
    msg = PoseWithCovarianceStamped(header=_header(t, frame_id))
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(z[0]), float(z[1])
    msg.pose.pose.orientation.w = 1.0
    msg.pose.covariance = _planar_cov(R)
    return msg


def pose_cov_to_position(msg: PoseWithCovarianceStamped) -> tuple[float, np.ndarray, np.ndarray]:
    """``geometry_msgs/PoseWithCovarianceStamped`` → ``(t, z (2,), R (2×2))``."""
    p = msg.pose.pose.position
    return stamp_to_sec(msg.header.stamp), np.array([p.x, p.y], dtype=float), xy_block(msg.pose.covariance)


# --- table ⇄ PointCloud2 --------------------------------------------------------------------

_FLOAT32 = np.dtype('<f4')
_POINTFIELD_DTYPES = {
    PointField.INT8: 'i1', PointField.UINT8: 'u1', PointField.INT16: 'i2', PointField.UINT16: 'u2',
    PointField.INT32: 'i4', PointField.UINT32: 'u4', PointField.FLOAT32: 'f4', PointField.FLOAT64: 'f8',
}


def positions_to_pose_array(t: float, xy: np.ndarray, frame_id: str = FRAME_MAP,
                            headings: np.ndarray | None = None) -> PoseArray:
    """(N, 2) particle positions (and optional headings, rad from +x) → PoseArray (z = 0).

    Particle clouds are for display, so weights are not carried: publish after resampling.
    """
    xy = np.asarray(xy, dtype=float)
    msg = PoseArray()
    msg.header = _header(t, frame_id)
    half = np.zeros(len(xy)) if headings is None else 0.5 * np.asarray(headings, dtype=float)
    msg.poses = [Pose(position=Point(x=px, y=py)) for px, py in xy.tolist()]
    for pose, qz, qw in zip(msg.poses, np.sin(half).tolist(), np.cos(half).tolist(), strict=True):
        pose.orientation.z, pose.orientation.w = qz, qw
    return msg


def pose_array_to_positions(msg: PoseArray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`positions_to_pose_array`: ((N, 2) positions, (N,) headings)."""
    xy = np.array([(p.position.x, p.position.y) for p in msg.poses], dtype=float).reshape(-1, 2)
    q = np.array([(p.orientation.z, p.orientation.w) for p in msg.poses], dtype=float).reshape(-1, 2)
    return xy, 2.0 * np.arctan2(q[:, 0], q[:, 1])


_DATATYPE_OF = {np.dtype('<f4'): PointField.FLOAT32, np.dtype('<f8'): PointField.FLOAT64}
#: The fields every PointCloud2 we publish starts with: float32, at offsets 0, 4, 8.
XYZ = ('x', 'y', 'z')


def _columns(fields: Mapping[str, np.ndarray]) -> tuple[dict[str, np.ndarray], int]:
    """The columns as arrays, and their common length (``ValueError`` unless all are 1-D of one length)."""
    if not fields:
        raise ValueError('a PointCloud2 table needs at least one field')
    cols = {str(name): np.asarray(col) for name, col in fields.items()}
    shapes = {name: col.shape for name, col in cols.items()}
    if any(len(s) != 1 for s in shapes.values()) or len({s[0] for s in shapes.values()}) != 1:
        raise ValueError(f'fields must be 1-D columns of one length, got shapes {shapes}')
    return cols, next(iter(shapes.values()))[0]


def _pack_cloud(t: float, frame_id: str, cols: Mapping[str, np.ndarray], dtype: np.dtype) -> PointCloud2:
    """Columns → ``PointCloud2`` through the structured ``dtype`` (its offsets and itemsize; padding zero)."""
    n = len(next(iter(cols.values())))
    table = np.zeros(n, dtype=dtype)  # zeros: padding bytes are deterministic (bit-for-bit replays)
    for name, col in cols.items():  # loop over columns, not points
        table[name] = col
    step = dtype.itemsize
    msg = PointCloud2(
        header=_header(t, frame_id), height=1, width=n, is_bigendian=False, point_step=step, row_step=step * n,
        fields=[PointField(name=name, offset=dtype.fields[name][1], datatype=_DATATYPE_OF[dtype.fields[name][0]],
                           count=1) for name in dtype.names],
        is_dense=bool(all(np.isfinite(table[name]).all() for name in dtype.names)),
    )
    msg.data = array.array('B', table.tobytes())  # array.array: rclpy skips its per-byte check
    return msg


def table_to_pointcloud2(t: float, frame_id: str, fields: Mapping[str, np.ndarray]) -> PointCloud2:
    """Named columns of equal length n → ``PointCloud2`` with one float32 field per column, one point per row.

    Packed through a numpy structured array (no loop over points). A table may have 0 rows. A
    table to publish has positions: use ``points_to_pointcloud2``.
    """
    cols, _ = _columns(fields)
    return _pack_cloud(t, frame_id, cols, np.dtype([(name, _FLOAT32) for name in cols]))


def points_to_pointcloud2(t: float, frame_id: str, xy: np.ndarray, fields: Mapping[str, np.ndarray]) -> PointCloud2:
    """Points ``xy`` (n, 2) or (n, 3) [m, in ``frame_id``] and columns → ``PointCloud2`` with float32 ``x``,
    ``y``, ``z`` first (offsets 0, 4, 8; z = 0 for (n, 2)), then one float32 field per column."""
    xy = np.asarray(xy, dtype=float)
    if xy.ndim != 2 or xy.shape[1] not in (2, 3):
        raise ValueError(f'points must have shape (n, 2) or (n, 3), got {xy.shape}')
    clash = [k for k in fields if k in XYZ]
    if clash:
        raise ValueError(f'column(s) {", ".join(clash)} clash with the point fields x, y, z')
    z = xy[:, 2] if xy.shape[1] == 3 else np.zeros(len(xy))
    return table_to_pointcloud2(t, frame_id, {'x': xy[:, 0], 'y': xy[:, 1], 'z': z, **fields})


def cloud_columns(table: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """A table read by ``pointcloud2_to_table`` without its point fields x, y, z."""
    return {k: v for k, v in table.items() if k not in XYZ}


def pointcloud2_to_table(msg: PointCloud2) -> dict[str, np.ndarray]:
    """``PointCloud2`` → ``{field name: float64 array}`` (shape (n,), or (n, count) when count > 1).

    Honours each field's datatype, offset and count, ``is_bigendian``, ``point_step`` and
    row padding (``row_step``), so clouds from other producers read too. float64 holds every
    PointField datatype exactly.
    """
    if not msg.fields:
        return {}
    endian = '>' if msg.is_bigendian else '<'
    names, formats, offsets = [], [], []
    for f in msg.fields:
        if f.datatype not in _POINTFIELD_DTYPES:
            raise ValueError(f'field {f.name!r}: unknown PointField datatype {f.datatype}')
        base = endian + _POINTFIELD_DTYPES[f.datatype]
        names.append(f.name)
        formats.append(base if f.count == 1 else (base, (f.count,)))
        offsets.append(f.offset)
    dtype = np.dtype({'names': names, 'formats': formats, 'offsets': offsets, 'itemsize': msg.point_step})
    height, width, row_step = int(msg.height), int(msg.width), int(msg.row_step)
    raw = np.frombuffer(msg.data, dtype=np.uint8)
    if width * msg.point_step > row_step or raw.size < height * row_step:
        raise ValueError(f'PointCloud2 data too short: {raw.size} bytes for {height}x{width} points '
                         f'(point_step {msg.point_step}, row_step {row_step})')
    rows = np.ascontiguousarray(raw[:height * row_step].reshape(height, row_step)[:, :width * msg.point_step])
    points = rows.view(dtype).reshape(height * width)
    with np.errstate(invalid='ignore'):  # a hostile cloud's NaN in an integer field: the caller's checks refuse it
        return {name: points[name].astype(np.float64) for name in names}


# --- SLAM topics (hybrid CEKF/PF SLAM; the mapping table is in track_msgs_py.topics) -------------

_POSE_IDX = (0, 1, 5)  # x, y, yaw in the 6×6 row-major pose covariance of Odometry


def pose_to_odometry(t: float, pose: np.ndarray, P: np.ndarray, frame_id: str = FRAME_MAP,
                     child_frame_id: str = FRAME_LASER) -> Odometry:
    """Pose (x, y, φ) with covariance P (3×3) → Odometry: orientation yaw φ, covariance entries
    (x, y, yaw) = P, z/roll/pitch ``PLANAR_VARIANCE``; the twist is not estimated (x/y and yaw rate
    ``NOT_ESTIMATED_VARIANCE``, the planar rates 0)."""
    pose = np.asarray(pose, dtype=float)
    msg = Odometry(header=_header(t, frame_id), child_frame_id=child_frame_id)
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(pose[0]), float(pose[1])
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(pose[2] / 2), math.cos(pose[2] / 2)
    cov = _planar_cov(np.zeros((2, 2)), 0.0).reshape(6, 6)
    cov[np.ix_(_POSE_IDX, _POSE_IDX)] = np.asarray(P, dtype=float)
    msg.pose.covariance = cov.reshape(36)
    msg.twist.covariance = _planar_cov(np.eye(2) * NOT_ESTIMATED_VARIANCE)
    return msg


def odometry_to_pose(msg: Odometry) -> tuple[float, np.ndarray, np.ndarray]:
    """Inverse of :func:`pose_to_odometry`: (t, pose (x, y, yaw), P (3×3)); yaw from a z-axis rotation."""
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    cov = np.asarray(msg.pose.covariance, dtype=float).reshape(6, 6)[np.ix_(_POSE_IDX, _POSE_IDX)]
    return stamp_to_sec(msg.header.stamp), np.array([p.x, p.y, yaw]), cov.copy()


def inputs_to_twist(t: float, speed: float, steer: float, frame_id: str = FRAME_BASE) -> TwistStamped:
    """Encoder speed [m/s] and steering angle [rad] → TwistStamped (linear.x, angular.z)."""
    msg = TwistStamped(header=_header(t, frame_id))
    msg.twist.linear.x, msg.twist.angular.z = float(speed), float(steer)
    return msg


def twist_to_inputs(msg: TwistStamped) -> tuple[float, float, float]:
    """TwistStamped → (t, encoder speed, steering angle)."""
    return stamp_to_sec(msg.header.stamp), float(msg.twist.linear.x), float(msg.twist.angular.z)


def scan_points(z: np.ndarray) -> np.ndarray:
    """(n, 2) detections in the laser frame (x ahead, y left, REP-103) of z (n, 2) = (range, eq. 5 bearing).

    Eq. 5's bearing is 0 to the right and π/2 ahead, so the point is r·(cos(b − π/2), sin(b − π/2)) =
    (r sin b, −r cos b): the frame whose pose (x, y, φ) ``/slam/pose`` carries, so the laser frame
    placed at that pose puts the point where ``track_core.slam.models.inverse_observe`` does.
    """
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    return np.stack([z[:, 0] * np.sin(z[:, 1]), -z[:, 0] * np.cos(z[:, 1])], axis=1)


def scan_to_pointcloud2(t: float, z: np.ndarray, diameter: np.ndarray | None = None, frame_id: str = FRAME_LASER,
                        **extra: np.ndarray) -> PointCloud2:
    """One scan, z (n, 2) of (range to the surface [m], bearing [rad]) and diameters (n,) → PointCloud2:
    float32 x, y, z (``scan_points``, z = 0), range, bearing, diameter, then ``extra``."""
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    d = np.zeros(len(z)) if diameter is None else np.asarray(diameter, dtype=float)
    return points_to_pointcloud2(t, frame_id, scan_points(z),
                                 {'range': z[:, 0], 'bearing': z[:, 1], 'diameter': d, **extra})


# --- visualisation and diagnostics ----------------------------------------------------------

def ellipse_points(mean: np.ndarray, cov: np.ndarray, n_sigma: float = 2.0, n_points: int = 72) -> np.ndarray:
    """Closed loop (n_points + 1, 2) of the n_sigma ellipse of one outside Gaussian, checked first.

    The geometry is :func:`track_core.filters.gaussian.ellipse_points` (batched; use it directly
    for many ellipses of already-checked covariances); here a bad ``cov`` raises a ``ValueError``
    with its reason.
    """
    mean = _as_shape(mean, (2,), 'mean')
    cov = _as_shape(cov, (2, 2), 'cov')
    reason = covariance_problem(cov)
    if reason is not None:
        raise ValueError(f'cov: {reason}')
    return gaussian_ellipse_points(mean, cov, n_sigma, n_points)


def covariance_ellipse_marker(t: float, mean: np.ndarray, cov: np.ndarray, frame_id: str = FRAME_MAP, *,
                              ns: str = 'covariance', marker_id: int = 0, n_sigma: float = 2.0,
                              n_points: int = 72, z: float = 0.0, line_width: float = 0.05,
                              color: Sequence[float] = (1.0, 0.5, 0.0, 1.0), lifetime: float = 0.0) -> Marker:
    """LINE_STRIP ``Marker`` of the n_sigma (default 2σ) ellipse of N(mean, cov) in the x/y plane at height z.

    ``lifetime`` 0 keeps the marker until replaced (same ns/id) or deleted.
    """
    mean = _as_shape(mean, (2,), 'mean')
    cov = _as_shape(cov, (2, 2), 'cov')
    return covariance_ellipse_markers(t, mean[None], cov[None], frame_id, ns=ns, marker_ids=[marker_id],
                                      n_sigma=n_sigma, n_points=n_points, z=z, line_width=line_width, color=color,
                                      lifetime=lifetime)[0]


def covariance_ellipse_markers(t: float, means: np.ndarray, covs: np.ndarray, frame_id: str = FRAME_MAP, *,
                               ns: str = 'covariance', marker_ids: Sequence[int], n_sigma: float = 2.0,
                               n_points: int = 72, z: float = 0.0, line_width: float = 0.05,
                               color: Sequence[float] = (1.0, 0.5, 0.0, 1.0), lifetime: float = 0.0) -> list[Marker]:
    """:func:`covariance_ellipse_marker` of means (n, 2), covs (n, 2, 2): one outline computation for all.

    Each covariance is checked (``ValueError`` naming its row and the reason).
    """
    means = np.asarray(means, dtype=float).reshape(-1, 2)
    covs = np.asarray(covs, dtype=float).reshape(-1, 2, 2)
    for k, cov in enumerate(covs):
        reason = covariance_problem(cov)
        if reason is not None:
            raise ValueError(f'cov{f" {k}" if len(covs) > 1 else ""}: {reason}')
    pts = gaussian_ellipse_points(means, covs, n_sigma, n_points) if len(covs) else np.zeros((0, n_points + 1, 2))
    stamp, life = sec_to_stamp(t), sec_to_stamp(lifetime)
    r, g, b, a = (float(c) for c in color)
    out = []
    for mid, loop in zip(marker_ids, pts.tolist(), strict=True):
        msg = Marker(header=Header(stamp=Time(sec=stamp.sec, nanosec=stamp.nanosec), frame_id=frame_id), ns=ns,
                     id=int(mid), type=Marker.LINE_STRIP, action=Marker.ADD, color=ColorRGBA(r=r, g=g, b=b, a=a),
                     lifetime=Duration(sec=life.sec, nanosec=life.nanosec))
        msg.pose.orientation.w = 1.0
        msg.scale.x = float(line_width)
        msg.points = [Point(x=px, y=py, z=float(z)) for px, py in loop]  # message needs Point objects
        out.append(msg)
    return out


#: DiagnosticStatus levels as ints (the message stores them as one byte).
DIAG_OK, DIAG_WARN, DIAG_ERROR, DIAG_STALE = 0, 1, 2, 3


def diagnostic_status(name: str, level: int | bytes, message: str, values: Mapping[str, object],
                      hardware_id: str = '') -> DiagnosticStatus:
    """``diagnostic_msgs/DiagnosticStatus``; ``level`` 0..3 (OK, WARN, ERROR, STALE) as int or the
    message's byte constant; each value is written with ``str()`` (floats round-trip)."""
    lvl = level[0] if isinstance(level, bytes | bytearray) and len(level) == 1 else level
    if not isinstance(lvl, int) or not DIAG_OK <= lvl <= DIAG_STALE:
        raise ValueError(f'diagnostic level must be 0..3 (OK, WARN, ERROR, STALE), got {level!r}')
    return DiagnosticStatus(level=bytes([lvl]), name=name, message=message, hardware_id=hardware_id,
                            values=[KeyValue(key=str(k), value=str(v)) for k, v in values.items()])


def diagnostic_array(t: float, statuses: Sequence[DiagnosticStatus]) -> DiagnosticArray:
    """Statuses stamped at ``t`` into the ``diagnostic_msgs/DiagnosticArray`` published on /diagnostics."""
    return DiagnosticArray(header=_header(t, ''), status=list(statuses))


# --- IDSQ sensor layout ⇄ PointCloud2, handoff bytes ⇄ UInt8MultiArray ---------------------

#: The FLOAT64 fields of the ``/idsq/layout`` cloud, after float32 x, y, z (type 0 acoustic, 1 DOA).
LAYOUT_FIELDS = ('id', 'x_f64', 'y_f64', 'type')
_LAYOUT_DTYPE = np.dtype({'names': [*XYZ, *LAYOUT_FIELDS], 'formats': ['<f4'] * 3 + ['<f8'] * 4,
                          'offsets': [0, 4, 8, 16, 24, 32, 40], 'itemsize': 48})
#: ``layout.dim[0].label`` of a handoff message: ``data`` is ``track_core.idsq.encode_handoff`` bytes.
HANDOFF_LABEL = 'idsq_handoff_v1'


def layout_to_pointcloud2(t: float, layout: SensorLayout, frame_id: str = FRAME_MAP) -> PointCloud2:
    """IDSQ sensor layout → ``PointCloud2``, one point per sensor: float32 x, y, z (0) for the viewers,
    then FLOAT64 ``LAYOUT_FIELDS`` (the positions again, exactly, for every node; see the module table)."""
    pos = layout.positions
    return _pack_cloud(t, frame_id, {'x': pos[:, 0], 'y': pos[:, 1], 'z': np.zeros(layout.n),
                                     'id': np.arange(layout.n), 'x_f64': pos[:, 0], 'y_f64': pos[:, 1],
                                     'type': layout.is_doa.astype(float)}, _LAYOUT_DTYPE)


def pointcloud2_to_layout(msg: PointCloud2, comm_range: float) -> SensorLayout:
    """Inverse of ``layout_to_pointcloud2`` (points in any order); ``ValueError`` with a one-line reason
    if unusable. ``comm_range`` [m] is the receiver's neighbour rule (not carried by the message)."""
    from track_core.idsq.network import SensorLayout  # here, not at the top: track_core.idsq loads scipy.stats

    cols = pointcloud2_to_table(msg)
    if 'x_f64' not in cols and 'y_f64' not in cols and 'x' in cols and 'y' in cols:  # the older layout
        cols['x_f64'], cols['y_f64'] = cols['x'], cols['y']
    missing = [f for f in LAYOUT_FIELDS if f not in cols]
    if missing:
        raise ValueError(f'layout has no field(s) {", ".join(missing)}')
    ids = cols['id']
    order = np.argsort(ids, kind='stable')
    if not np.array_equal(ids[order], np.arange(ids.size)):
        raise ValueError(f'layout ids must be 0..{ids.size - 1} once each')
    types = cols['type'][order]
    if not np.all((types == 0) | (types == 1)):
        raise ValueError('layout type must be 0 (acoustic) or 1 (DOA)')
    pos = np.stack([cols['x_f64'][order], cols['y_f64'][order]], axis=1)
    return SensorLayout(pos, types == 1, comm_range)


def handoff_to_uint8_array(payload: bytes) -> UInt8MultiArray:
    """Handoff bytes (``encode_handoff``) → ``std_msgs/UInt8MultiArray`` labelled ``HANDOFF_LABEL``."""
    msg = UInt8MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=HANDOFF_LABEL, size=len(payload), stride=len(payload))]
    msg.data = array.array('B', payload)
    return msg


def uint8_array_to_handoff(msg: UInt8MultiArray) -> bytes:
    """``std_msgs/UInt8MultiArray`` → its ``data`` as bytes, unchecked (``receive_handoff`` validates)."""
    return msg.data.tobytes() if hasattr(msg.data, 'tobytes') else bytes(msg.data)
