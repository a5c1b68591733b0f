"""tools/build_interfaces.py: the include-path patch, and the tf2_msgs it built into the venv."""

import importlib.util
import sysconfig
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]


def _tool():
    spec = importlib.util.spec_from_file_location('build_interfaces', ROOT / 'tools/build_interfaces.py')
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_patch_replaces_the_manylinux_include_paths_once(tmp_path):
    tool = _tool()
    f = tmp_path / 'pkg/cmake/export_pkg__rosidl_generator_pyExport.cmake'
    f.parent.mkdir(parents=True)
    f.write_text('INTERFACE_INCLUDE_DIRECTORIES "/opt/python/cp311-cp311/include/python3.11;'
                 '/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include"\n')
    other = tmp_path / 'pkg/notes.txt'
    other.write_text('/opt/python/cp311-cp311/include/python3.11')
    py_inc, np_inc = sysconfig.get_paths()['include'], np.get_include()
    assert tool.patch_include_paths(tmp_path, py_inc, np_inc) == 1
    assert f.read_text() == f'INTERFACE_INCLUDE_DIRECTORIES "{py_inc};{np_inc}"\n'
    assert other.read_text() == '/opt/python/cp311-cp311/include/python3.11'  # only *.cmake files
    assert tool.patch_include_paths(tmp_path, py_inc, np_inc) == 0  # idempotent


def test_the_venv_cmake_files_name_no_foreign_include_path():
    venv_share = Path(sysconfig.get_paths()['data']) / 'share'
    bad = [p for p in venv_share.rglob('*.cmake') if '/opt/python/cp' in p.read_text(errors='replace')]
    assert bad == []


def test_built_tf2_msgs_round_trips_through_rclpy_and_rosbags():
    from geometry_msgs.msg import TransformStamped
    from rclpy.serialization import deserialize_message, serialize_message
    from rosbags.typesys import Stores, get_typestore
    from tf2_msgs.msg import TFMessage

    msg = TFMessage(transforms=[TransformStamped(child_frame_id='laser')])
    msg.transforms[0].header.frame_id = 'map'
    msg.transforms[0].transform.translation.x = 1.5
    raw = serialize_message(msg)
    assert deserialize_message(raw, TFMessage) == msg
    other = get_typestore(Stores.ROS2_JAZZY).deserialize_cdr(raw, 'tf2_msgs/msg/TFMessage')
    assert other.transforms[0].child_frame_id == 'laser'
    assert other.transforms[0].transform.translation.x == 1.5
