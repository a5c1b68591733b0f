"""``doa_sensor``: a direction-of-arrival (bearing) sensor of the IDSQ network (eq. 11, Fig. 6).

All the logic is in ``track_nodes.idsq_sensor``; this executable fixes ``type`` to ``doa``.
"""

from __future__ import annotations

from track_nodes.idsq_sensor import IdsqSensorNode, main_for


class DoaSensorNode(IdsqSensorNode):
    DEFAULT_NAME = 'doa_sensor'
    SENSOR_TYPE = 'doa'


NODE_CLASS = DoaSensorNode


def main(argv=None) -> int:
    return main_for(DoaSensorNode, argv)


if __name__ == '__main__':
    raise SystemExit(main())
