"""Tables of named columns ⇄ ``sensor_msgs/PointCloud2``, and the SLAM scan cloud.

=========================  ==========================================  ===============================================
data                       message type                                fields
=========================  ==========================================  ===============================================
table of named columns     sensor_msgs/PointCloud2                     one ``FLOAT32`` PointField per column (dict
(each (n,))                                                            order, offset 4·i, count 1), height 1, width n,
                                                                       little-endian, ``point_step`` 4·k, ``is_dense``
                                                                       = all values finite; ``data`` = packed rows
points with named columns  sensor_msgs/PointCloud2                     ``points_to_pointcloud2``: the same with
(xy (n, 2|3) + columns)                                                float32 ``x``, ``y``, ``z`` first (offsets 0, 4,
                                                                       8; z = 0 when not given), the columns after
=========================  ==========================================  ===============================================

Deliberate deviations and losses:

- PointCloud2 columns are float32: values lose precision beyond ~7 significant digits.
- Every cloud we publish carries float32 ``x``, ``y``, ``z`` first, at offsets 0, 4, 8 (RViz
  needs them to draw a cloud, Foxglove refuses one with fewer than two of them). A table
  without positions of its own gets them from its record (``records.slam.SlamScan``: the
  detection in the laser frame; ``records.rfid.RfidPhase``: where the reader was;
  ``records.idsq.IdsqBelief``: the cell centre). ``cloud_columns`` drops them again for a reader
  of the table's own columns.

``pointcloud2_to_table`` reads clouds of other producers too (any PointField datatype, byte
order, padding); nothing here validates a cloud beyond its byte layout.
"""

from __future__ import annotations

import array
from collections.abc import Mapping

import numpy as np
from sensor_msgs.msg import PointCloud2, PointField

from track_msgs_py.stamps import stamped_header
from track_msgs_py.topics import FRAME_LASER

_FLOAT32 = np.dtype('<f4')
_POINTFIELD_DTYPES = {
    PointField.INT8: 'i1', PointField.UINT8: 'u1', PointField.INT16: 'i2', PointField.UINT16: 'u2',
    PointField.INT32: 'i4', PointField.UINT32: 'u4', PointField.FLOAT32: 'f4', PointField.FLOAT64: 'f8',
}
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


def pack_cloud(t: float, frame_id: str, cols: Mapping[str, np.ndarray], dtype: np.dtype) -> PointCloud2:
    """Columns → ``PointCloud2`` through the structured ``dtype`` (its offsets and itemsize; padding zero).

    For a cloud of a fixed layout of its own (float32 and float64 fields, ``records.idsq``'s sensor
    layout); a plain table goes through ``table_to_pointcloud2``.
    """
    n = len(next(iter(cols.values())))
    table = np.zeros(n, dtype=dtype)  # zeros: padding bytes are deterministic (bit-for-bit replays)
    for name, col in cols.items():  # loop over columns, not points
        table[name] = col
    step = dtype.itemsize
    msg = PointCloud2(
        header=stamped_header(t, frame_id), height=1, width=n, is_bigendian=False, point_step=step,
        row_step=step * n,
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
    return pack_cloud(t, frame_id, cols, np.dtype([(name, _FLOAT32) for name in cols]))


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


# --- the SLAM scan (/slam/scan; its table is records.slam.SlamScan) -------------------------

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
