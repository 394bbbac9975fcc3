"""The corrupt-input corpus (issue 18): damaged and hostile inputs through `seatune ingest` then `seatune windows`.

Clean logs of a small drifting trial (6 min: IMU 10 Hz, NavSatFix and TwistStamped 1 Hz) are written with the
project's writers (mcap, rosbags), then damaged in a seeded way: single-bit flips at offsets drawn inside each
MCAP record kind (located with mcap's own StreamReader), 8-byte bursts of set bits (0xFF) in the header, data and
index regions of a ROS1 bag and a ROS2 .db3, truncations, unit mistakes, dead sensors, NaN bursts, wild values and
stamps, hindcasts covering part of the track, and too little data.

The rule, per input: ingest then windows exit 0 with a new warning (one the clean logs do not give), or exit 0
with the motion table of the clean log to 1 ppm (the damage hit bytes ingest does not use — a covariance, an
index — or a float's last mantissa bits), or one of them exits 2 with exactly one line on stderr; never a
traceback; a command that exits 2 leaves every file of the run directory as it was (the run directory starts
with the clean log's artefacts), and no command leaves a temporary behind.
"""

from __future__ import annotations

import hashlib
import shutil
import struct
import zlib
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from tests.conftest import ROOT

T0 = pd.Timestamp("2026-03-14T07:00:00Z")  # inside the sample hindcast (2026-03-14 05:00 to 13:00 UTC)
SECONDS = 360
HINDCAST = ROOT / "sample_logs" / "sample_trial_hindcast.csv"
G0 = 9.80665
WINDOWS = {"min_duration_s": 120, "max_duration_s": 180, "sog_smoothing_s": 10}
CLEAN = {"mcap": "trial.mcap", "mcap_raw": "trial_raw.mcap", "bag": "trial.bag", "db3": "trial_db3"}


# ----------------------------------------------------------------------------------------------- clean logs


def tables(seconds: int = SECONDS) -> dict[str, pd.DataFrame]:
    """IMU (10 Hz: roll ≈ 2.3° at 9 s, pitch ≈ 0.9° at 6.5 s), NavSatFix and TwistStamped (1 Hz) of a vessel
    drifting at 0.11 m/s off western Norway."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(18)
    n = seconds * 10
    s = np.arange(n) / 10.0
    roll = 0.04 * np.sin(2 * np.pi * s / 9.0) + rng.normal(0, 0.002, n)
    pitch = 0.015 * np.sin(2 * np.pi * s / 6.5 + 1.0) + rng.normal(0, 0.001, n)
    q = Rotation.from_euler("ZYX", np.column_stack([np.full(n, 0.6), pitch, roll])).as_quat()
    imu = pd.DataFrame({"time": T0 + pd.to_timedelta(s, unit="s"), "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2],
                        "qw": q[:, 3], "wx": np.gradient(roll, s), "wy": np.gradient(pitch, s),
                        "wz": rng.normal(0, 1e-3, n), "ax": rng.normal(0, 0.05, n), "ay": rng.normal(0, 0.05, n),
                        "az": 9.81 + rng.normal(0, 0.1, n)})
    g = np.arange(seconds, dtype=float)
    tg = T0 + pd.to_timedelta(g, unit="s")
    fix = pd.DataFrame({"time": tg, "latitude": 61.2 + 9e-7 * g, "longitude": 3.4 + 1.9e-6 * g, "altitude": 0.5})
    vel = pd.DataFrame({"time": tg, "vx": 0.05, "vy": 0.1, "vz": 0.0, "wx": 0.0, "wy": 0.0, "wz": 0.0})
    return {"imu": imu, "fix": fix, "vel": vel}


def streams(t: dict[str, pd.DataFrame]):
    from seatune.simulate.log_writers import Stream

    return [Stream("/imu/data", "sensor_msgs/msg/Imu", "imu_link", t["imu"]),
            Stream("/gnss/fix", "sensor_msgs/msg/NavSatFix", "gnss", t["fix"]),
            Stream("/gnss/vel", "geometry_msgs/msg/TwistStamped", "gnss", t["vel"])]


def write_mcap(path: Path, t=None, **kw) -> Path:
    from seatune.simulate.log_writers import write_mcap as w

    return w(path, streams(t or tables()), chunk_size=kw.pop("chunk_size", 32 * 1024), **kw)


def write_clean(folder: Path) -> dict[str, Path]:
    from seatune.simulate.log_writers import write_ros1_bag, write_ros2_bag

    folder.mkdir(parents=True, exist_ok=True)
    t = tables()
    return {"mcap": write_mcap(folder / CLEAN["mcap"], t),
            "mcap_raw": write_mcap(folder / CLEAN["mcap_raw"], t, chunk_size=64 * 1024, compression="none"),
            "bag": write_ros1_bag(folder / CLEAN["bag"], streams(t), chunk_size=128 * 1024),
            "db3": write_ros2_bag(folder / CLEAN["db3"], streams(t))}


# ----------------------------------------------------------------------------------------------- damage


def mcap_records(path: Path) -> list[tuple[str, int, int]]:
    """(record type, start, end) of every record, walked with mcap's own StreamReader (independent of seatune)."""
    from mcap.stream_reader import StreamReader

    out = []
    with open(path, "rb") as f:
        reader = StreamReader(f, emit_chunks=True)
        records = iter(reader.records)
        start = 8
        for rec in records:
            out.append((type(rec).__name__, start, f.tell()))
            start = f.tell()
    return out


