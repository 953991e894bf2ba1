"""Hostile datagrams on the domain: RTPS built by hand and sent over loopback to the running node's own UDP
ports (the node's processes run on this host; nothing here sends to any address but 127.0.0.1).

- A DATA_FRAG claiming a sample of 1 GiB, and one claiming 4 GiB - 1, from a GUID prefix nobody announced,
  to the SPDP reader and to the user readers: the node stays alive, its RSS within 100 MB of before, and it
  answers a GraspCandidate.
- Eight DATA_FRAGs claiming 1 GiB each, from eight GUID prefixes: RSS within 200 MB, answering.
- With max_message_bytes 1 MiB, a GraspCandidate of 2 MiB (a long id) from the client's own reliable
  publisher is dropped with a warning naming the bound, and the next candidates from that publisher are
  answered at once (the dropped sequence number does not hold them back).
- 20,000 fake SPDP participants (distinct GUID prefixes, as fast as the socket takes them): RSS bounded, a
  candidate answered promptly during and after, and SIGINT ends the node within about a second.

The RTPS bytes follow DDSI-RTPS 2.5 section 9 (the header 9.4.4, submessage headers 9.4.5.1, DATA 9.4.5.3,
DATA_FRAG 9.4.5.4, ParameterList 9.4.2.11, the SPDP parameters 9.6.2.2 and 9.6.3). All little-endian (the
E flag set), as Fast DDS sends them. See conftest.py for how to run.
"""
from __future__ import annotations

import os
import socket
import struct
import threading
import time
from pathlib import Path

import pytest

from conftest import DOMAIN_ID, GraspClient, candidate_msg, probe_candidate

# ---------------------------------------------------------------------------------------------------
# RTPS on the wire
# ---------------------------------------------------------------------------------------------------
VENDOR_ID = b"\x01\x0f"  # eProsima (Fast DDS), as the peers on a ROS domain announce themselves
PROTOCOL_VERSION = b"\x02\x03"  # RTPS 2.3, what Fast DDS 2.14 sends

# Entity ids (9.3.1.2 and 9.6.1.3): the SPDP built-in participant writer and reader.
SPDP_WRITER = bytes.fromhex("000100c2")
SPDP_READER = bytes.fromhex("000100c7")
PARTICIPANT = bytes.fromhex("000001c1")
UNKNOWN = bytes(4)  # ENTITYID_UNKNOWN: "every reader that matches the writer"

SUBMSG_DATA = 0x15
SUBMSG_DATA_FRAG = 0x16
FLAG_E = 0x01  # little-endian submessage
FLAG_DATA = 0x04  # DATA: the payload is the sample's data

PID_SENTINEL = 0x0001
PID_PARTICIPANT_LEASE_DURATION = 0x0002
PID_PROTOCOL_VERSION = 0x0015
PID_VENDOR_ID = 0x0016
PID_DEFAULT_UNICAST_LOCATOR = 0x0031
PID_METATRAFFIC_UNICAST_LOCATOR = 0x0032
PID_PARTICIPANT_GUID = 0x0050
PID_BUILTIN_ENDPOINT_SET = 0x0058

# The built-in endpoints a Fast DDS participant announces (9.3.2, BuiltinEndpointSet_t): the SPDP
# announcer and detector, SEDP publications and subscriptions announcers and detectors, and the participant
# message writer and reader.
BUILTIN_ENDPOINTS = (1 << 0) | (1 << 1) | (1 << 2) | (1 << 3) | (1 << 4) | (1 << 5) | (1 << 10) | (1 << 11)


def rtps_header(guid_prefix: bytes) -> bytes:
    """The 20-byte RTPS message header (9.4.4)."""
    assert len(guid_prefix) == 12
    return (b"RTPS"  # protocol: the four letters
            + PROTOCOL_VERSION  # protocol version major, minor
            + VENDOR_ID  # vendor id
            + guid_prefix)  # GuidPrefix_t of the sending participant: every GUID below is under it


def submessage(kind: int, flags: int, body: bytes) -> bytes:
    """A submessage: id, flags (E set: little-endian), octetsToNextHeader, then the body (9.4.5.1)."""
    return struct.pack("<BBH", kind, flags | FLAG_E, len(body)) + body


