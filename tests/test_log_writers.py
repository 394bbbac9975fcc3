"""seatune.simulate.log_writers: every file is read back with the format's own library, never through seatune.

Expected values come straight from the synthetic tables built here (the independent source): stamps and log
times to the nanosecond, field values bit-exact, covariances laid out as sensor_msgs documents them
(row-major 3×3, diagonal = variance, element 0 = -1 for "not provided").
"""

from __future__ import annotations

import math
import os
import struct

import numpy as np
import pandas as pd
import pytest
from mcap.exceptions import McapError
from mcap.reader import NonSeekingReader, make_reader
from mcap_ros1.decoder import DecoderFactory as Ros1DecoderFactory
from mcap_ros2.decoder import DecoderFactory as Ros2DecoderFactory
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.typesys import Stores, get_typestore

from seatune.simulate.log_writers import Stream, truncate, write_csv, write_mcap, write_ros1_bag, write_ros2_bag

T0 = pd.Timestamp("2024-05-01T12:00:00Z")
IMU, NSF, V3S, TWS = ("sensor_msgs/msg/Imu", "sensor_msgs/msg/NavSatFix", "geometry_msgs/msg/Vector3Stamped",
                      "geometry_msgs/msg/TwistStamped")


def _times(offsets_ns) -> pd.Series:
    return pd.Series(T0 + pd.to_timedelta(np.asarray(offsets_ns, dtype=np.int64), unit="ns"))