def flip_bit(path: Path, offset: int, bit: int) -> None:
    b = bytearray(path.read_bytes())
    b[offset] ^= 1 << bit
    path.write_bytes(bytes(b))


def stuck_bytes(path: Path, offset: int, n: int = 8) -> None:
    """`n` bytes from `offset` set to 0xFF (a burst of bits stuck at one)."""
    b = bytearray(path.read_bytes())
    b[offset:offset + n] = b"\xff" * len(b[offset:offset + n])
    path.write_bytes(bytes(b))


def _rng(name: str) -> np.random.Generator:
    return np.random.default_rng(zlib.crc32(name.encode()))


def mcap_flip(kind: str, region: str, which: int):
    """A single-bit flip in the `which`-th draw of `region` of the clean MCAP (`kind` mcap or mcap_raw):
    Header; Chunk.length (the record's length field); Chunk.data (its compressed records); MessageIndex;
    Summary (a record after DataEnd)."""
    def make(clean, tmp):
        src = clean[kind]
        dst = tmp / src.name
        shutil.copy(src, dst)
        recs = mcap_records(src)
        data_end = next(s for k, s, _ in recs if k == "DataEnd")
        rng = _rng(f"{kind} {region} {which}")
        if region == "Chunk.length":
            pool = [(s + 1, s + 9) for k, s, e in recs if k == "Chunk"]
        elif region == "Chunk.data":
            pool = [(s + 64, e) for k, s, e in recs if k == "Chunk"]
        elif region == "Summary":
            pool = [(s, e) for k, s, e in recs if s > data_end and k != "Footer"]
        else:
            pool = [(s, e) for k, s, e in recs if k == region]
        lo, hi = pool[int(rng.integers(len(pool)))]
        flip_bit(dst, int(rng.integers(lo, hi)), int(rng.integers(8)))
        return [{"path": str(dst)}]
    return make