def data_frag(reader: bytes, writer: bytes, seq: int, sample_size: int, fragment_size: int,
              first_fragment: int = 1, payload: bytes | None = None) -> bytes:
    """A DATA_FRAG submessage (9.4.5.4) carrying one fragment of a sample that claims `sample_size` bytes."""
    if payload is None:
        payload = bytes(min(fragment_size, sample_size))
    body = (struct.pack("<HH", 0, 28)  # extraFlags; octetsToInlineQos: the 28 bytes from readerId to sampleSize
            + reader  # readerId
            + writer  # writerId
            + struct.pack("<iI", seq >> 32, seq & 0xFFFFFFFF)  # writerSN: high, low
            + struct.pack("<I", first_fragment)  # fragmentStartingNum, from 1
            + struct.pack("<H", 1)  # fragmentsInSubmessage
            + struct.pack("<H", fragment_size)  # fragmentSize
            + struct.pack("<I", sample_size)  # sampleSize: what the reader is told to assemble
            + payload)  # serializedPayload: this fragment's bytes
    return submessage(SUBMSG_DATA_FRAG, 0, body)


def parameter(pid: int, value: bytes) -> bytes:
    """One parameter of a ParameterList (9.4.2.11): pid, length, the value padded to 4 bytes."""
    value += bytes(-len(value) % 4)
    return struct.pack("<HH", pid, len(value)) + value


def udpv4_locator(port: int) -> bytes:
    """Locator_t (9.3.2): kind LOCATOR_KIND_UDPv4, port, 16 address bytes with 127.0.0.1 in the last four."""
    return struct.pack("<iI", 1, port) + bytes(12) + bytes([127, 0, 0, 1])


def spdp_data(guid_prefix: bytes, locator_port: int, lease_s: int = 20, seq: int = 1) -> bytes:
    """An SPDP DATA submessage (9.4.5.3) announcing participant `guid_prefix` (SPDPdiscoveredParticipantData,
    8.5.3.2, as a PL_CDR_LE ParameterList), its locators at 127.0.0.1:`locator_port`."""
    params = (parameter(PID_PROTOCOL_VERSION, PROTOCOL_VERSION)
              + parameter(PID_VENDOR_ID, VENDOR_ID)
              + parameter(PID_PARTICIPANT_GUID, guid_prefix + PARTICIPANT)
              + parameter(PID_METATRAFFIC_UNICAST_LOCATOR, udpv4_locator(locator_port))
              + parameter(PID_DEFAULT_UNICAST_LOCATOR, udpv4_locator(locator_port))
              + parameter(PID_PARTICIPANT_LEASE_DURATION, struct.pack("<iI", lease_s, 0))  # seconds, fraction
              + parameter(PID_BUILTIN_ENDPOINT_SET, struct.pack("<I", BUILTIN_ENDPOINTS))
              + struct.pack("<HH", PID_SENTINEL, 0))
    payload = b"\x00\x03\x00\x00" + params  # encapsulation PL_CDR_LE, options 0; then the ParameterList
    body = (struct.pack("<HH", 0, 16)  # extraFlags; octetsToInlineQos: readerId to writerSN, no inline QoS
            + SPDP_READER  # readerId
            + SPDP_WRITER  # writerId
            + struct.pack("<iI", seq >> 32, seq & 0xFFFFFFFF)  # writerSN
            + payload)  # serializedPayload
    return submessage(SUBMSG_DATA, FLAG_DATA, body)


def fake_prefix(i: int) -> bytes:
    """A GUID prefix nobody announced: vendor-like first bytes, then `i`."""
    return b"\xbe\xef" + os.urandom(2) + struct.pack(">Q", i)


# ---------------------------------------------------------------------------------------------------
# The node's process: its UDP ports and its memory
# ---------------------------------------------------------------------------------------------------
def udp_ports(pid: int) -> list[int]:
    """The local ports of the UDP sockets process `pid` holds (IPv4, from /proc/net/udp by socket inode)."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    ports = set()
    for line in Path(f"/proc/{pid}/net/udp").read_text().splitlines()[1:]:
        cols = line.split()
        if cols[9] in inodes:
            ports.add(int(cols[1].split(":")[1], 16))
    return sorted(ports)


def metatraffic_ports(pid: int) -> list[int]:
    """The node's unicast discovery ports (9.6.1.1: 7400 + 250 * domain + 10 + 2 * participant id), where its
    SPDP and SEDP readers listen."""
    base = 7400 + 250 * DOMAIN_ID
    ports = [p for p in udp_ports(pid) if base + 10 <= p < base + 250 and (p - base - 10) % 2 == 0]
    assert ports, f"no unicast discovery port among the node's UDP ports {udp_ports(pid)}"
    return ports


def user_ports(pid: int) -> list[int]:
    """The node's unicast user-traffic ports (7400 + 250 * domain + 11 + 2 * participant id)."""
    base = 7400 + 250 * DOMAIN_ID
    return [p for p in udp_ports(pid) if base + 11 <= p < base + 250 and (p - base - 11) % 2 == 0]


