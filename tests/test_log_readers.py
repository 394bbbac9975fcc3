"""seatune.io.log_readers on genuine files: the simulator's writers (seatune.simulate.log_writers) and files written
here directly with rosbags' and mcap's own writers.

Expected tables are built from the input arrays (the independent source): stamps and log times to the ns,
fields bit-exact, "orientation not provided" as NaN, rows in receive (log-time) order. Every format must give
exactly these tables.
"""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest
from rosbags.typesys import Stores, get_typestore

from seatune.errors import UserError
from seatune.io import log_readers as lr
from seatune.io.log_readers import LogContents, detect_format, read_log, read_table_log
from seatune.pipeline.motions import imu_motions
from seatune.simulate.log_writers import Stream, truncate, write_csv, write_mcap, write_ros1_bag, write_ros2_bag

T0 = pd.Timestamp("2024-05-01T12:00:00Z")
IMU, FIX, TWIST, VEC3, ODOM, POINT = ("sensor_msgs/msg/Imu", "sensor_msgs/msg/NavSatFix",
                                      "geometry_msgs/msg/TwistStamped", "geometry_msgs/msg/Vector3Stamped",
                                      "nav_msgs/msg/Odometry", "geometry_msgs/msg/PointStamped")
FIELDS = {IMU: ["qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az"],
          FIX: ["latitude", "longitude", "altitude", "status"], TWIST: ["vx", "vy", "vz", "wx", "wy", "wz"],
          VEC3: ["x", "y", "z"], POINT: ["x", "y", "z"],
          ODOM: ["x", "y", "z", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "wx", "wy", "wz"]}


def _times(ns) -> pd.Series:
    return pd.Series(T0 + pd.to_timedelta(np.asarray(ns, dtype=np.int64), unit="ns"))