def every_chunk_flipped(clean, tmp):
    dst = tmp / clean["mcap"].name
    shutil.copy(clean["mcap"], dst)
    for k, s, e in mcap_records(clean["mcap"]):
        if k == "Chunk":
            flip_bit(dst, (s + e) // 2, 3)
    return [{"path": str(dst)}]


def truncated(kind: str, keep: float):
    def make(clean, tmp):
        from seatune.simulate.log_writers import truncate

        dst = tmp / clean[kind].name
        truncate(clean[kind], keep, dest=dst) if clean[kind].is_file() else truncate(
            shutil.copytree(clean[kind], dst), keep)
        return [{"path": str(dst)}]
    return make


def bag_regions(path: Path) -> dict[str, tuple[int, int]]:
    """The ROS1 bag's file-header record, its chunks and its index (connection and chunk-info records at
    index_pos, read from the file header as the bag format 2.0 lays it out)."""
    raw = path.read_bytes()
    at = raw.index(b"index_pos=") + len(b"index_pos=")
    index_pos = struct.unpack_from("<Q", raw, at)[0]
    return {"header": (13, 4096 + 13), "chunks": (4096 + 13, index_pos), "index": (index_pos, len(raw))}


def bag_burst(region: str, which: int):
    def make(clean, tmp):
        dst = tmp / clean["bag"].name
        shutil.copy(clean["bag"], dst)
        lo, hi = bag_regions(dst)[region]
        stuck_bytes(dst, int(_rng(f"bag {region} {which}").integers(lo, hi - 8)))
        return [{"path": str(dst)}]
    return make


def db3_burst(region: str, which: int):
    """SQLite's 100-byte database header, the first page (schema), or the pages after it (messages)."""
    def make(clean, tmp):
        dst = shutil.copytree(clean["db3"], tmp / clean["db3"].name)
        db = next(dst.glob("*.db3"))
        lo, hi = {"header": (0, 100), "schema": (100, 4096), "pages": (4096, db.stat().st_size)}[region]
        stuck_bytes(db, int(_rng(f"db3 {region} {which}").integers(lo, hi - 8)))
        return [{"path": str(dst)}]
    return make


# ----------------------------------------------------------------------------------------------- hostile content


def mcap_with(change):
    """The trial as MCAP with `change(tables)` applied first (a logger writing wrong data)."""
    def make(clean, tmp):
        t = tables()
        change(t)
        return [{"path": str(write_mcap(tmp / "trial.mcap", t))}]
    return make


def _set(table: str, rows, columns, value):
    def change(t):
        t[table].loc[rows, columns] = value
    return change


def _in_g(t):
    t["imu"][["ax", "ay", "az"]] /= G0


def _deg_rates(t):
    t["imu"][["wx", "wy", "wz"]] = np.degrees(t["imu"][["wx", "wy", "wz"]])


def _dead(t):
    t["imu"][["wx", "wy", "wz", "ax", "ay", "az", "qx", "qy", "qz"]] = 0.0
    t["imu"]["qw"] = 1.0


def _wild_stamp(t):
    t["imu"]["log_time"] = t["imu"]["time"]  # received on time, stamped in 2031 (a flipped bit in sec)
    t["imu"].loc[1000, "time"] = t["imu"].loc[1000, "time"] + pd.Timedelta(seconds=2**27)


def csv_logs(imu_change=None):
    """The trial as a CSV IMU export plus a GNSS CSV (no declared units)."""
    def make(clean, tmp):
        t = tables()
        if imu_change:
            imu_change(t)
        imu, fix, vel = t["imu"], t["fix"], t["vel"]
        imu.assign(time=imu["time"].dt.strftime("%Y-%m-%dT%H:%M:%S.%fZ")).to_csv(tmp / "imu.csv", index=False)
        gnss = fix[["time", "latitude", "longitude"]].assign(vel_east=vel["vx"], vel_north=vel["vy"])
        gnss.assign(time=gnss["time"].dt.strftime("%Y-%m-%dT%H:%M:%SZ")).to_csv(tmp / "gnss.csv", index=False)
        return [{"path": str(tmp / "imu.csv"), "kind": "imu"},
                {"path": str(tmp / "gnss.csv"), "kind": "gnss", "columns": {"vel_east": "vx", "vel_north": "vy"}}]
    return make


def short_log(seconds: int):
    def make(clean, tmp):
        return [{"path": str(write_mcap(tmp / "trial.mcap", tables(seconds)))}]
    return make


def partial_hindcast(hours: tuple[str, str]):
    """The sample hindcast CSV cut to [start, end] (UTC hours)."""
    def make(tmp):
        df = pd.read_csv(HINDCAST)
        t = pd.to_datetime(df["time"], utc=True)
        df = df[(t >= pd.Timestamp(hours[0], tz="UTC")) & (t <= pd.Timestamp(hours[1], tz="UTC"))]
        df.to_csv(tmp / "hindcast.csv", index=False)
        return tmp / "hindcast.csv"
    return make


def clean_mcap(clean, tmp):
    return [{"path": str(clean["mcap"])}]


# case → (logs maker, hindcast maker or None, clean format whose motions an unaffected run reproduces or None)
CASES = {
    **{f"mcap bit flip: {r} #{i}": (mcap_flip("mcap", r, i), None, "mcap")
       for r, k in (("Header", 2), ("Chunk.length", 1), ("Chunk.data", 4), ("MessageIndex", 2), ("Summary", 2))
       for i in range(k)},
    **{f"mcap (uncompressed chunks) bit flip: Chunk.data #{i}": (mcap_flip("mcap_raw", "Chunk.data", i), None,
                                                                  "mcap_raw") for i in range(3)},
    "mcap: every chunk flipped": (every_chunk_flipped, None, None),
    "mcap cut at 50 %": (truncated("mcap", 0.5), None, None),
    "mcap cut at 99.9 %": (truncated("mcap", 0.999), None, None),
    **{f"ros1 bag 0xFF burst: {r} #{i}": (bag_burst(r, i), None, "bag")
       for r, k in (("header", 2), ("chunks", 4), ("index", 2)) for i in range(k)},
    "ros1 bag cut at 60 % (recorder died)": (truncated("bag", 0.6), None, None),
    **{f"db3 0xFF burst: {r} #{i}": (db3_burst(r, i), None, "db3")
       for r, k in (("header", 1), ("schema", 1), ("pages", 4)) for i in range(k)},
    "db3 cut at 70 % (recorder died)": (truncated("db3", 0.7), None, None),
    "specific force in g (ROS)": (mcap_with(_in_g), None, None),
    "angular rates in deg/s (ROS)": (mcap_with(_deg_rates), None, None),
    "specific force in g (CSV, no unit declared)": (csv_logs(_in_g), None, None),
    "dead IMU (constant zero)": (mcap_with(_dead), None, None),
    "dead gyro (constant zero)": (mcap_with(_set("imu", slice(None), ["wx", "wy", "wz"], 0.0)), None, None),
    "NaN burst in the accelerometer (60 s)": (mcap_with(_set("imu", slice(1200, 1799), ["ax", "ay", "az"],
                                                             np.nan)), None, None),
    "NaN in the quaternion (one component)": (mcap_with(_set("imu", slice(300, 340), "qz", np.nan)), None, None),
    "specific force 1e300 in 5 messages": (mcap_with(_set("imu", [10, 500, 900, 2000, 3000], "az", 1e300)), None,
                                           None),
    "infinite angular rate": (mcap_with(_set("imu", [42, 43], "wx", np.inf)), None, None),
    "latitude out of range": (mcap_with(_set("fix", [5, 6], "latitude", 612.0)), None, None),
    "one stamp 4 years ahead": (mcap_with(_wild_stamp), None, None),
    "hindcast covering the first hour only": (clean_mcap, partial_hindcast(("2026-03-14T05:00", "2026-03-14T06:00")),
                                              None),
    "hindcast ending inside the track": (clean_mcap, partial_hindcast(("2026-03-14T05:00", "2026-03-14T07:00")),
                                         None),
    "too little data: 20 s": (short_log(20), None, None),
    "too little data: 1 s": (short_log(1), None, None),
}


# ----------------------------------------------------------------------------------------------- the rule


def run_yaml(folder: Path, logs, hindcast: Path | None = None) -> Path:
    data = {"name": "corpus", "run_dir": str(folder / "run"), "vessel": str(ROOT / "configs/vessels/sample_osv.yaml"),
            "logs": logs, "hindcast": {"path": str(hindcast or HINDCAST)}, "windows": WINDOWS}
    path = folder / "run.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def invoke(command: str, path: Path):
    from click.testing import CliRunner

    from seatune.cli import stages  # noqa: F401  (registers the commands)
    from seatune.cli.main import cli

    return CliRunner().invoke(cli, [command, str(path)])


def hashes(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()}


def warnings_of(res) -> set[str]:
    return {line for line in res.stdout.splitlines() if line.startswith("warning:")}


@pytest.fixture(scope="module")
def corpus_base(tmp_path_factory):
    """Clean logs, and per clean format the run directory, warnings and motion table of its clean run."""
    root = tmp_path_factory.mktemp("corpus")
    clean = write_clean(root / "clean")
    runs = {}
    for kind, path in clean.items():
        folder = root / f"run_{kind}"
        folder.mkdir()
        y = run_yaml(folder, [{"path": str(path)}])
        res = [invoke(c, y) for c in ("ingest", "windows")]
        assert [r.exit_code for r in res] == [0, 0], [r.output for r in res]
        assert "accepted" in res[1].stdout and " 0 of " not in res[1].stdout, res[1].stdout
        runs[kind] = {"dir": folder / "run", "warnings": warnings_of(res[0]),
                      "motions": pd.read_parquet(folder / "run" / "motions.parquet")}
    return clean, runs


@pytest.mark.parametrize("case", list(CASES))
def test_corrupt_input_warns_or_stops_in_one_line(corpus_base, tmp_path, case):
    clean, runs = corpus_base
    make_logs, make_hindcast, same_as = CASES[case]
    logs = make_logs(clean, tmp_path)
    hindcast = make_hindcast(tmp_path) if make_hindcast else None
    path = run_yaml(tmp_path, logs, hindcast)
    shutil.copytree(runs["mcap"]["dir"], tmp_path / "run")  # the earlier artefacts a bad input must not touch
    clean_warnings = set().union(*(r["warnings"] for r in runs.values()))
    outcome, warned = [], False
    for command in ("ingest", "windows"):
        before = hashes(tmp_path / "run")
        res = invoke(command, path)
        assert res.exit_code in (0, 2), (command, res.output, res.exception)
        assert res.exception is None or isinstance(res.exception, SystemExit), (command, res.exception)
        assert "Traceback" not in res.output
        assert not list((tmp_path / "run").glob(".*.tmp")), "a temporary was left behind"
        if res.exit_code == 2:
            lines = res.stderr.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("seatune: error: "), res.stderr
            assert hashes(tmp_path / "run") == before, f"{command} exited 2 but changed the run directory"
            outcome.append(f"{command} exit 2")
            break
        new = warnings_of(res) - clean_warnings
        warned |= bool(new)
        outcome.append(f"{command} exit 0" + (" warned" if new else ""))
    if not outcome[-1].endswith("exit 2") and not warned:
        motions = pd.read_parquet(tmp_path / "run" / "motions.parquet")
        assert same_as is not None and unaffected(motions, runs[same_as]["motions"]), (
            "exit 0 without a new warning, and the motions differ from the clean log's")
        outcome.append("motions as the clean log's")
    print(f"corpus outcome | {case} | {' / '.join(outcome)}")


def unaffected(motions: pd.DataFrame, clean: pd.DataFrame) -> bool:
    """The same grid and columns, every value within 1 ppm of the clean run's (damage to the low bytes of a
    float's mantissa cannot be told from the data, and changes nothing that matters)."""
    if list(motions.columns) != list(clean.columns) or len(motions) != len(clean):
        return False
    if not motions["time"].equals(clean["time"]):
        return False
    num = [c for c in clean.columns if c != "time"]
    return bool(np.allclose(motions[num].to_numpy(float), clean[num].to_numpy(float), rtol=1e-6, atol=0.0,
                            equal_nan=True))


# ----------------------------------------------------------------------------------------------- the pieces


def chunk_messages(path: Path) -> list[tuple[int, int, int]]:
    """(chunk start offset, /imu/data messages in it, message_start_time) per chunk, with mcap's own reader."""
    from mcap.records import Channel, Chunk
    from mcap.stream_reader import StreamReader, breakup_chunk

    out, imu = [], set()
    with open(path, "rb") as f:
        start = 8
        for rec in StreamReader(f, emit_chunks=True).records:
            if isinstance(rec, Chunk):
                inner = breakup_chunk(rec)
                imu |= {r.id for r in inner if isinstance(r, Channel) and r.topic == "/imu/data"}
                out.append((start, sum(getattr(r, "channel_id", None) in imu for r in inner), rec.message_start_time))
            start = f.tell()
    return out


def imu_rows(path: Path) -> tuple[int, list[str]]:
    from seatune.io.log_readers import read_log

    log = read_log(path)
    return len(log.topics["/imu/data"].table), log.warnings


def test_mcap_chunk_failing_its_crc_is_dropped_whole_and_named(tmp_path):
    clean = write_mcap(tmp_path / "clean.mcap", chunk_size=64 * 1024, compression="none")
    chunks = chunk_messages(clean)
    start, n_in_chunk, t_start = chunks[3]
    end = chunks[4][0]
    bad = tmp_path / "bad.mcap"
    shutil.copy(clean, bad)
    flip_bit(bad, (start + end) // 2, 6)  # inside a message of an uncompressed chunk: only the CRC can tell
    n_clean = sum(n for _, n, _ in chunks)
    assert imu_rows(clean) == (n_clean, [])
    n, warnings = imu_rows(bad)
    assert n == n_clean - n_in_chunk and n_in_chunk > 50
    (w,) = warnings
    when = pd.Timestamp(t_start, unit="ns", tz="UTC").strftime("%Y-%m-%d %H:%M:%S")
    assert f"bad.mcap: 1 damaged chunk(s) dropped with all their messages: byte {start:,} (messages {when}" in w
    assert w.endswith("fails its CRC")


def test_mcap_chunk_with_a_broken_length_is_stepped_over_with_the_chunk_index(tmp_path):
    clean = write_mcap(tmp_path / "clean.mcap")
    chunks = chunk_messages(clean)
    start, n_in_chunk, _ = chunks[5]
    bad = tmp_path / "bad.mcap"
    shutil.copy(clean, bad)
    flip_bit(bad, start + 8, 7)  # the top byte of the Chunk record's length: the stream cannot go on
    n, warnings = imu_rows(bad)
    assert n == sum(n for _, n, _ in chunks) - n_in_chunk  # only that chunk lost, not the rest of the file
    assert any("stepped over with the summary's chunk index" in w and f"resumed at byte {chunks[6][0]:,}" in w
               for w in warnings), warnings
    assert any(f"byte {start:,}" in w and "unreachable" in w for w in warnings), warnings


def test_mcap_data_section_crc_is_checked_where_written(tmp_path):
    """Re-written with mcap's Writer(enable_data_crcs=True); a flip in a MessageIndex record (outside every chunk)
    fails only the data-section CRC: all messages kept, one warning."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    src = write_mcap(tmp_path / "src.mcap")
    crc = tmp_path / "crc.mcap"
    with open(src, "rb") as fi, open(crc, "wb") as fo:
        reader = make_reader(fi)
        writer = Writer(fo, chunk_size=32 * 1024, compression=CompressionType.ZSTD, enable_data_crcs=True)
        writer.start(profile=reader.get_header().profile, library="test")
        ids = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if channel.id not in ids:
                sid = writer.register_schema(schema.name, schema.encoding, schema.data)
                ids[channel.id] = writer.register_channel(channel.topic, channel.message_encoding, sid,
                                                          dict(channel.metadata))
            writer.add_message(ids[channel.id], message.log_time, message.data, message.publish_time,
                               message.sequence)
        writer.finish()
    n_clean = imu_rows(crc)
    assert n_clean[1] == []
    index = [(s, e) for k, s, e in mcap_records(crc) if k == "MessageIndex"][2]
    flip_bit(crc, index[0] + 20, 2)  # a message's log time in the index: no message is affected
    n, warnings = imu_rows(crc)
    assert n == n_clean[0]
    (w,) = warnings
    assert "the data section fails its CRC" in w and "every chunk passes its own" in w


def test_plausibility_gate_masks_and_counts_per_column():
    from seatune.physics.plausibility import Limits, gate_angles, gate_topic

    t = tables(60)["imu"].assign(log_time=lambda d: d["time"])
    t.loc[[3, 4], "az"] = [5.5 * G0, -1e300]  # beyond 5 g
    t.loc[7, "ay"] = np.inf
    t.loc[9, "ax"] = np.nan  # a NaN among finite values of a ROS field
    t.loc[[11, 12, 13], "wy"] = [5.1, -7.0, 4.9]  # two beyond 5 rad/s
    t.loc[20, ["qx", "qy", "qz", "qw"]] = [0.0, 0.0, 3.0, 1.0]  # not a unit quaternion
    t.loc[30, "time"] += pd.Timedelta(days=400)  # a wild stamp
    out, counts = gate_topic(t, Limits())
    assert counts == {"az": 2, "ay": 1, "ax": 1, "wy": 2, "orientation": 1, "stamp": 1}
    assert out.loc[[3, 4], "az"].isna().all() and out.loc[5, "az"] == t.loc[5, "az"]
    assert out.loc[20, ["qx", "qy", "qz", "qw"]].isna().all() and pd.isna(out.loc[30, "time"])
    assert np.isnan(t.loc[9, "ax"]) and not np.isnan(t.loc[3, "az"])  # the input is left as it was
    _, counts = gate_topic(t, Limits(max_specific_force_g=5.6, max_rate_rad_s=4.8), messages=False)
    assert counts == {"az": 1, "ay": 1, "wy": 3, "orientation": 1, "stamp": 1}  # table log: NaN is an empty cell
    motions = pd.DataFrame({"roll": [0.1, np.radians(91.0), np.nan, -np.radians(89.0)], "pitch": [0.0, 0.0, 0.0, -2.0]})
    out, counts = gate_angles(motions, Limits())
    assert counts == {"roll": 1, "pitch": 1} and out["roll"].isna().sum() == 2


def test_plausibility_limits_from_the_run_yaml_reach_the_defect_counts(corpus_base, tmp_path):
    from seatune.io.parquet import table_metadata

    t = tables()
    t["imu"].loc[[100, 900, 1500, 2000, 2500, 3000, 3300], "az"] = 3.0 * G0
    log = write_mcap(tmp_path / "spikes.mcap", t)
    counts = {}
    for limit in (5.0, 2.0):
        y = run_yaml(tmp_path, [{"path": str(log)}])
        data = yaml.safe_load(y.read_text())
        data["ingest"] = {"plausibility": {"max_specific_force_g": limit}}
        y.write_text(yaml.safe_dump(data))
        res = invoke("ingest", y)
        assert res.exit_code == 0, res.output
        counts[limit] = table_metadata(tmp_path / "run" / "motions.parquet")["counts"]
    assert "implausible /imu/data az" not in counts[5.0]
    assert counts[2.0]["implausible /imu/data az"] == 7


def test_windows_shorter_than_the_welch_segment_stop_filter_in_one_line(corpus_base, tmp_path):
    clean, runs = corpus_base
    shutil.copytree(runs["mcap"]["dir"], tmp_path / "run")
    path = run_yaml(tmp_path, [{"path": str(clean["mcap"])}])  # windows of 2–3 min, Welch segments of 256 s
    before = hashes(tmp_path / "run")
    res = invoke("filter", path)
    assert res.exit_code == 2, res.output
    (line,) = res.stderr.strip().splitlines()
    assert "filter.welch_segment_s: too little data: window 0 has 180 s of samples" in line
    assert hashes(tmp_path / "run") == before


def test_identify_takes_a_window_with_a_masked_accelerometer_burst(corpus_base, tmp_path):
    """A NaN burst in the specific force (masked by ingest) inside an accepted window: filter and identify
    measure around it (this was a ValueError traceback in identify's heave spectrum)."""
    t = tables()
    t["imu"].loc[1200:1799, ["ax", "ay", "az"]] = np.nan
    path = run_yaml(tmp_path, [{"path": str(write_mcap(tmp_path / "trial.mcap", t))}])
    data = yaml.safe_load(path.read_text())
    data["filter"] = {"welch_segment_s": 64}
    path.write_text(yaml.safe_dump(data))
    res = invoke("identify", path)
    assert res.exit_code == 0 and res.exception is None, res.output
    raos = pd.read_parquet(tmp_path / "run" / "raos.parquet")
    assert set(raos.loc[raos["scope"] == "window", "window_id"].astype(str)) == {"0", "1"}


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["mcap", "mcap_raw", "bag", "db3"])
def test_bit_flip_sweep_never_lets_an_implausible_value_through(corpus_base, tmp_path, kind):
    """100 seeded single-bit flips anywhere in each clean log, through `seatune ingest`: exit 0 or exit 2 with one
    line, never a traceback, and after exit 0 every motion sample within the plausibility limits (or masked)."""
    clean, _ = corpus_base
    src = clean[kind] if clean[kind].is_file() else next(clean[kind].glob("*.db3"))
    rng = _rng(f"sweep {kind}")
    exits = Counter()
    limits = {"imu_fx": 5 * G0, "imu_fy": 5 * G0, "imu_fz": 5 * G0, "roll_rate": 5.0, "pitch_rate": 5.0,
              "yaw_rate": 5.0, "roll": np.pi / 2, "pitch": np.pi / 2}
    for i in range(100):
        case = tmp_path / f"flip{i}"
        log = (shutil.copytree(clean[kind], case / clean[kind].name) if kind == "db3"
               else shutil.copy(src, case.mkdir() or case / src.name))
        target = next(Path(log).glob("*.db3")) if kind == "db3" else Path(log)
        flip_bit(target, int(rng.integers(target.stat().st_size)), int(rng.integers(8)))
        path = run_yaml(case, [{"path": str(log)}])
        res = invoke("ingest", path)
        assert res.exit_code in (0, 2) and (res.exception is None or isinstance(res.exception, SystemExit)), (
            i, res.output, res.exception)
        exits[res.exit_code] += 1
        if res.exit_code == 2:
            assert len(res.stderr.strip().splitlines()) == 1, res.stderr
            continue
        motions = pd.read_parquet(case / "run" / "motions.parquet")
        for column, limit in limits.items():
            v = motions[column].to_numpy(float)
            assert not (np.abs(v[np.isfinite(v)]) > limit).any() and not np.isinf(v).any(), (i, column)
    print(f"bit-flip sweep {kind}: {dict(exits)}")
