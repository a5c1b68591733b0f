"""``acoustic_sensor``: an acoustic-amplitude sensor of the IDSQ network (eqs. 5-6).

All the logic is in ``track_nodes.idsq_sensor``; this executable fixes ``type`` to ``acoustic``.
"""

from __future__ import annotations

from track_nodes.idsq_sensor import IdsqSensorNode, main_for


class AcousticSensorNode(IdsqSensorNode):
    DEFAULT_NAME = 'acoustic_sensor'
    SENSOR_TYPE = 'acoustic'


NODE_CLASS = AcousticSensorNode


def main(argv=None) -> int:
    return main_for(AcousticSensorNode, argv)


if __name__ == '__main__':
    raise SystemExit(main())