def rss_mb(pid: int) -> float:
    """VmRSS of process `pid`, in MB."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise AssertionError(f"no VmRSS in /proc/{pid}/status")


def send_all(datagrams: list[tuple[bytes, int]]):
    """Send each (message, port) to 127.0.0.1:port."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for msg, port in datagrams:
            s.sendto(msg, ("127.0.0.1", port))


# The user writers' entity ids a Fast DDS participant gives its first writers (9.3.1.2: a key, then kind
# 0x03, a user writer without key): a DATA_FRAG to ENTITYID_UNKNOWN with such a writer id goes to every
# user reader of the node that matched a writer of that id from any participant.
USER_WRITER_IDS = [struct.pack(">I", (k << 8) | 0x03) for k in range(1, 24)]


def claiming(prefix: bytes, sample_size: int, node_pid: int) -> list[tuple[bytes, int]]:
    """Datagrams from `prefix` each carrying one 1 KiB fragment of a sample claiming `sample_size` bytes:
    to the SPDP reader at every discovery port, and to the user readers at every user port."""
    out = []
    for port in metatraffic_ports(node_pid):
        out.append((rtps_header(prefix) + data_frag(SPDP_READER, SPDP_WRITER, 1, sample_size, 1024), port))
    for port in user_ports(node_pid):
        msg = rtps_header(prefix) + b"".join(data_frag(UNKNOWN, w, 1, sample_size, 1024) for w in USER_WRITER_IDS)
        out.append((msg, port))
    return out


def answers_promptly(client: GraspClient, tag: str, timeout: float = 10.0) -> float:
    """Seconds to the answer of one probe candidate (paper case (a)); fails after `timeout`."""
    t0 = time.monotonic()
    ans = client.send_one(probe_candidate(f"hostile-{tag}-{time.monotonic_ns()}"), timeout=timeout)
    assert ans.status == 0, ans.message
    return time.monotonic() - t0


def settled_rss(pid: int, seconds: float = 1.0) -> float:
    """RSS after `seconds`: what the node still holds once the datagrams were handled."""
    time.sleep(seconds)
    return rss_mb(pid)


# ---------------------------------------------------------------------------------------------------
# The tests
# ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("sample_size", [1 << 30, (1 << 32) - 1], ids=["1GiB", "4GiB-1"])
def test_one_datagram_claiming_a_huge_sample(grasp_node, client, sample_size):
    pid = grasp_node.proc.pid
    answers_promptly(client, "before")
    before = rss_mb(pid)
    send_all(claiming(fake_prefix(1), sample_size, pid))
    after = settled_rss(pid)
    assert grasp_node.proc.poll() is None, (f"the node died ({grasp_node.proc.returncode}) on one DATA_FRAG "
                                            f"claiming {sample_size} bytes; output:\n{grasp_node.output(20)}")
    took = answers_promptly(client, "after")
    print(f"claiming {sample_size}: RSS {before:.1f} -> {after:.1f} MB, answer in {took * 1000:.0f} ms")
    assert after - before < 100, f"RSS grew from {before:.1f} to {after:.1f} MB on one DATA_FRAG"


def test_eight_datagrams_claiming_1gib_from_eight_guids(grasp_node, client):
    pid = grasp_node.proc.pid
    answers_promptly(client, "before")
    before = rss_mb(pid)
    for i in range(8):
        send_all(claiming(fake_prefix(100 + i), 1 << 30, pid))
    after = settled_rss(pid)
    assert grasp_node.proc.poll() is None, f"the node died ({grasp_node.proc.returncode})"
    took = answers_promptly(client, "after")
    print(f"8 x 1 GiB: RSS {before:.1f} -> {after:.1f} MB, answer in {took * 1000:.0f} ms")
    assert after - before < 200, f"RSS grew from {before:.1f} to {after:.1f} MB on 8 DATA_FRAGs"