def _stamps(n: int, period_ns: int, seed: int) -> np.ndarray:
    """Regular stamps with odd ns, a repeated stamp, a swapped pair and a gap (defects the reader keeps)."""
    t = np.arange(n, dtype=np.int64) * period_ns + 123_457 + seed
    t[n // 2:] += 5 * period_ns
    t[n // 3] = t[n // 3 - 1]
    t[n // 4], t[n // 4 + 1] = t[n // 4 + 1], t[n // 4]
    return t


@pytest.fixture(scope="module")
def streams() -> list[Stream]:
    rng = np.random.default_rng(7)
    n = 400
    t = _stamps(n, 100_000_000, 0)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    imu = pd.DataFrame({
        "time": _times(t), "log_time": _times(np.arange(n) * 100_000_000 + 5_000_000 + (t - t[0]) % 7),
        "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3],
        **{c: rng.normal(size=n) for c in ("wx", "wy", "wz", "ax", "ay")}, "az": 9.81 + rng.normal(size=n),
        "var_q": 1e-6, "var_w": 1e-5, "var_a": 1e-4,
    })
    imu.loc[7, "wx"] = np.nan  # a NaN sample stays NaN
    t2 = _stamps(120, 100_000_000, 3)
    raw = pd.DataFrame({"time": _times(t2), **{c: rng.normal(size=120) for c in ("wx", "wy", "wz", "ax", "ay", "az")}})
    tg = _stamps(40, 1_000_000_000, 11)
    fix = pd.DataFrame({"time": _times(tg), "log_time": _times(tg + 40_000_000),
                        "latitude": 60.39 + rng.normal(0, 1e-4, 40), "longitude": 5.32 + rng.normal(0, 1e-4, 40),
                        "altitude": rng.normal(45.0, 0.5, 40), "status": np.where(np.arange(40) == 5, -1, 0),
                        "var_pos": 2.25})
    vel = pd.DataFrame({"time": _times(tg), **{c: rng.normal(size=40) for c in ("vx", "vy", "vz", "wx", "wy", "wz")}})
    vec = pd.DataFrame({"time": _times(_stamps(30, 500_000_000, 5)), **{c: rng.normal(size=30) for c in "xyz"}})
    return [Stream("/imu/data", IMU, "imu_link", imu), Stream("/imu/raw", IMU, "imu_raw_link", raw),
            Stream("/gnss/fix", FIX, "gnss", fix), Stream("/gnss/vel", TWIST, "enu", vel),
            Stream("/wave/radar", VEC3, "radar", vec)]


def expected(stream: Stream, receive_order: bool = True) -> pd.DataFrame:
    """The table a reader must return, from the stream's own table (rows in log-time order, or file order)."""
    t = stream.table
    log = t["log_time"] if "log_time" in t else t["time"]
    df = pd.DataFrame({"time": t["time"].reset_index(drop=True), "log_time": log.reset_index(drop=True)})
    for c in FIELDS[stream.msgtype]:
        if c in t:
            df[c] = t[c].to_numpy(dtype=np.int8 if c == "status" else np.float64)
        elif c == "status":
            df[c] = np.zeros(len(t), dtype=np.int8)
        else:  # Imu without orientation (covariance[0] = -1), NavSatFix without altitude
            df[c] = np.nan
    if not receive_order:
        return df
    order = np.argsort(log.astype("int64").to_numpy(), kind="stable")
    return df.iloc[order].reset_index(drop=True)


def assert_log_matches(log: LogContents, streams: list[Stream]) -> None:
    assert set(log.topics) == {s.topic for s in streams}
    for s in streams:
        tt = log.topics[s.topic]
        assert (tt.msgtype, tt.frame_id) == (s.msgtype, s.frame_id)
        pd.testing.assert_frame_equal(tt.table, expected(s), check_exact=True)


@pytest.fixture(scope="module")
def written(streams, tmp_path_factory) -> dict:
    d = tmp_path_factory.mktemp("logs")
    return {
        "mcap": write_mcap(d / "trial.mcap", streams, chunk_size=4096, message_index=False),
        "mcap-ros1-lz4": write_mcap(d / "trial_ros1.mcap", streams, profile="ros1", compression="lz4",
                                    chunk_size=4096),
        "mcap-none": write_mcap(d / "trial_none.mcap", streams, compression="none", chunk_size=4096),
        "ros1": write_ros1_bag(d / "trial.bag", streams, chunk_size=8192),
        "ros1-bz2": write_ros1_bag(d / "trial_bz2.bag", streams, compression="bz2", chunk_size=8192),
        "ros1-lz4": write_ros1_bag(d / "trial_lz4.bag", streams, compression="lz4", chunk_size=8192),
        "ros2-sqlite3": write_ros2_bag(d / "bag_sqlite", streams),
        "ros2-mcap": write_ros2_bag(d / "bag_mcap", streams, storage="mcap"),
    }


# ------------------------------------------------------------------------------------------- every format


@pytest.mark.parametrize("kind", ["mcap", "mcap-ros1-lz4", "mcap-none", "ros1", "ros1-bz2", "ros1-lz4",
                                  "ros2-sqlite3", "ros2-mcap"])
def test_every_format_gives_the_same_tables(streams, written, kind):
    log = read_log(written[kind])
    assert log.format == {"mcap": "mcap", "ros1": "ros1bag", "ros2": "ros2bag"}[kind.split("-")[0]]
    assert not log.truncated and log.warnings == []
    assert_log_matches(log, streams)


def test_detect_format_reads_the_content_not_the_name(written, streams, tmp_path):
    swapped = {"mcap": tmp_path / "looks_like.bag", "ros1": tmp_path / "looks_like.mcap"}
    shutil.copy(written["mcap"], swapped["mcap"])
    shutil.copy(written["ros1"], swapped["ros1"])
    assert detect_format(swapped["mcap"]) == "mcap"
    assert detect_format(swapped["ros1"]) == "ros1bag"
    assert_log_matches(read_log(swapped["ros1"]), streams)  # a ROS1 bag without the .bag suffix
    assert detect_format(written["ros2-sqlite3"]) == "ros2bag"
    assert detect_format(written["ros2-sqlite3"] / "bag_sqlite.db3") == "ros2bag"
    csv = write_csv(tmp_path / "imu.txt", streams[1].table)
    assert detect_format(csv) == "csv"
    pq = tmp_path / "imu.csv"
    streams[1].table.to_parquet(pq)
    assert detect_format(pq) == "parquet"


def test_bare_db3_and_crashed_ros2_bags(streams, written, tmp_path):
    assert_log_matches(read_log(written["ros2-sqlite3"] / "bag_sqlite.db3"), streams)
    for kind in ("ros2-sqlite3", "ros2-mcap"):  # recorder died: no metadata.yaml, storage intact up to the end
        crashed = truncate(written[kind], 1.0, dest=tmp_path / f"crashed_{kind}")
        log = read_log(crashed)
        assert any("metadata.yaml missing" in w for w in log.warnings)
        assert_log_matches(log, streams)


def test_topic_selection(streams, written):
    log = read_log(written["mcap"], topics=["/imu/raw", "/gnss/fix"])
    assert set(log.topics) == {"/imu/raw", "/gnss/fix"}
    assert_log_matches(log, [streams[1], streams[2]])
    with pytest.raises(UserError, match="not in the log"):
        read_log(written["ros1"], topics=["/no/such"])


# ------------------------------------------------------------------------------------------- direct writers


def _messages(ts, ros1: bool, n: int, seed: int) -> dict:
    """Imu, Odometry, PointStamped messages of a typestore, and the tables they must read back as."""
    rng = np.random.default_rng(seed)
    T = ts.types
    Time, Header, V3, Q, P = (T[k] for k in ("builtin_interfaces/msg/Time", "std_msgs/msg/Header",
                                             "geometry_msgs/msg/Vector3", "geometry_msgs/msg/Quaternion",
                                             "geometry_msgs/msg/Point"))
    stamp = np.arange(n, dtype=np.int64) * 50_000_000 + 987_654_321 + 1_714_564_800 * 10**9
    stamp[3] = stamp[2]  # duplicated stamp, kept by the reader
    log = stamp + 2_000_000

    def header(i, frame):
        sec, nsec = divmod(int(stamp[i]), 10**9)
        kw = {"seq": i} if ros1 else {}
        return Header(**kw, stamp=Time(sec=sec, nanosec=nsec), frame_id=frame)

    v = rng.normal(size=(n, 16))
    q = v[:, :4] / np.linalg.norm(v[:, :4], axis=1, keepdims=True)
    cov9, cov36 = np.zeros(9), np.zeros(36)
    imu, odom, point = [], [], []
    for i in range(n):
        imu.append(T[IMU](header=header(i, "imu_ned" if i != 5 else "imu_ned2"),
                          orientation=Q(x=q[i, 0], y=q[i, 1], z=q[i, 2], w=q[i, 3]), orientation_covariance=cov9,
                          angular_velocity=V3(x=v[i, 4], y=v[i, 5], z=v[i, 6]), angular_velocity_covariance=cov9,
                          linear_acceleration=V3(x=v[i, 7], y=v[i, 8], z=v[i, 9]),
                          linear_acceleration_covariance=cov9))
        pose = T["geometry_msgs/msg/PoseWithCovariance"](
            pose=T["geometry_msgs/msg/Pose"](position=P(x=v[i, 10], y=v[i, 11], z=v[i, 12]),
                                             orientation=Q(x=q[i, 0], y=q[i, 1], z=q[i, 2], w=q[i, 3])),
            covariance=cov36)
        twist = T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](linear=V3(x=v[i, 13], y=v[i, 14], z=v[i, 15]),
                                               angular=V3(x=v[i, 4], y=v[i, 5], z=v[i, 6])), covariance=cov36)
        odom.append(T[ODOM](header=header(i, "odom"), child_frame_id="base_link", pose=pose, twist=twist))
        point.append(T[POINT](header=header(i, "map"), point=P(x=v[i, 10], y=v[i, 11], z=v[i, 12])))
    base = {"time": _times(stamp - T0.value), "log_time": _times(log - T0.value)}
    want = {
        "/imu": pd.DataFrame({**base, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3],
                              **{c: v[:, k] for c, k in zip(("wx", "wy", "wz", "ax", "ay", "az"), range(4, 10),
                                                           strict=True)}}),
        "/odom": pd.DataFrame({**base, "x": v[:, 10], "y": v[:, 11], "z": v[:, 12], "qx": q[:, 0], "qy": q[:, 1],
                               "qz": q[:, 2], "qw": q[:, 3], "vx": v[:, 13], "vy": v[:, 14], "vz": v[:, 15],
                               "wx": v[:, 4], "wy": v[:, 5], "wz": v[:, 6]}),
        "/point": pd.DataFrame({**base, "x": v[:, 10], "y": v[:, 11], "z": v[:, 12]}),
    }
    text = [T["std_msgs/msg/String"](data=f"note {i}") for i in range(3)]
    return {"msgs": {"/imu": (IMU, imu), "/odom": (ODOM, odom), "/point": (POINT, point),
                     "/note": ("std_msgs/msg/String", text)}, "log": log, "want": want}