def _stamps(n: int, period_ns: int, seed: int) -> np.ndarray:
    """Regular stamps with odd nanoseconds, one duplicated stamp and one 5-period gap."""
    t = np.arange(n, dtype=np.int64) * period_ns + 123_457 + seed
    t[n // 2:] += 5 * period_ns  # gap
    t[n // 3] = t[n // 3 - 1]  # duplicated stamp
    return t


@pytest.fixture(scope="module")
def streams() -> list[Stream]:
    rng = np.random.default_rng(42)
    n = 300
    t = _stamps(n, 100_000_000, 0)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    imu = pd.DataFrame({
        "time": _times(t),
        "log_time": _times(t + rng.integers(1_000_000, 9_000_000, n)),  # receive latency 1–9 ms
        "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3],
        "wx": rng.normal(0, 0.05, n), "wy": rng.normal(0, 0.05, n), "wz": rng.normal(0, 0.01, n),
        "ax": rng.normal(0, 0.3, n), "ay": rng.normal(0, 0.3, n), "az": 9.80665 + rng.normal(0, 0.2, n),
        "var_q": 1e-6, "var_w": rng.uniform(1e-5, 2e-5, n), "var_a": 4e-4,
    })
    t2 = _stamps(250, 100_000_000, 7)
    imu2 = pd.DataFrame({  # a raw IMU: no orientation, no covariances, log_time = stamp
        "time": _times(t2),
        "wx": rng.normal(size=250), "wy": rng.normal(size=250), "wz": rng.normal(size=250),
        "ax": rng.normal(size=250), "ay": rng.normal(size=250), "az": rng.normal(size=250),
    })
    tg = _stamps(40, 1_000_000_000, 11)
    fix = pd.DataFrame({
        "time": _times(tg),
        "log_time": _times(tg + 40_000_000),
        "latitude": 60.391 + rng.normal(0, 1e-4, 40), "longitude": 5.322 + rng.normal(0, 1e-4, 40),
        "altitude": rng.normal(45.0, 0.5, 40), "status": np.where(np.arange(40) == 5, -1, 0),
        "var_pos": 2.25, "var_alt": 9.0,
    })
    tv = _stamps(60, 500_000_000, 13)
    vec = pd.DataFrame({"time": _times(tv), **{c: rng.normal(size=60) for c in ("x", "y", "z")}})
    vec.loc[10, "y"] = np.nan  # a NaN sample is written as NaN
    tt = _stamps(30, 1_000_000_000, 17)
    twist = pd.DataFrame({"time": _times(tt), **{c: rng.normal(size=30) for c in ("vx", "vy", "vz", "wx", "wy", "wz")}})
    return [
        Stream("/imu/data", IMU, "imu_link", imu),
        Stream("/imu2/data_raw", "sensor_msgs/Imu", "imu2_link", imu2),  # ROS1 spelling is normalised
        Stream("/gnss/fix", NSF, "gnss_antenna", fix),
        Stream("/wave/elevation", V3S, "radar", vec),
        Stream("/nav/twist", TWS, "base_link", twist),
    ]


# ------------------------------------------------------------------------------------------------ expectations


def _ns(series: pd.Series) -> list[int]:
    return series.astype("int64").tolist()


def _f(x) -> str:
    """Exact float key that also equates NaN with NaN."""
    return repr(float(x))


def _cov(var, diag=(0, 4, 8)) -> tuple:
    c = [0.0] * 9
    for k in diag:
        c[k] = var
    return tuple(_f(v) for v in c)


def expected(stream: Stream) -> list[tuple]:
    """(log time, stamp sec, stamp nanosec, frame_id, fields...) per message, from the table alone."""
    t = stream.table
    stamp = _ns(t["time"])
    log = _ns(t["log_time"]) if "log_time" in t else stamp
    rows = []
    zero = _cov(0.0)
    for i in range(len(t)):
        r = t.iloc[i]
        if stream.msgtype == IMU:
            if "qw" in t:
                q = tuple(_f(r[c]) for c in ("qx", "qy", "qz", "qw"))
                cq = _cov(r["var_q"]) if "var_q" in t else zero
            else:
                q = (_f(0.0),) * 4
                cq = (_f(-1.0),) + zero[1:]
            fields = (q, cq, tuple(_f(r[c]) for c in ("wx", "wy", "wz")), _cov(r["var_w"]) if "var_w" in t else zero,
                      tuple(_f(r[c]) for c in ("ax", "ay", "az")), _cov(r["var_a"]) if "var_a" in t else zero)
        elif stream.msgtype == NSF:
            cov = list(_cov(r["var_pos"]))
            cov[8] = _f(r["var_alt"])
            fields = (_f(r["latitude"]), _f(r["longitude"]), _f(r["altitude"]), int(r["status"]), 1, tuple(cov), 2)
        elif stream.msgtype == V3S:
            fields = tuple(_f(r[c]) for c in ("x", "y", "z"))
        else:
            fields = tuple(_f(r[c]) for c in ("vx", "vy", "vz", "wx", "wy", "wz"))
        rows.append((log[i], stamp[i] // 10**9, stamp[i] % 10**9, stream.frame_id, fields))
    return rows


def observed(msgtype: str, log_ns: int, msg) -> tuple:
    """The same tuple from a decoded message (rosbags, mcap_ros2 and genpy-style mcap_ros1 objects)."""
    st = msg.header.stamp
    sec = st.sec if hasattr(st, "sec") else st.secs
    nsec = st.nanosec if hasattr(st, "nanosec") else st.nsecs

    def v3(v):
        return (_f(v.x), _f(v.y), _f(v.z))

    def cov(c):
        return tuple(_f(x) for x in c)

    if msgtype == IMU:
        o = msg.orientation
        fields = ((_f(o.x), _f(o.y), _f(o.z), _f(o.w)), cov(msg.orientation_covariance), v3(msg.angular_velocity),
                  cov(msg.angular_velocity_covariance), v3(msg.linear_acceleration),
                  cov(msg.linear_acceleration_covariance))
    elif msgtype == NSF:
        fields = (_f(msg.latitude), _f(msg.longitude), _f(msg.altitude), int(msg.status.status),
                  int(msg.status.service), cov(msg.position_covariance), int(msg.position_covariance_type))
    elif msgtype == V3S:
        fields = v3(msg.vector)
    else:
        fields = v3(msg.twist.linear) + v3(msg.twist.angular)
    return (log_ns, sec, nsec, msg.header.frame_id, fields)


def check_all(streams, got: dict[str, list[tuple]], types: dict[str, str], order: list[int]) -> None:
    """Topics, types, counts, and every message's stamps, log time, frame and fields; global log-time order."""
    assert types == {s.topic: s.msgtype for s in streams}
    for s in streams:
        want = expected(s)
        assert len(got[s.topic]) == len(want), s.topic
        assert sorted(got[s.topic]) == sorted(want), s.topic
    assert order == sorted(order), "messages are not interleaved in log-time order"
    assert sum(len(v) for v in got.values()) == len(order)


# ------------------------------------------------------------------------------------------------ MCAP


def _read_mcap(path, factory, nonseeking=False):
    got, types, order = {}, {}, []
    with open(path, "rb") as f:
        reader = (NonSeekingReader(f, decoder_factories=[factory]) if nonseeking
                  else make_reader(f, decoder_factories=[factory]))
        msgs = reader.iter_decoded_messages(log_time_order=False)  # file order
        for schema, channel, message, decoded in msgs:
            types[channel.topic] = schema.name
            got.setdefault(channel.topic, []).append(observed(_ros2_name(schema.name), message.log_time, decoded))
            assert message.publish_time == message.log_time
            order.append(message.log_time)
    return got, types, order


def _ros2_name(name: str) -> str:
    return name if "/msg/" in name else name.replace("/", "/msg/")


def test_mcap_ros2_read_back_with_mcap_ros2_decoder(streams, tmp_path):
    path = write_mcap(tmp_path / "trial.mcap", streams, chunk_size=4096)
    got, types, order = _read_mcap(path, Ros2DecoderFactory())
    check_all(streams, got, types, order)
    with open(path, "rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
    assert {c.topic: c.message_encoding for c in summary.channels.values()} == {s.topic: "cdr" for s in streams}
    assert all("offered_qos_profiles" in c.metadata for c in summary.channels.values())
    assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
    counts = {summary.channels[k].topic: v for k, v in summary.statistics.channel_message_counts.items()}
    assert counts == {s.topic: len(s.table) for s in streams}
    assert len(summary.chunk_indexes) > 3


def test_mcap_ros1_profile_read_back_with_mcap_ros1_decoder(streams, tmp_path):
    path = write_mcap(tmp_path / "trial_ros1.mcap", streams, profile="ros1", compression="lz4")
    got, types, order = _read_mcap(path, Ros1DecoderFactory())
    types = {k: _ros2_name(v) for k, v in types.items()}
    check_all(streams, got, types, order)
    with open(path, "rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros1"
        summary = reader.get_summary()
    assert {s.name for s in summary.schemas.values()} == {"sensor_msgs/Imu", "sensor_msgs/NavSatFix",
                                                          "geometry_msgs/Vector3Stamped", "geometry_msgs/TwistStamped"}
    assert {c.message_encoding for c in summary.channels.values()} == {"ros1"}


# ------------------------------------------------------------------------------------------------ rosbags


def _read_any(path, typestore=Stores.ROS2_HUMBLE):
    got, types, order = {}, {}, []
    with AnyReader([path], default_typestore=get_typestore(typestore)) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        counts = {c.topic: c.msgcount for c in reader.connections}
        for conn, t, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            got.setdefault(conn.topic, []).append(observed(conn.msgtype, t, msg))
            order.append(t)
            if hasattr(msg.header, "seq"):  # ROS1: the header's sequence counts each publisher's messages
                got[conn.topic][-1] += (msg.header.seq,)
    return got, types, counts, order


@pytest.mark.parametrize("fmt", ["ros1", "ros2-sqlite3", "ros2-mcap", "mcap"])
def test_rosbags_anyreader_reads_every_format(streams, tmp_path, fmt):
    if fmt == "ros1":
        path = write_ros1_bag(tmp_path / "trial.bag", streams, chunk_size=8192)
    elif fmt == "mcap":
        path = write_mcap(tmp_path / "trial.mcap", streams)
    else:
        path = write_ros2_bag(tmp_path / "trial_bag", streams, storage=fmt.split("-")[1])
        assert (path / "metadata.yaml").is_file()
        assert (path / f"trial_bag.{'db3' if fmt.endswith('sqlite3') else 'mcap'}").is_file()
    got, types, counts, order = _read_any(path)
    assert counts == {s.topic: len(s.table) for s in streams}
    if fmt == "ros1":
        for s in streams:  # seq 0..n-1 in table order; strip it before comparing the rest
            want_seq = {row[:5]: i for i, row in enumerate(expected(s))}
            assert sorted(r[5] for r in got[s.topic]) == list(range(len(s.table)))
            assert all(want_seq[r[:5]] == r[5] for r in got[s.topic])
            got[s.topic] = [r[:5] for r in got[s.topic]]
    check_all(streams, got, types, order)


def test_ros1_bag_carries_noetic_definitions(streams, tmp_path):
    path = write_ros1_bag(tmp_path / "trial.bag", streams, compression="bz2")
    # md5sums of the ROS1 Noetic definitions, as `rosmsg md5` prints them
    md5 = {IMU: "6a62c6daae103f4ff57a132d6f95cec2", NSF: "2d3a8cd499b9b4a0249fb98fd05cfa48",
           V3S: "7b324c7325e683bf02a9b14b01090ec7", TWS: "98d34b0043a2093cf9d9345ab6eef12e"}
    with AnyReader([path]) as reader:
        assert {c.topic: c.digest for c in reader.connections} == {s.topic: md5[s.msgtype] for s in streams}
        assert all("\nstd_msgs/Header header\n" in "\n" + c.msgdef.data for c in reader.connections)


# ------------------------------------------------------------------------------------------------ CSV


@pytest.mark.parametrize("time_format", ["iso", "unix"])
def test_csv_exact(streams, tmp_path, time_format):
    table = streams[0].table
    path = write_csv(tmp_path / "imu.csv", table.drop(columns=["time"]).assign(time=table["time"]),
                     time_format=time_format)
    raw = pd.read_csv(path, dtype={"time": str, "log_time": str}, float_precision="round_trip")
    assert list(raw.columns)[0] == "time"
    for col in ("time", "log_time"):
        if time_format == "iso":
            assert raw[col].str.endswith("Z").all()
            got = pd.to_datetime(raw[col], utc=True, format="ISO8601")
            assert _ns(got) == _ns(table[col])
        else:
            sec, frac = raw[col].str.split(".", expand=True).T.values
            assert frac.tolist() == [f"{v % 10**9:09d}" for v in _ns(table[col])]
            assert [int(s) * 10**9 + int(f) for s, f in zip(sec, frac, strict=True)] == _ns(table[col])
    for col in ("qx", "qw", "wx", "az", "var_w"):
        assert raw[col].tolist() == table[col].tolist()  # shortest repr round-trips every double


# ------------------------------------------------------------------------------------------------ truncation


def test_truncated_mcap_reads_up_to_the_cut_with_a_non_seeking_reader(streams, tmp_path):
    full = write_mcap(tmp_path / "full.mcap", streams, chunk_size=2048)
    with open(full, "rb") as f:
        complete = [(c.topic, m.log_time, m.data) for _, c, m in make_reader(f).iter_messages(log_time_order=False)]
    cut = truncate(full, 0.6, dest=tmp_path / "cut.mcap")
    assert cut.stat().st_size == int(full.stat().st_size * 0.6)
    assert full.stat().st_size > cut.stat().st_size  # dest leaves the original untouched

    # The seeking reader (what make_reader gives for a file) needs the footer/summary: it fails at once.
    with open(cut, "rb") as f, pytest.raises(McapError):
        list(make_reader(f).iter_messages())
    # rosbags' MCAP storage needs the end magic too.
    with pytest.raises(AnyReaderError, match="magic"):
        AnyReader([cut]).open()

    # A non-seeking reader in file order yields every message of every complete chunk, then raises at the cut.
    partial = []
    with open(cut, "rb") as f:
        reader = NonSeekingReader(f, decoder_factories=[Ros2DecoderFactory()])
        with pytest.raises((McapError, struct.error)):
            for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
                partial.append((channel.topic, message.log_time, message.data))
                assert decoded.header.frame_id
    assert 0.4 * len(complete) < len(partial) < 0.7 * len(complete)
    assert partial == complete[: len(partial)]  # an exact prefix: nothing lost before the last whole chunk


def test_truncated_ros1_bag_looks_like_a_crashed_recorder(streams, tmp_path):
    full = write_ros1_bag(tmp_path / "full.bag", streams)
    cut = truncate(full, 0.5, dest=tmp_path / "cut.bag")
    head = cut.read_bytes()[:4096]
    at = head.index(b"index_pos=") + len(b"index_pos=")
    assert head[at:at + 8] == bytes(8)  # as `rosbag record` leaves a .bag.active
    with pytest.raises(AnyReaderError, match="not indexed"):
        AnyReader([cut]).open()
    plain = truncate(full, 0.5, dest=tmp_path / "plain.bag", crash=False)
    with pytest.raises(AnyReaderError, match="damaged"):
        AnyReader([plain]).open()


def test_crashed_ros2_sqlite_bag_reads_from_the_db3(streams, tmp_path):
    bag = write_ros2_bag(tmp_path / "bag", streams)
    crashed = truncate(bag, 1.0, dest=tmp_path / "crashed")
    assert not (crashed / "metadata.yaml").exists() and (bag / "metadata.yaml").exists()
    with pytest.raises(FileNotFoundError):
        AnyReader([crashed]).open()
    got, types, counts, order = _read_any(crashed / "bag.db3")  # the storage file alone holds everything
    check_all(streams, got, types, order)
    cut = truncate(bag, 0.5, dest=tmp_path / "cut")
    with pytest.raises(AnyReaderError, match="malformed"):
        AnyReader([cut / "bag.db3"]).open()


def test_truncate_in_place_and_bounds(tmp_path):
    p = tmp_path / "x.csv"
    p.write_bytes(b"0123456789")
    assert truncate(p, 0.35) == p and p.read_bytes() == b"012"
    for bad in (0.0, 1.5):
        with pytest.raises(ValueError):
            truncate(p, bad)


# ------------------------------------------------------------------------------------------------ atomicity, validation


def test_failed_writes_leave_the_old_file_and_no_debris(streams, tmp_path, monkeypatch):
    import mcap.writer
    import rosbags.rosbag1
    import rosbags.rosbag2

    target = write_mcap(tmp_path / "trial.mcap", streams[:1])
    before = target.read_bytes()
    bag = write_ros2_bag(tmp_path / "bag", streams[:1])
    bag_before = sorted(os.listdir(bag))

    def boom(*args, **kwargs):
        raise RuntimeError("power cut")

    ros1 = write_ros1_bag(tmp_path / "trial.bag", streams[:1])
    ros1_before = ros1.read_bytes()

    monkeypatch.setattr(mcap.writer.Writer, "finish", boom)
    monkeypatch.setattr(rosbags.rosbag2.Writer, "write", boom)
    monkeypatch.setattr(rosbags.rosbag1.Writer, "write", boom)
    monkeypatch.setattr(pd.DataFrame, "to_csv", boom)
    with pytest.raises(RuntimeError):
        write_mcap(target, streams)
    with pytest.raises(RuntimeError):
        write_ros2_bag(bag, streams)
    with pytest.raises(RuntimeError):
        write_ros1_bag(ros1, streams)
    with pytest.raises(RuntimeError):
        write_csv(tmp_path / "new.csv", streams[0].table)
    assert target.read_bytes() == before
    assert ros1.read_bytes() == ros1_before
    assert sorted(os.listdir(bag)) == bag_before
    assert sorted(os.listdir(tmp_path)) == ["bag", "trial.bag", "trial.mcap"]
    monkeypatch.undo()
    write_ros2_bag(bag, streams)  # replacing an existing bag directory
    _, _, counts, _ = _read_any(bag)
    assert counts == {s.topic: len(s.table) for s in streams}


def test_stream_validation(streams):
    imu = streams[0].table
    with pytest.raises(ValueError, match="missing columns"):
        Stream("/imu", IMU, "imu", imu.drop(columns=["wx"]))
    with pytest.raises(ValueError, match="unsupported msgtype"):
        Stream("/odom", "nav_msgs/msg/Odometry", "odom", imu)
    with pytest.raises(ValueError, match="or none"):
        Stream("/imu", IMU, "imu", imu.drop(columns=["qw"]))
    naive = imu.assign(time=imu["time"].dt.tz_localize(None))
    with pytest.raises(ValueError, match="UTC"):
        write_mcap("/nonexistent/never.mcap", [Stream("/imu", IMU, "imu", naive)])
    with pytest.raises(ValueError, match="one stream only"):
        write_mcap("/nonexistent/never.mcap", [streams[0], streams[0]])
    assert Stream("/imu", "sensor_msgs/Imu", "imu", imu).msgtype == IMU
    assert math.isnan(streams[3].table["y"].iloc[10])


def test_empty_stream_and_ros1_spelling(streams, tmp_path):
    empty = Stream("/imu/empty", IMU, "imu", streams[0].table.iloc[:0])
    path = write_mcap(tmp_path / "e.mcap", [empty, streams[2]])
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert sorted(c.topic for c in summary.channels.values()) == ["/gnss/fix", "/imu/empty"]
    assert summary.statistics.message_count == len(streams[2].table)
    with pytest.raises(ValueError, match="var_pos"):
        Stream("/fix", NSF, "gnss", streams[2].table.drop(columns=["var_pos"]))


def test_cdr_bytes_equal_mcap_ros2_own_encoder(streams, tmp_path):
    """Two independent CDR encoders (rosbags typestore here, mcap_ros2's dynamic one) give the same bytes."""
    import io

    from mcap.writer import CompressionType
    from mcap_ros2.writer import Writer as Ros2Writer

    path = write_mcap(tmp_path / "trial.mcap", streams)
    ours, buf = [], io.BytesIO()
    ref = Ros2Writer(buf, compression=CompressionType.NONE)
    schemas = {}
    with open(path, "rb") as f:
        msgs = make_reader(f, decoder_factories=[Ros2DecoderFactory()]).iter_decoded_messages(log_time_order=False)
        for i, (schema, channel, message, decoded) in enumerate(msgs):
            if schema.id not in schemas:
                schemas[schema.id] = ref.register_msgdef(schema.name, schema.data.decode())
            ref.write_message(channel.topic, schemas[schema.id], decoded, log_time=message.log_time, sequence=i)
            ours.append(message.data)
    ref.finish()
    buf.seek(0)
    theirs = [m.data for _, _, m in make_reader(buf).iter_messages(log_time_order=False)]
    assert len(ours) == sum(len(s.table) for s in streams)
    assert theirs == ours


@pytest.mark.parametrize("ros1", [False, True])
def test_imu_rows_are_the_typestore_bytes(streams, monkeypatch, ros1):
    """The fixed-layout IMU encoder (numpy, a block at a time) gives every message byte for byte as the typestore
    serialises it, across block edges, with NaN samples, absent orientation and "not provided" covariances."""
    from seatune.simulate import log_writers as lw

    monkeypatch.setattr(lw._ImuRows, "BLOCK", 64)  # several blocks, read out of order below
    ts = lw._typestore(ros1)
    imu = streams[0].table.copy()
    imu.loc[7, "wx"] = np.nan
    imu.loc[11, "var_w"] = -1.0
    for stream in (replace_table(streams[0], imu), streams[1]):
        p = lw._prepare([stream])[0]
        rows = lw._serialize(ts, p, ros1)
        assert isinstance(rows, lw._ImuRows)  # the fast path was taken, not the fallback
        reference = lw._serialize_each(ts, p, ros1)
        order = np.r_[np.arange(len(reference))[::-1], np.arange(len(reference))]
        assert [rows[int(r)] for r in order] == [reference[int(r)] for r in order]


def replace_table(stream: Stream, table: pd.DataFrame) -> Stream:
    return Stream(stream.topic, stream.msgtype, stream.frame_id, table)