def test_a_message_above_max_message_bytes_is_dropped(start_node, peer):
    ns = "/hostile_big"
    node = start_node("--ros-args", "-r", f"__ns:={ns}", "-p", "record:=false",
                      "-p", f"max_message_bytes:={1 << 20}", name="node (max_message_bytes 1 MiB)")
    client = GraspClient(peer, ns)
    client.ensure_roundtrip()
    pid = node.proc.pid
    before = rss_mb(pid)
    seen = len(node.all_lines())
    big = probe_candidate("big-" + "x" * (2 << 20))  # a 2 MiB id: about 33 DATA_FRAGs of 64 KiB
    n = len(client.order)
    client.pub.publish(candidate_msg(big))
    line = node.wait_for_line(r"claims a sample of \d+ bytes, more than the 1048576", timeout=10.0, after=seen)
    # The next candidates of the same reliable publisher: answered within a second each, not after the
    # writer gives up on the dropped one.
    took = [answers_promptly(client, f"after-{k}", timeout=5.0) for k in range(3)]
    client.peer.spin_for(0.5)
    dropped = [a.candidate_id[:20] for a in client.order[n:] if a.candidate_id.startswith("big-")]
    after = rss_mb(pid)
    print(f"2 MiB candidate against max_message_bytes 1 MiB: {line.strip()[:160]}; answers after it "
          f"{[round(t * 1000) for t in took]} ms; RSS {before:.1f} -> {after:.1f} MB")
    assert not dropped, f"the 2 MiB candidate was answered: {dropped}"
    assert max(took) < 1.0, f"answers after the dropped message took {took} s"
    assert node.proc.poll() is None
    node.stop_and_check()


FAKE_PARTICIPANTS = 20_000
FLOOD_S = 30.0  # the flood's time bound: it stops there, however many were sent


class Sink:
    """A socket at 127.0.0.1 the fake participants announce as their locators: it counts what the node sends
    them, so nothing the node sends leaves this host or reaches a port nobody reads."""

    def __init__(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.datagrams = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._drain, daemon=True)
        self._thread.start()

    def _drain(self):
        while not self._stop.is_set():
            try:
                self.sock.recv(70000)
                self.datagrams += 1
            except socket.timeout:
                pass
            except OSError:
                return

    def close(self):
        self._stop.set()
        self._thread.join(2)
        self.sock.close()


def test_many_fake_participants(start_node, peer):
    ns = "/hostile_spdp"
    node = start_node("--ros-args", "-r", f"__ns:={ns}", "-p", "record:=false", name="node (fake participants)")
    client = GraspClient(peer, ns)
    client.ensure_roundtrip()
    pid = node.proc.pid
    idle = min(answers_promptly(client, "idle") for _ in range(3))
    before = rss_mb(pid)
    ports = metatraffic_ports(pid)
    sink = Sink()
    try:
        sent = 0
        during = []
        t0 = time.monotonic()
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            while sent < FAKE_PARTICIPANTS and time.monotonic() - t0 < FLOOD_S:
                for _ in range(100):
                    prefix = fake_prefix(sent)
                    for port in ports:
                        s.sendto(rtps_header(prefix) + spdp_data(prefix, sink.port), ("127.0.0.1", port))
                    sent += 1
                time.sleep(0.04)  # some 2,000 a second: most reach the node (its socket is not what is tested)
                if sent % 4000 == 0:
                    during.append(answers_promptly(client, f"during-{sent}"))
        flood_s = time.monotonic() - t0
        time.sleep(2.0)
        after_rss = rss_mb(pid)
        after = [answers_promptly(client, f"after-{k}") for k in range(5)]
        print(f"{sent} fake participants in {flood_s:.1f} s: RSS {before:.1f} -> {after_rss:.1f} MB; answers idle "
              f"{idle * 1000:.0f} ms, during {[round(t * 1000) for t in during]} ms, after "
              f"{[round(t * 1000) for t in after]} ms; {sink.datagrams} datagrams to the fakes")
        assert node.proc.poll() is None, f"the node died ({node.proc.returncode})"
        assert after_rss - before < 50, f"RSS grew from {before:.1f} to {after_rss:.1f} MB with {sent} fakes"
        slowest = max(during + after)
        assert slowest < max(0.3, 5 * idle), (f"answers slowed to {slowest * 1000:.0f} ms (idle "
                                              f"{idle * 1000:.0f} ms) with {sent} fake participants")
        t_stop = time.monotonic()
        rc = node.stop(timeout=10)
        stop_s = time.monotonic() - t_stop
        print(f"SIGINT to exit: {stop_s:.2f} s")
        assert rc == 0, f"exit code {rc} after SIGINT; output:\n{node.output(20)}"
        assert stop_s < 1.5, f"SIGINT took {stop_s:.1f} s to end the node with {sent} fake participants"
    finally:
        sink.close()