def _write_ros1_mcap(path, data, ts):
    """A ROS1-profile MCAP written with mcap's own Writer: ros1msg schemas, ros1 message encoding."""
    from mcap.writer import Writer

    with open(path, "wb") as f:
        w = Writer(f, chunk_size=2048)
        w.start(profile="ros1", library="test")
        ids = {}
        for topic, (msgtype, _) in data["msgs"].items():
            msgdef, md5 = ts.generate_msgdef(msgtype, ros_version=1)
            sid = w.register_schema(name=msgtype.replace("/msg/", "/"), encoding="ros1msg", data=msgdef.encode())
            ids[topic] = w.register_channel(topic=topic, message_encoding="ros1", schema_id=sid,
                                            metadata={"md5sum": md5})
        for i, t in enumerate(data["log"].tolist()):
            for topic, (msgtype, msgs) in data["msgs"].items():
                if i < len(msgs):
                    w.add_message(ids[topic], log_time=t, publish_time=t, sequence=i,
                                  data=bytes(ts.serialize_ros1(msgs[i], msgtype)))
        w.finish()
    return path


def _write_rosbags(path, data, ts, ros1: bool):
    """A ROS1 bag or a ROS2 bag with MCAP storage written with rosbags' own writers."""
    if ros1:
        from rosbags.rosbag1 import Writer

        writer = Writer(path)
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    with writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=ts)
                 for topic, (msgtype, _) in data["msgs"].items()}
        for i, t in enumerate(data["log"].tolist()):
            for topic, (msgtype, msgs) in data["msgs"].items():
                if i < len(msgs):
                    raw = ts.serialize_ros1(msgs[i], msgtype) if ros1 else ts.serialize_cdr(msgs[i], msgtype)
                    writer.write(conns[topic], t, bytes(raw))
    return path


