"""Bags that were not finalised or are damaged: the writer's bounds, and every reader's answer to each damage.

The writer's side: chunks span less than a second of bag time, metadata.yaml exists from the start and says what
the written chunks hold, and a write the disk refuses (a real EFBIG: RLIMIT_FSIZE in a child process) stops the
writer with one BagWriteError and leaves a readable bag.

The readers' side is one table (the bag cases of the fuzz set): a finished bag damaged one way per case -- cut by
a byte, cut to its magic, cut inside a chunk, emptied, overwritten with random bytes, metadata.yaml removed, not
YAML, not rosbag2's, stale, a listed file missing, a chunk corrupted, ... -- and for each, ``./rfidnav bag info``
and ``bag recover`` (the CLI in this process) and ``read_messages`` either read it, stating in one line per damaged
file what was lost, or refuse it in one line naming it, with a non-zero exit and never a traceback. What is read
is checked against what was written: exactly the messages of the chunks before the damage.
"""

from __future__ import annotations

import os
import random
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import psutil
import pytest
import yaml
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.stream_reader import StreamReader
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosgraph_msgs.msg import Clock

from rfidnav_bag.bags import bag_info, message_definition, read_messages
from rfidnav_bag.errors import BagError
from rfidnav_bag.recorder_node import RecorderNode
from rfidnav_bag.writer import CHUNK_DURATION_NS, BagWriter, StorageOptions
from rfidnav_bringup import cli
from rfidnav_bringup.processes import DomainLease
from rfidnav_common.ros import standalone_node
from support.domains import handed_domains

pytestmark = pytest.mark.tier("unit")

NEVER = QosTime(0, 0)
QOS = (Qos(QosHistory.UNKNOWN, 0, QosReliability.RELIABLE, QosDurability.VOLATILE, NEVER, NEVER,
           QosLiveliness.AUTOMATIC, NEVER, False),)
CLOCK = "rosgraph_msgs/msg/Clock"
STEP_NS = 10_000_000  # 100 Hz
T0_NS = 2_000_000_000
ROUNDS = 500  # 5 s of bag time: five chunks of a second


def clock_message(stamp_ns: int) -> bytes:
    message = Clock()
    message.clock.sec, message.clock.nanosec = divmod(stamp_ns, 1_000_000_000)
    return serialize_message(message)


def write_bag(path: Path, options: StorageOptions = StorageOptions(), rounds: int = ROUNDS) -> list[int]:
    """/clock and /clock_copy every 10 ms from 2 s, through the recorder's writer; the stamps written, in order."""
    writer = BagWriter(path, options)
    writer.open()
    topics = [writer.add_topic(name, CLOCK, *message_definition(CLOCK), QOS) for name in ("/clock", "/clock_copy")]
    stamps = []
    for i in range(rounds):
        stamp = T0_NS + i * STEP_NS
        for topic in topics:
            writer.write(topic, stamp, clock_message(stamp))
            stamps.append(stamp)
    writer.close()
    return stamps


def chunks(mcap_file: Path) -> list[Chunk]:
    """The chunk records of a file, finished or not (read up to where it ends)."""
    found = []
    with mcap_file.open("rb") as stream:
        try:
            for record in StreamReader(stream, emit_chunks=True).records:
                if isinstance(record, Chunk):
                    found.append(record)
        except EndOfFile:
            pass   # an unfinished file: no footer yet
    return found


def chunk_offsets(mcap_file: Path) -> list[tuple[int, int]]:
    """(start, length) of every chunk record, from the file's summary."""
    with mcap_file.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return [(index.chunk_start_offset, index.chunk_length) for index in summary.chunk_indexes]


# ------------------------------------------------------------------------------------------- the writer

