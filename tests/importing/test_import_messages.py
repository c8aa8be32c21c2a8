"""cosim import of message logs and tables: ROS 2 bags (sqlite3 and MCAP storage) written by
rosbags' own writer, plain MCAP files written by mcap-ros2-support's writer, Parquet written by
pyarrow; the values checked against the numbers written, the errors for their one line."""
import shutil
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from cosim.importing import ImportFailure, to_recording
from cosim.cli.main import main

N = 50
DT = 0.002
T0_NS = 1_700_000_000_123_456_789          # an absolute stamp: the epoch in 2023


def _signals():
    t = np.arange(N) * DT
    return t, 0.3 * np.sin(7 * t), 0.3 * 7 * np.cos(7 * t), 0.5 + np.cos(3 * t), -0.2 + 0.1 * np.sin(11 * t)


MAP = '''robot = "pendulum"
[columns]
time = { topic = "/joint_states", field = "%s" }
q1 = { topic = "/joint_states", field = "position[1]" }
qd1 = { topic = "/joint_states", field = "velocity[1]" }
tau1 = { topic = "/joint_states", field = "effort[1]" }
qref1 = { topic = "/cmd", field = "data", unit = "deg" }
'''


def _write_bag(path, storage):
    """A bag of two topics by rosbags' writer: /joint_states (two joints; ours is the second)
    and /cmd (std_msgs/Float64, in degrees) logged 1 ms after each joint state."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    JS, F = ts.types["sensor_msgs/msg/JointState"], ts.types["std_msgs/msg/Float64"]
    H, T = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    t, q, qd, tau, ref = _signals()
    plug = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plug) as w:
        cj = w.add_connection("/joint_states", JS.__msgtype__, typestore=ts)
        cc = w.add_connection("/cmd", F.__msgtype__, typestore=ts)
        for k in range(N):
            ns = T0_NS + int(round(t[k] * 1e9))
            m = JS(header=H(stamp=T(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="base"), name=["a", "b"],
                   position=np.array([9.0, q[k]]), velocity=np.array([9.0, qd[k]]), effort=np.array([9.0, tau[k]]))
            w.write(cj, ns + 50_000, ts.serialize_cdr(m, JS.__msgtype__))
            w.write(cc, ns + 1_000_000, ts.serialize_cdr(F(data=float(np.degrees(ref[k]))), F.__msgtype__))
    return path


JOINT_STATE_DEF = """std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def _write_mcap(path):
    """A plain MCAP file by mcap-ros2-support's writer: /joint_states only."""
    from mcap_ros2.writer import Writer

    t, q, qd, tau, _ = _signals()
    with open(path, "wb") as f:
        w = Writer(f)
        schema = w.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE_DEF)
        for k in range(N):
            ns = T0_NS + int(round(t[k] * 1e9))
            msg = {"header": {"stamp": {"sec": ns // 10**9, "nanosec": ns % 10**9}, "frame_id": ""},
                   "name": ["a", "b"], "position": [9.0, q[k]], "velocity": [9.0, qd[k]], "effort": [9.0, tau[k]]}
            w.write_message("/joint_states", schema, msg, log_time=ns + 50_000, publish_time=ns)
        w.finish()
    return path


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("clock", ["header.stamp", "log_time"])
def test_ros2_bag(tmp_path, storage, clock):
    bag = _write_bag(tmp_path / f"bag_{storage}", storage)
    (tmp_path / "map.toml").write_text(MAP % clock)
    rec = to_recording(bag, tmp_path / "map.toml")
    t, q, qd, tau, ref = _signals()
    # the first joint state comes before any /cmd message and is left out (test_bag_zero_order_hold);
    # times are relative to the first row kept, stamps and log times are whole nanoseconds of t
    assert len(rec) == N - 1
    np.testing.assert_allclose(rec.time, t[1:] - t[1], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(rec.q[:, 0], q[1:])
    np.testing.assert_array_equal(rec.qd[:, 0], qd[1:])
    np.testing.assert_array_equal(rec.tau[:, 0], tau[1:])
    assert rec.sidecar["source"]["format"] == "rosbag2"


def test_bag_zero_order_hold(tmp_path):
    """The other topic's value on each row: the last command logged at or before it."""
    bag = _write_bag(tmp_path / "bag", "sqlite3")
    (tmp_path / "map.toml").write_text(MAP % "log_time")
    rec = to_recording(bag, tmp_path / "map.toml")
    t, q, _, _, ref = _signals()
    # a joint state is logged 50 us after its stamp, its command 1 ms after: at joint state k
    # the last command is k-1's; joint state 0 comes before any command and is left out
    assert len(rec) == N - 1
    np.testing.assert_allclose(rec.qref[:, 0], ref[:-1], rtol=1e-14, atol=1e-15)
    np.testing.assert_array_equal(rec.q[:, 0], q[1:])
    np.testing.assert_allclose(rec.time, t[1:] - t[1], atol=1e-12)


def test_plain_mcap(tmp_path):
    f = _write_mcap(tmp_path / "run.mcap")
    m = (MAP % "header.stamp").split("qref1")[0]
    (tmp_path / "map.toml").write_text(m)
    rec = to_recording(f, tmp_path / "map.toml")
    t, q, qd, tau, _ = _signals()
    np.testing.assert_allclose(rec.time, t, atol=1e-12)
    np.testing.assert_array_equal(rec.q[:, 0], q)
    np.testing.assert_array_equal(rec.tau[:, 0], tau)
    assert rec.sidecar["source"]["format"] == "mcap"


def test_parquet(tmp_path):
    """Numbers, a list column (column = 2 of it), a timestamp column in seconds."""
    t, q, qd, tau, ref = _signals()
    stamps = pa.array((T0_NS + np.round(t * 1e9)).astype("int64"), pa.timestamp("ns"))
    table = pa.table({"stamp": stamps, "pos": [[9.0, v] for v in q], "vel": qd, "torque_mNm": tau * 1e3})
    pq.write_table(table, tmp_path / "run.parquet")
    (tmp_path / "map.toml").write_text(f'''robot = "pendulum"
[columns]
time = {{ variable = "stamp", offset = {-T0_NS * 1e-9!r} }}
q1 = {{ variable = "pos", column = 2 }}
qd1 = "vel"
tau1 = {{ variable = "torque_mNm", unit = "mN m" }}
''')
    rec = to_recording(tmp_path / "run.parquet", tmp_path / "map.toml")
    np.testing.assert_allclose(rec.time, t, atol=1e-6)   # an epoch in float64: ~0.2 us
    np.testing.assert_array_equal(rec.q[:, 0], q)
    np.testing.assert_allclose(rec.tau[:, 0], tau, rtol=1e-15)
    assert rec.sidecar["source"]["format"] == "parquet"


def _fails(tmp_path, capsys, source, map_text, *words):
    (tmp_path / "m.toml").write_text(map_text)
    with pytest.raises(ImportFailure) as e:
        to_recording(source, tmp_path / "m.toml")
    msg = str(e.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, msg
    code = main(["import", str(source), "--map", str(tmp_path / "m.toml"), "--out", str(tmp_path / "out")])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and msg in err[0]
    return msg


def test_message_errors(tmp_path, capsys):
    bag = _write_bag(tmp_path / "bag", "sqlite3")
    good = MAP % "header.stamp"
    _fails(tmp_path, capsys, bag, good.replace('"/cmd"', '"/cmnd"'), "bag", "topic '/cmnd'", "field 'data'",
           "no such topic", "did you mean '/cmd'")
    _fails(tmp_path, capsys, bag, good.replace("velocity[1]", "velocty[1]"), "topic '/joint_states'",
           "field 'velocty[1]'", "has no field 'velocty'", "did you mean 'velocity'")
    _fails(tmp_path, capsys, bag, good.replace("effort[1]", "effort[2]"), "field 'effort[2]'",
           "index 2 is out of range", "2 value(s)")
    _fails(tmp_path, capsys, bag, good.replace("effort[1]", "effort"), "field 'effort'", "effort[0]")
    _fails(tmp_path, capsys, bag, good.replace('field = "position[1]"', 'field = "position[1"'), "not a field path")
    _fails(tmp_path, capsys, bag, good.replace(', field = "position[1]"', ""), "columns.q1.field", "topic and field")


def test_empty_bag_and_foreign_file(tmp_path, capsys):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    with Writer(tmp_path / "empty", version=9) as w:
        w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
    _fails(tmp_path, capsys, tmp_path / "empty", MAP % "log_time", "empty", "has no messages", "/joint_states")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"\x89MCAP0\r\nnot really")
    _fails(tmp_path, capsys, junk, MAP % "log_time", "junk.mcap", "cannot be read as a MCAP file")
    lone = tmp_path / "lone" / "x.db3"
    lone.parent.mkdir()
    shutil.copy(next((tmp_path / "empty").glob("*.db3")), lone)
    _fails(tmp_path, capsys, lone, MAP % "log_time", "x.db3", "metadata.yaml")


def test_parquet_errors(tmp_path, capsys):
    pq.write_table(pa.table({"t": [0.0, 0.1, 0.2], "q": [[1.0], [2.0, 3.0], [4.0]], "name": ["a", "b", "c"],
                             "v": [0.0, 1.0, 2.0]}), tmp_path / "bad.parquet")
    body = 'robot = "pendulum"\n[columns]\ntime = "t"\nqd1 = "v"\ntau1 = "v"\n'
    _fails(tmp_path, capsys, tmp_path / "bad.parquet", body + 'q1 = { variable = "q", column = 1 }\n',
           "variable 'q'", "lists have different lengths", "row 2")
    _fails(tmp_path, capsys, tmp_path / "bad.parquet", body + 'q1 = "name"\n', "variable 'name'", "not an array of "
                                                                                                  "numbers")
    _fails(tmp_path, capsys, tmp_path / "bad.parquet", body + 'q1 = "qq"\n', "variable 'qq'", "did you mean 'q'")
    (tmp_path / "fake.parquet").write_text("t,q\n1,2\n")
    _fails(tmp_path, capsys, tmp_path / "fake.parquet", body + 'q1 = "q"\n', "is not a Parquet file")


def test_cli_imports_a_bag_folder(tmp_path, capsys):
    """`cosim import BAG_FOLDER` (the folder holding metadata.yaml) writes the recording."""
    bag = _write_bag(tmp_path / "run1", "mcap")
    (tmp_path / "map.toml").write_text(MAP % "header.stamp")
    assert main(["import", str(bag), "--map", str(tmp_path / "map.toml"), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "from rosbag2" in out and f"({N - 1} rows" in out, out
    assert (tmp_path / "out" / "run1.csv").is_file() and (tmp_path / "out" / "run1.json").is_file()


def test_joint_picked_by_name_whatever_the_order(tmp_path, capsys):
    """`position[b]`: the element where "b" is in each message's name list; the publisher swaps
    the order of its two joints on every other message."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    JS, H, T = (ts.types[k] for k in ("sensor_msgs/msg/JointState", "std_msgs/msg/Header",
                                      "builtin_interfaces/msg/Time"))
    t, q, qd, tau, _ = _signals()
    with Writer(tmp_path / "swapped", version=9) as w:
        c = w.add_connection("/joint_states", JS.__msgtype__, typestore=ts)
        for k in range(N):
            ns = T0_NS + int(round(t[k] * 1e9))
            mine = [q[k], qd[k], tau[k]]
            order = ["a", "b"] if k % 2 == 0 else ["b", "a"]
            arr = [np.array([9.0, v]) if k % 2 == 0 else np.array([v, 9.0]) for v in mine]
            m = JS(header=H(stamp=T(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""), name=order,
                   position=arr[0], velocity=arr[1], effort=arr[2])
            w.write(c, ns, ts.serialize_cdr(m, JS.__msgtype__))
    body = (MAP % "header.stamp").split("qref1")[0].replace("[1]", "[b]")
    (tmp_path / "map.toml").write_text(body)
    rec = to_recording(tmp_path / "swapped", tmp_path / "map.toml")
    np.testing.assert_array_equal(rec.q[:, 0], q)
    np.testing.assert_array_equal(rec.tau[:, 0], tau)
    _fails(tmp_path, capsys, tmp_path / "swapped", body.replace("position[b]", "position[c]"), "field 'position[c]'",
           "'c' is not in the first message's name list (it has: a, b)")