def test_direct_writers_odometry_pointstamped_ros1_mcap(tmp_path):
    ros1, ros2 = get_typestore(Stores.ROS1_NOETIC), get_typestore(Stores.ROS2_HUMBLE)
    d1, d2 = _messages(ros1, True, 60, 1), _messages(ros2, False, 60, 1)
    logs = [read_log(_write_ros1_mcap(tmp_path / "ros1.mcap", d1, ros1)),
            read_log(_write_rosbags(tmp_path / "direct.bag", d1, ros1, ros1=True)),
            read_log(_write_rosbags(tmp_path / "direct_ros2", d2, ros2, ros1=False))]
    assert [g.format for g in logs] == ["mcap", "ros1bag", "ros2bag"]
    for log in logs:
        assert set(log.topics) == {"/imu", "/odom", "/point"}
        assert any("std_msgs/msg/String" in w and "/note" in w for w in log.warnings)  # skipped, and said so
        assert any("several frame_ids" in w for w in log.warnings)  # 'imu_ned2' on one message
        for topic, want in d1["want"].items():
            pd.testing.assert_frame_equal(log.topics[topic].table, want, check_exact=True)
        assert log.topics["/odom"].msgtype == ODOM and log.topics["/odom"].frame_id == "odom"
        assert log.topics["/odom"].table.attrs["child_frame_id"] == "base_link"
        assert log.topics["/point"].msgtype == POINT and log.topics["/imu"].frame_id == "imu_ned"


def test_vectorised_and_message_by_message_decoders_agree(monkeypatch):
    """The block decoder (NumPy structured views) against the typestore's deserializer, for every type and both
    encodings, including varying frame_id lengths in one block of payloads (grouped by length)."""
    for store, enc, ros1 in ((Stores.ROS2_HUMBLE, "cdr", False), (Stores.ROS1_NOETIC, "ros1", True)):
        ts = get_typestore(store)
        data = _messages(ts, ros1, 20, 2)
        for topic, (msgtype, msgs) in data["msgs"].items():
            if topic == "/note":
                continue
            ser = ts.serialize_ros1 if ros1 else ts.serialize_cdr
            raws = [bytes(ser(m, msgtype)) for m in msgs]
            slow = lr._finish(lr._decode_slow(raws, msgtype, enc), msgtype)
            with monkeypatch.context() as mp:  # the fast path only, also for the odd frame_id of message 5
                mp.setattr(lr, "_decode_slow", None)
                fast = lr._decode(raws, msgtype, enc)
            assert fast["keep"] is None
            for c in (*lr.MSGTYPES[msgtype], "stamp"):
                np.testing.assert_array_equal(fast[c], slow[c], err_msg=f"{enc} {msgtype} {c}")
            assert fast["frames"] == slow["frames"]
    ts = get_typestore(Stores.ROS2_HUMBLE)
    msgs = _messages(ts, False, 6, 3)["msgs"]["/imu"][1]
    raws = [bytes(ts.serialize_cdr(m, IMU)) for m in msgs]
    raws[2] = raws[2][:40]  # a corrupt message is skipped and counted, the others read
    out = lr._decode(raws, IMU, "cdr")
    assert out["keep"].tolist() == [True, True, False, True, True, True]
    assert len(out["qx"]) == 5