def test_chunks_span_less_than_a_second_of_bag_time(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag")
    spans = [(c.message_start_time, c.message_end_time) for c in chunks(tmp_path / "bag" / "bag_0.mcap")]
    assert len(spans) == 5, spans
    assert all(end - start < CHUNK_DURATION_NS for start, end in spans)
    assert [start for start, _ in spans] == [T0_NS + k * CHUNK_DURATION_NS for k in range(5)]


def test_metadata_yaml_exists_from_the_start_and_a_checkpoint_brings_it_up_to_date(tmp_path: Path) -> None:
    writer = BagWriter(tmp_path / "bag")
    writer.open()
    metadata = tmp_path / "bag" / "metadata.yaml"

    def information() -> dict:
        return yaml.safe_load(metadata.read_text())["rosbag2_bagfile_information"]

    assert information()["relative_file_paths"] == ["bag_0.mcap"] and information()["message_count"] == 0
    topic = writer.add_topic("/clock", CLOCK, *message_definition(CLOCK), QOS)
    for i in range(30):   # 0.3 s: all in the chunk in progress, nothing on disk yet
        writer.write(topic, T0_NS + i * STEP_NS, clock_message(T0_NS + i * STEP_NS))
    assert information()["message_count"] == 0 and not chunks(tmp_path / "bag" / "bag_0.mcap")
    writer.checkpoint()
    # What metadata.yaml says is what a reader finds in the unfinished file: the 30 messages, one chunk.
    assert information()["message_count"] == 30
    assert information()["topics_with_message_count"][0]["message_count"] == 30
    info = bag_info(tmp_path / "bag")
    assert info.message_count == 30 and len(chunks(tmp_path / "bag" / "bag_0.mcap")) == 1
    assert info.notes and "no summary" in info.notes[0]
    writer.close()
    assert bag_info(tmp_path / "bag").notes == () and information()["message_count"] == 30


# A child process writes a bag under RLIMIT_FSIZE (SIGXFSZ ignored, so the write past it fails with EFBIG): the
# disk refusing a write, without root or a small filesystem.
FULL_DISK_WRITER = """
import resource, signal, sys
sys.path.insert(0, sys.argv[3])
from test_bag_damage import write_bag
from rfidnav_bag.errors import BagWriteError
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[2]), int(sys.argv[2])))
try:
    write_bag(__import__("pathlib").Path(sys.argv[1]), rounds=5000)
except BagWriteError as error:
    print(error)
    sys.exit(3)
"""


def test_a_write_the_disk_refuses_stops_the_writer_and_leaves_a_readable_bag(tmp_path: Path) -> None:
    limit = 60_000   # about four one-second chunks of this bag
    result = subprocess.run([sys.executable, "-c", FULL_DISK_WRITER, str(tmp_path / "bag"), str(limit),
                             str(Path(__file__).parent)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 3, result.stdout + result.stderr
    assert result.stdout.count("\n") == 1 and "File too large; recording stopped with" in result.stdout
    assert "Traceback" not in result.stderr
    on_disk = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    info = bag_info(tmp_path / "bag")
    # metadata.yaml (rewritten after the error) counts exactly the chunks a reader finds
    assert info.message_count == on_disk["message_count"] > 0
    assert f"with {info.message_count:,} messages on disk" in result.stdout
    stamps = [t for _, t, _ in read_messages(tmp_path / "bag", ["/clock"])]
    assert stamps == [T0_NS + i * STEP_NS for i in range(len(stamps))], "a message lost before the error"
    assert (tmp_path / "bag" / "bag_0.mcap").stat().st_size <= limit


# ------------------------------------------------------------------------------------------- the readers

@dataclass(frozen=True)
class Damage:
    """One way of damaging a finished bag, and what the readers must make of it."""

    name: str
    damage: Callable[[Path], None]
    readable: bool  # read (with notes) or refused (one line)
    says: str  # in the note (readable) or the error line (refused); "" for a bag read without a note
    messages: Callable[[list[int]], list[int]] | None = None  # the stamps read of what was written; None: all
    options: StorageOptions = StorageOptions()


def first_file(bag: Path) -> Path:
    return bag / f"{bag.name}_0.mcap"


def cut_to(size: Callable[[Path], int]) -> Callable[[Path], None]:
    def damage(bag: Path) -> None:
        data = first_file(bag).read_bytes()
        first_file(bag).write_bytes(data[:size(first_file(bag))])
    return damage


def mid_chunk(k: int) -> Callable[[Path], int]:
    def size(path: Path) -> int:
        start, length = chunk_offsets(path)[k]
        return start + length // 2
    return size


def in_chunks(k: int) -> Callable[[list[int]], list[int]]:
    """The stamps of the first ``k`` one-second chunks."""
    return lambda stamps: [s for s in stamps if s < T0_NS + k * CHUNK_DURATION_NS]


def overwrite(text: bytes | None) -> Callable[[Path], None]:
    def damage(bag: Path) -> None:
        if text is None:
            (bag / "metadata.yaml").unlink()
        else:
            (bag / "metadata.yaml").write_bytes(text)
    return damage


def corrupt_chunk(k: int) -> Callable[[Path], None]:
    """Flip bytes in the middle of chunk ``k``'s data (its CRC fails then), and cut the summary off."""
    def damage(bag: Path) -> None:
        path = first_file(bag)
        offsets = chunk_offsets(path)
        start, length = offsets[k]
        data = bytearray(path.read_bytes())
        for offset in range(start + length // 2, start + length // 2 + 8):
            data[offset] ^= 0xFF
        path.write_bytes(bytes(data[:sum(offsets[-1])]))
    return damage


def stale_metadata(bag: Path) -> None:
    """metadata.yaml as a checkpoint left it: fewer messages than the (finished) files hold."""
    document = yaml.safe_load((bag / "metadata.yaml").read_text())
    document["rosbag2_bagfile_information"]["message_count"] = 10
    (bag / "metadata.yaml").write_text(yaml.safe_dump(document))


def drop_file(index: int) -> Callable[[Path], None]:
    return lambda bag: (bag / f"{bag.name}_{index}.mcap").unlink()


def cut_last_file(bag: Path) -> None:
    files = sorted(bag.glob("*.mcap"), key=lambda p: int(p.stem.rsplit("_", 1)[1]))
    files[-1].write_bytes(files[-1].read_bytes()[:mid_chunk(0)(files[-1])])


SPLIT = StorageOptions(max_bag_duration_ns=2 * CHUNK_DURATION_NS)   # files of 2 s: bag_0 .. bag_2


def in_files(*indexes: int) -> Callable[[list[int]], list[int]]:
    """The stamps of the split bag's files ``indexes`` (each 2 s and a step: a file's first message is more than
    2 s after the previous file's first)."""
    bounds = [T0_NS + k * (2 * CHUNK_DURATION_NS + STEP_NS) for k in range(4)]
    return lambda stamps: [s for s in stamps if any(bounds[i] <= s < bounds[i + 1] for i in indexes)]


DAMAGES = [
    Damage("cut_by_one_byte", cut_to(lambda p: p.stat().st_size - 1), True, "no intact summary"),
    Damage("cut_to_the_magic", cut_to(lambda p: 8), False, "nothing but the MCAP magic"),
    Damage("cut_inside_the_header", cut_to(lambda p: 20), False, "incomplete record"),
    Damage("cut_mid_chunk", cut_to(mid_chunk(2)), True, "the last, incomplete chunk", in_chunks(2)),
    Damage("cut_mid_first_chunk", cut_to(mid_chunk(0)), False, "incomplete record"),
    Damage("cut_after_a_chunk", cut_to(lambda p: sum(chunk_offsets(p)[1])), True, "ends after a whole chunk",
           in_chunks(2)),
    Damage("compressed_cut_mid_chunk", cut_to(mid_chunk(3)), True, "the last, incomplete chunk", in_chunks(3),
           StorageOptions(compression="zstd")),
    Damage("zero_bytes", cut_to(lambda p: 0), False, "empty (0 bytes)"),
    Damage("random_bytes", lambda bag: first_file(bag).write_bytes(random.Random(7).randbytes(4096)), False,
           "not an MCAP file"),
    Damage("missing_metadata", overwrite(None), True, "no metadata.yaml"),
    Damage("malformed_metadata", overwrite(b"rosbag2_bagfile_information: [version: 9\n  files: {"), True,
           "metadata.yaml is not valid YAML"),
    Damage("metadata_not_rosbag2", overwrite(b"- 1\n- 2\n"), True, "holds no rosbag2_bagfile_information"),
    Damage("empty_metadata", overwrite(b""), True, "holds no rosbag2_bagfile_information"),
    Damage("metadata_not_utf8", overwrite(b"rosbag2_bagfile_information: \xff\xfe\n"), True,
           "metadata.yaml cannot be read"),
    Damage("metadata_missing_keys", overwrite(b"rosbag2_bagfile_information:\n  relative_file_paths: [bag_0.mcap]\n"
                                              b"  message_count: 1000\n  storage_identifier: mcap\n"), True,
           "metadata.yaml is not usable"),
    Damage("stale_metadata", stale_metadata, True, ""),
    Damage("missing_metadata_and_cut", lambda bag: (overwrite(None)(bag), cut_to(mid_chunk(1))(bag)), True,
           "the last, incomplete chunk", in_chunks(1)),
    Damage("corrupt_chunk_of_a_cut_file", corrupt_chunk(1), True, "1 damaged chunk(s) skipped",
           lambda stamps: [s for s in stamps if not T0_NS + CHUNK_DURATION_NS <= s < T0_NS + 2 * CHUNK_DURATION_NS]),
    Damage("compressed_corrupt_chunk_of_a_cut_file", corrupt_chunk(2), True, "1 damaged chunk(s) skipped",
           lambda stamps: [s for s in stamps if not T0_NS + 2 * CHUNK_DURATION_NS <= s < T0_NS + 3 * CHUNK_DURATION_NS],
           StorageOptions(compression="zstd")),
    Damage("split_last_file_cut", cut_last_file, True, "bag_2.mcap is unreadable", in_files(0, 1), SPLIT),
    Damage("split_listed_file_missing", drop_file(1), True, "bag_1.mcap (listed in metadata.yaml) is missing",
           in_files(0, 2), SPLIT),
    Damage("no_file_left", drop_file(0), False, "is missing"),
    Damage("no_bag_at_all", lambda bag: (shutil.rmtree(bag), bag.mkdir()), False, "no metadata.yaml, no .mcap file"),
]


def run_cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = cli.main(list(args))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.parametrize("case", DAMAGES, ids=[d.name for d in DAMAGES])
def test_every_reader_reads_a_damaged_bag_stating_the_loss_or_refuses_it_in_one_line(
        case: Damage, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / "bag"
    written = write_bag(bag, case.options)
    case.damage(bag)

    code, out, err = run_cli(capsys, "bag", "info", str(bag))
    lines = err.splitlines()
    assert "Traceback" not in out + err
    if not case.readable:
        assert code != 0 and len(lines) == 1 and out == "", err
        assert lines[0].startswith(f"rfidnav bag: {bag}") and case.says in lines[0], lines
        with pytest.raises(BagError, match=case.says.replace("(", r"\(").replace(")", r"\)")):
            list(read_messages(bag))
        code, out, err = run_cli(capsys, "bag", "recover", str(bag))
        assert code != 0 and len(err.splitlines()) == 1 and "Traceback" not in err and not (
            tmp_path / "bag_recovered").exists(), err
        return

    expected = case.messages(written) if case.messages else written
    assert code == 0, err
    assert all(line.startswith(f"rfidnav bag info: {bag}: ") for line in lines), lines
    assert case.says in err if case.says else lines == [], lines
    assert f"Messages:         {len(expected)}\n" in out
    # One line per damaged file, and one for metadata.yaml if it had to be rebuilt: never more.
    assert len(lines) <= 2
    stamps = [t for _, t, _ in read_messages(bag, ["/clock"])]
    assert stamps == sorted(set(expected)), "read other messages than the intact chunks hold"

    code, out, err = run_cli(capsys, "bag", "recover", str(bag))
    assert code == 0 and "Traceback" not in err, err
    assert f"-> {tmp_path / 'bag_recovered'}: {len(expected):,} messages" in out
    with AnyReader([tmp_path / "bag_recovered"]) as reader:
        assert [t for c, t, _ in reader.messages() if c.topic == "/clock"] == stamps
    assert bag_info(tmp_path / "bag_recovered").notes == ()


def test_a_damaged_chunk_in_a_finished_bag_ends_a_read_in_one_line_and_recover_skips_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Its summary is intact, so it reads as finished (rosbags): the chunk's CRC fails only when it is read."""
    bag = tmp_path / "bag"
    written = write_bag(bag, StorageOptions(compression="zstd"))
    path = first_file(bag)
    start, length = chunk_offsets(path)[1]
    data = bytearray(path.read_bytes())
    data[start + length // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    assert bag_info(bag).message_count == len(written) and bag_info(bag).notes == ()
    with pytest.raises(BagError, match="corrupt message data"):
        list(read_messages(bag))
    code, out, err = run_cli(capsys, "bag", "recover", str(bag))
    assert code == 0 and err.splitlines() == [f"rfidnav bag recover: {bag}: bag_0.mcap: read 800 messages; "
                                              "1 damaged chunk(s) skipped"], err
    second = range(T0_NS + CHUNK_DURATION_NS, T0_NS + 2 * CHUNK_DURATION_NS)
    assert [t for _, t, _ in read_messages(tmp_path / "bag_recovered")] == [s for s in written if s not in second]


def test_a_plain_file_and_a_missing_path_are_refused_in_one_line(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    plain = tmp_path / "bag_0.mcap"
    plain.write_bytes(os.urandom(100))
    for path, says in ((plain, "not a run folder nor a rosbag2 folder"),
                       (tmp_path / "nothing", "the path does not exist")):
        code, out, err = run_cli(capsys, "bag", "info", str(path))
        assert code == 2 and out == "" and err.count("\n") == 1 and says in err and str(path) in err, err


# ------------------------------------------------------------------------------------------- a real run

KILL_AT_NS = 60_000_000_000   # sim time at which the recorder of the run is killed
CLOCK_RATE_HZ = 50.0   # robot_sim's /clock (odom_rate_hz)
WORKSPACE = Path(__file__).resolve().parents[1]


def run_killing_the_recorder(out: Path, scenario: str) -> tuple[int, int, str]:
    """``./rfidnav run SCENARIO --rtf max`` whose recorder is SIGKILLed once /clock passes KILL_AT_NS: the latest
    /clock this process had seen at the kill, the CLI's exit code and its output."""
    with DomainLease(handed_domains()) as free:     # a domain of this worker's share, free now
        domain = free.domain_id
    env = dict(os.environ)
    env.pop("ROS_DOMAIN_ID", None)
    command = [sys.executable, "-m", "rfidnav_bringup.cli", "run", scenario, "--rtf", "max", "--domain",
               str(domain), "--out", str(out), "--quiet"]
    latest = [0]
    with subprocess.Popen(command, cwd=WORKSPACE, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True) as run:
        assert run.stdout is not None
        # Join only once the run leased its domain.
        head = []
        for line in iter(run.stdout.readline, ""):
            head.append(line)
            if line.startswith("graph on "):
                break
        with standalone_node("test_bag_damage_clock", domain) as (node, executor):
            node.create_subscription(Clock, "/clock", lambda m: latest.__setitem__(
                0, m.clock.sec * 1_000_000_000 + m.clock.nanosec), 100)
            deadline = time.monotonic() + 240
            while latest[0] < KILL_AT_NS and run.poll() is None:
                assert time.monotonic() < deadline, "the run's clock never reached the kill"
                executor.spin_once(timeout_sec=0.01)
            assert run.poll() is None, "".join(head) + run.stdout.read()
            recorders = [p for p in psutil.Process(run.pid).children(recursive=True)
                         if any(part.endswith("/recorder") for part in p.cmdline())]
            assert len(recorders) == 1, recorders
            executor.spin_once(timeout_sec=0)   # the latest /clock already delivered
            killed_at = latest[0]
            recorders[0].kill()
        output, _ = run.communicate(timeout=180)
        output = "".join(head) + output
    return killed_at, run.returncode, output


@pytest.mark.tier("graph")
def test_a_run_whose_recorder_is_sigkilled_keeps_its_bag_to_within_a_second_of_the_kill(tmp_path: Path) -> None:
    """The figure of the README: how much bag (sim) time a SIGKILL of a real run's recorder loses, between the
    last message that can be read and the latest /clock an outside node had seen at the kill."""
    killed_at, code, output = run_killing_the_recorder(tmp_path, "hallway")
    assert code != 0 and "recorder exited with code -9" in output, output
    [bag] = tmp_path.glob("*/bag")
    info = bag_info(bag)
    assert any("has no summary" in note for note in info.notes), info.notes
    lost_s = (killed_at - info.end_ns) / 1e9
    print(f"recorder SIGKILLed at {killed_at / 1e9:.3f} s of sim time; last readable message at "
          f"{info.end_ns / 1e9:.3f} s: {lost_s:.3f} s lost; {info.notes}")
    # The chunk in progress spans under a second of bag time; the stepped clock lets the recorder fall at most
    # step_slack messages behind on /clock (50 Hz): at most a second more that it had not handled yet.
    assert lost_s < CHUNK_DURATION_NS / 1e9 + RecorderNode.step_slack / CLOCK_RATE_HZ, f"{lost_s:.3f} s lost"
    assert info.topic("/odom").count > 0 and info.topic("/rfid/reads").count > 0