# ------------------------------------------------------------------------------------------- cut short


def _prefix_check(log: LogContents, streams: list[Stream], full_counts: dict[str, int]) -> None:
    """Read up to the cut: every topic is an exact prefix (in receive order) of the complete table."""
    total = sum(full_counts.values())
    got = sum(len(t.table) for t in log.topics.values())
    assert log.truncated
    assert 0.4 * total <= got < total
    for s in streams:
        if s.topic in log.topics:
            tab = log.topics[s.topic].table
            pd.testing.assert_frame_equal(tab, expected(s).iloc[: len(tab)], check_exact=True)


@pytest.mark.parametrize("kind", ["mcap", "mcap-ros1-lz4", "mcap-none", "ros1", "ros1-bz2", "ros1-lz4",
                                  "ros2-sqlite3", "ros2-mcap"])
@pytest.mark.parametrize("crash", [True, False])
def test_cut_short_logs_are_read_up_to_the_cut(streams, written, tmp_path, kind, crash):
    src = written[kind]
    dest = tmp_path / (src.name if src.is_dir() else f"cut{src.suffix}")
    cut = truncate(src, 0.5, dest=dest, crash=crash)
    log = read_log(cut)
    _prefix_check(log, streams, {s.topic: len(s.table) for s in streams})
    first = log.warnings[0]
    assert first.startswith(f"{cut.name}: ") and "messages up to 2024-05-01T" in first
    assert "cut short" in first or "damaged" in first


def test_unindexed_bag_scanner_equals_rosbags(streams, written):
    """The record scanner used for unindexed bags gives what rosbags gives for the indexed bag."""
    for kind in ("ros1", "ros1-bz2", "ros1-lz4"):
        res = lr._Result(written[kind], None)
        lr._scan_ros1_bag(written[kind], res)
        assert not res.truncated
        for s in streams:
            tab = res.sinks[s.topic].table(str(written[kind]), [])
            pd.testing.assert_frame_equal(tab.table, expected(s), check_exact=True)


# ------------------------------------------------------------------------------------------- CSV / Parquet


@pytest.mark.parametrize("time_format", ["iso", "unix"])
def test_csv_gives_the_bag_tables(streams, written, tmp_path, time_format):
    bag = read_log(written["ros1"])
    imu = streams[0].table.drop(columns=["log_time", "var_q", "var_w", "var_a"])
    log = read_log(write_csv(tmp_path / "imu.csv", imu, time_format=time_format))
    got = log.topics["/imu/imu"].table
    # a CSV has no receive time: rows in file order, log_time = time; here file order = receive order
    want = bag.topics["/imu/data"].table.assign(log_time=lambda d: d["time"])
    pd.testing.assert_frame_equal(got, want, check_exact=True)
    pd.testing.assert_frame_equal(got, expected(Stream("/imu", IMU, "", imu), receive_order=False), check_exact=True)
    assert log.topics["/imu/imu"].msgtype == IMU


def test_csv_gnss_export_with_aliases_and_parquet(tmp_path, streams):
    fix, vel = streams[2].table, streams[3].table
    table = fix[["time", "latitude", "longitude", "altitude"]].rename(columns={"latitude": "lat", "longitude": "lon"})
    table["vel_east"], table["vel_north"] = vel["vx"].to_numpy(), vel["vy"].to_numpy()
    table["source"] = "rtk"  # a text column that is no seatune field: not read, and said so
    log = read_log(write_csv(tmp_path / "gnss.csv", table))
    assert set(log.topics) == {"/gnss/fix", "/gnss/vel"}
    f = log.topics["/gnss/fix"].table
    np.testing.assert_array_equal(f["latitude"], fix["latitude"])
    np.testing.assert_array_equal(f["status"], np.zeros(len(fix), dtype=np.int8))
    np.testing.assert_array_equal(log.topics["/gnss/vel"].table["vy"], vel["vy"])
    assert any("'source'" in w for w in log.warnings)

    pq = tmp_path / "motion.parquet"
    ms = (fix["time"].astype("int64") // 1_000_000).to_numpy()  # Unix ms as integers, other column names
    pd.DataFrame({"t_ms": ms, "GyroX": vel["wx"], "GyroY": vel["wy"], "GyroZ": vel["wz"], "AccX": vel["vx"],
                  "AccY": vel["vy"], "AccZ": vel["vz"]}).to_parquet(pq)
    cmap = {"GyroX": "wx", "GyroY": "wy", "GyroZ": "wz", "AccX": "ax", "AccY": "ay", "AccZ": "az"}
    tt = read_table_log(pq, time_column="t_ms", column_map=cmap)
    assert tt.msgtype == IMU
    assert tt.table["time"].astype("int64").tolist() == (ms * 1_000_000).tolist()
    assert any("in ms" in w for w in tt.table.attrs["warnings"])
    tt2 = read_table_log(pq, time_column="t_ms", column_map=cmap, time_format="unix_ms")
    pd.testing.assert_series_equal(tt2.table["time"], tt.table["time"])
    np.testing.assert_array_equal(tt.table["az"], vel["vz"])


# ------------------------------------------------------------------------------------------- bad input


def _one_line(err: pytest.ExceptionInfo, path) -> str:
    text = str(err.value)
    assert "\n" not in text and str(path) in text
    return text


def test_malformed_corpus(tmp_path, streams, written):
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(UserError) as e:
        read_log(empty)
    assert "empty file" in _one_line(e, empty)

    noise = tmp_path / "noise.mcap"
    noise.write_bytes(np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8).tobytes())
    with pytest.raises(UserError) as e:
        read_log(noise)
    assert "unknown log format" in _one_line(e, noise)

    fake = tmp_path / "fake.mcap"  # MCAP magic, then garbage: nothing readable
    fake.write_bytes(lr._MCAP_MAGIC + b"\x01" + bytes(40))
    with pytest.raises(UserError) as e:
        read_log(fake)
    assert "nothing readable" in _one_line(e, fake)

    head = tmp_path / "head.bag"  # a bag cut inside its header record
    head.write_bytes(written["ros1"].read_bytes()[:200])
    with pytest.raises(UserError) as e:
        read_log(head)
    assert "nothing readable" in _one_line(e, head)

    csv = tmp_path / "bad.csv"
    csv.write_text("time,wx,wy,wz,ax,ay,az\n"
                   "2024-05-01T12:00:00Z,0.1,0.2,0.3,0.0,0.0,9.8\n"
                   "2024-05-01T12:00:00.1Z,0.1,n/a,0.3,0.0,0.0,9.8\n"  # n/a is a missing value, not text
                   "2024-05-01T12:00:00.2Z,0.1,0.2,ERR,0.0,0.0,9.8\n")
    with pytest.raises(UserError) as e:
        read_log(csv)
    assert "column 'wz', line 4" in _one_line(e, csv) and "'ERR'" in str(e.value)

    badtime = tmp_path / "badtime.csv"
    badtime.write_text("time,wx,wy,wz\n2024-05-01T12:00:00Z,1,2,3\nyesterday,1,2,3\n")
    with pytest.raises(UserError) as e:
        read_log(badtime)
    assert "column 'time', line 3" in _one_line(e, badtime)

    no_imu = write_ros1_bag(tmp_path / "gnss_only.bag", [streams[2]])
    log = read_log(no_imu)
    assert log.of_type(IMU) == [] and set(log.topics) == {"/gnss/fix"}
    with pytest.raises(UserError) as e:
        imu_motions(log)
    assert "no sensor_msgs/Imu topic" in _one_line(e, no_imu)

    with pytest.raises(UserError) as e:
        read_log(tmp_path / "missing.bag")
    _one_line(e, tmp_path / "missing.bag")
    empty_dir = tmp_path / "empty_dir"
    empty_dir.mkdir()
    with pytest.raises(UserError) as e:
        read_log(empty_dir)
    _one_line(e, empty_dir)


def test_benchmark_function_runs(written, streams):
    out = lr.benchmark_mcap(written["mcap"])
    assert out["identical"]
    assert out["messages"] == out["plain_messages"] == sum(len(s.table) for s in streams)
    assert out["seatune_msgs_per_s"] > 0 and out["plain_msgs_per_s"] > 0


# ------------------------------------------------------------------------------------------- issue 19


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_tf_static_is_read_as_the_sensors_mounting(tmp_path, storage):
    """/tf_static (tf2_msgs/TFMessage, CDR) written with rosbags' rosbag2 Writer: every transform comes back with
    its frames and values; /tf (moving frames) is listed among the topics not read."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    stamp = T["builtin_interfaces/msg/Time"](sec=1_714_564_800, nanosec=5)
    given = [("base_link", "imu_link", (0.5, -0.25, 3.0), (0.0, 0.0, np.sqrt(0.5), np.sqrt(0.5))),
             ("base_link", "gnss", (10.0, 0.0, 12.0), (0.0, 0.0, 0.0, 1.0))]
    msg = T["tf2_msgs/msg/TFMessage"](transforms=[T["geometry_msgs/msg/TransformStamped"](
        header=T["std_msgs/msg/Header"](stamp=stamp, frame_id=parent), child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](translation=T["geometry_msgs/msg/Vector3"](x=t[0], y=t[1], z=t[2]),
                                                   rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2],
                                                                                              w=q[3])))
        for parent, child, t, q in given])
    raw = ts.serialize_cdr(msg, "tf2_msgs/msg/TFMessage")
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(tmp_path / "bag", version=9, storage_plugin=plugin) as writer:
        for topic in ("/tf_static", "/tf"):
            conn = writer.add_connection(topic, "tf2_msgs/msg/TFMessage", typestore=ts)
            writer.write(conn, 1_714_564_800 * 10**9, raw)
    log = read_log(tmp_path / "bag")
    got = {(s.parent, s.child): (s.translation, s.rotation) for s in log.static_transforms}
    assert got == {(p, c): (t, q) for p, c, t, q in given}
    assert log.skipped == {"/tf": "tf2_msgs/msg/TFMessage"} and log.topics == {}


def test_csv_declared_units_are_converted_and_motion_names_read_as_imu_fields(tmp_path):
    t = pd.date_range("2024-05-01T12:00:00Z", periods=5, freq="100ms")
    df = pd.DataFrame({"t": t.strftime("%Y-%m-%dT%H:%M:%S.%fZ"), "gyro_x": [1.0, 2.0, -3.5, 0.0, 90.0],
                       "acc_z": [1.0, 0.98, 1.02, 1.0, 0.5], "roll_rate": 0.25, "sog_kn": 10.0})
    path = tmp_path / "mru.csv"
    df.to_csv(path, index=False)
    tt = read_table_log(path, time_column="t", column_map={"gyro_x": "pitch_rate", "acc_z": "imu_fz", "sog_kn": "sog"},
                        column_units={"gyro_x": "deg/s", "acc_z": "g", "sog_kn": "knots", "absent": "deg"})
    assert tt.table["wy"].tolist() == (df["gyro_x"] * (np.pi / 180)).tolist()  # the definitions, exactly
    assert tt.table["az"].tolist() == (df["acc_z"] * 9.80665).tolist()
    assert tt.table["sog"].tolist() == (df["sog_kn"] * (1852 / 3600)).tolist()
    assert tt.table["wx"].tolist() == [0.25] * 5  # an undeclared column is read as it is
    assert tt.table.attrs["declared_units"] == {"wy": "deg/s", "az": "g", "sog": "knots"}
    assert tt.table.attrs["log_columns"]["wy"] == "gyro_x" and tt.table.attrs["log_columns"]["wx"] == "roll_rate"
    log = read_log(path, table_options={"time_column": "t", "column_map": {"gyro_x": "pitch_rate"},
                                        "column_units": {"gyro_x": "deg/s"}})
    assert log.topics["/mru/imu"].table.attrs["declared_units"] == {"wy": "deg/s"}
    with pytest.raises(UserError, match="'gyro_x'.*unknown unit 'rpm'"):
        read_table_log(path, time_column="t", column_units={"gyro_x": "rpm"})
