"""Fixtures and helpers for driving the grasp_orient ROS 2 node from a real rclpy peer (Fast DDS).

Run (after `bash tests/peer/setup.sh` and `cargo build --profile test`, the build `cargo test` makes):

    source "$(bash tests/peer/setup.sh | tail -n1)"
    python -m pytest tests/ros -v

Environment:
    GRASP_ORIENT_BIN            the grasp_orient binary (default: <repo>/target/debug/grasp_orient)
    GRASP_ORIENT_TEST_DOMAIN_ID ROS_DOMAIN_ID for the session (default: 1 + pid % 100)

Nothing here skips: a missing binary, a missing rclpy or a node that does not come up fails every test
with the reason.
"""
from __future__ import annotations

import array
import json
import math
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable, Iterable

import pytest

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent.parent
DEFAULT_BIN = REPO_ROOT / "target" / "debug" / "grasp_orient"
PAPER_CASES = REPO_ROOT / "examples" / "paper_cases.jsonl"
EXAMPLE_SCRIPT = REPO_ROOT / "examples" / "publish_test_grasp.py"

READY_MARK = "waiting for"
READY_TIMEOUT_S = 20.0
EXIT_TIMEOUT_S = 10.0
REL_TOL = 1e-12

CANDIDATE_TYPE = "grasp_orient/msg/GraspCandidate"
RECOMMENDATION_TYPE = "grasp_orient/msg/GripRecommendation"
MARKER_ARRAY_TYPE = "visualization_msgs/msg/MarkerArray"


# ---------------------------------------------------------------------------------------------------
# Environment: one ROS domain per test session, discovery on this host only. Must be set before rclpy
# initialises (it reads the variables at rclpy.init()).
# ---------------------------------------------------------------------------------------------------
def session_domain_id() -> int:
    given = os.environ.get("GRASP_ORIENT_TEST_DOMAIN_ID")
    if given:
        return int(given)
    return 1 + os.getpid() % 100  # 1..100, never the default domain 0


def ros_env(domain_id: int, base: dict | None = None) -> dict:
    """The environment for a ROS process (rclpy or the node) on `domain_id`, discovery on localhost."""
    env = dict(os.environ if base is None else base)
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["GRASP_ORIENT_TEST_DOMAIN_ID"] = str(domain_id)  # child Python processes importing this file keep it
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    # ROS_LOCALHOST_ONLY is deprecated in Jazzy (the range above replaces it; setting both only warns).
    env.pop("ROS_LOCALHOST_ONLY", None)
    env.pop("ROS_STATIC_PEERS", None)
    env.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
    return env


DOMAIN_ID = session_domain_id()
os.environ.update(ros_env(DOMAIN_ID))
os.environ.pop("ROS_LOCALHOST_ONLY", None)
os.environ.pop("ROS_STATIC_PEERS", None)

try:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from grasp_orient.msg import GraspCandidate, GripRecommendation
    from visualization_msgs.msg import MarkerArray
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import GetParameters, SetParameters

    RCLPY_IMPORT_ERROR: str | None = None
except ImportError as e:  # reported by the fixtures as a failure, never a skip
    RCLPY_IMPORT_ERROR = (
        f"cannot import rclpy / grasp_orient.msg ({e}). Run the tests with the ROS peer venv: "
        f"source \"$(bash tests/peer/setup.sh | tail -n 1)\" && python -m pytest tests/ros"
    )


def binary_path() -> Path:
    given = os.environ.get("GRASP_ORIENT_BIN")
    return Path(given).resolve() if given else DEFAULT_BIN


def require_environment() -> Path:
    """Fail (never skip) when rclpy or the binary is missing; return the binary."""
    if RCLPY_IMPORT_ERROR:
        pytest.fail(RCLPY_IMPORT_ERROR, pytrace=False)
    b = binary_path()
    if not b.is_file() or not os.access(b, os.X_OK):
        pytest.fail(
            f"grasp_orient binary not found at {b} (build it with `cargo build --profile test`, or set GRASP_ORIENT_BIN)",
            pytrace=False,
        )
    return b


# ---------------------------------------------------------------------------------------------------
# Candidates as JSON-like dicts (the `solve` input form) and as ROS messages
# ---------------------------------------------------------------------------------------------------
def load_paper_cases() -> list[dict]:
    return [json.loads(l) for l in PAPER_CASES.read_text().splitlines() if l.strip()]


# One generator for every Python test: the port of tests/it/util/mod.rs random_grasp.
from mcap_util import random_grasp  # noqa: E402,F401


# Round-trip probes: paper case (a), which the node solves (so it gets markers), in a frame of its own. Tests
# leave that frame out of what they check of grip_markers: a probe answered before the node matched a marker
# reader has its markers recorded (record_markers) but not received.
PROBE_FRAME = "grasp_orient_test_probe"


def probe_candidate(cid: str) -> dict:
    """Paper case (a) with id `cid`, in PROBE_FRAME."""
    p = load_paper_cases()[0]
    p["id"] = cid
    p["header"]["frame_id"] = PROBE_FRAME
    return p


def is_probe_markers(arr: Any) -> bool:
    """Whether a marker array (a ROS message, or a dict as the recording readers and `to_plain` give it) is a
    probe's: all its markers in PROBE_FRAME."""
    ms = arr["markers"] if isinstance(arr, dict) else arr.markers
    frames = {m["header"]["frame_id"] if isinstance(m, dict) else m.header.frame_id for m in ms}
    return frames == {PROBE_FRAME}


def fill_message(msg, data: dict):
    """Set the fields of a ROS message from a JSON-like dict (nested dicts for nested messages)."""
    for k, v in data.items():
        cur = getattr(msg, k)
        if isinstance(v, dict):
            fill_message(cur, v)
        else:
            setattr(msg, k, v)
    return msg


def candidate_msg(data: dict):
    return fill_message(GraspCandidate(), data)


def to_plain(v: Any) -> Any:
    """A ROS message as a JSON-like value: nested dicts, lists, NaN/inf as None (as `solve` writes them)."""
    if hasattr(v, "get_fields_and_field_types"):
        return {k: to_plain(getattr(v, k)) for k in v.get_fields_and_field_types()}
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, (list, tuple, array.array)) or type(v).__name__ == "ndarray":
        return [to_plain(x.item() if hasattr(x, "item") else x) for x in v]
    if hasattr(v, "item"):  # numpy scalar
        return to_plain(v.item())
    return v


LINE_PREFIX = re.compile(r"^line \d+: ")


def compare(ros: Any, ref: Any, path: str = "", status: int | None = None) -> list[str]:
    """Differences between a ROS answer (to_plain form) and a `solve` JSON answer, field by field."""
    out: list[str] = []
    if isinstance(ref, dict) or isinstance(ros, dict):
        if not isinstance(ros, dict) or not isinstance(ref, dict):
            return [f"{path}: {ros!r} vs solve {ref!r}"]
        if status is None:
            status = ref.get("status")
        for k in sorted(set(ros) | set(ref)):
            if k not in ros or k not in ref:
                out.append(f"{path}{k}: missing on the {'ROS' if k not in ros else 'solve'} side")
                continue
            if k == "message" and path == "" and status == 2:
                a, b = ros[k], LINE_PREFIX.sub("", ref[k])
                if a != b:
                    out.append(f"message: {a!r} vs solve {b!r}")
                continue
            out += compare(ros[k], ref[k], f"{path}{k}.", status)
        return out
    p = path.rstrip(".")
    if isinstance(ref, list) or isinstance(ros, list):
        if not isinstance(ros, list) or not isinstance(ref, list) or len(ros) != len(ref):
            return [f"{p}: {ros!r} vs solve {ref!r}"]
        for i, (a, b) in enumerate(zip(ros, ref)):
            out += compare(a, b, f"{p}[{i}].", status)
        return out
    if ros is None or ref is None:
        return [] if ros is None and ref is None else [f"{p}: {ros!r} vs solve {ref!r}"]
    if isinstance(ref, bool) or isinstance(ref, str) or isinstance(ros, str):
        return [] if ros == ref else [f"{p}: {ros!r} vs solve {ref!r}"]
    if isinstance(ref, (int, float)) and isinstance(ros, (int, float)):
        if ros == ref or math.isclose(ros, ref, rel_tol=REL_TOL, abs_tol=0.0):
            return []
        return [f"{p}: {ros!r} vs solve {ref!r} (rel diff {abs(ros - ref) / max(abs(ros), abs(ref)):.3g})"]
    return [] if ros == ref else [f"{p}: {ros!r} vs solve {ref!r}"]


def run_python(args: list[str], env: dict, timeout: float, **kw) -> subprocess.CompletedProcess:
    """`python ARGS` (an rclpy script), as subprocess.run with captured text output. A script still
    running after `timeout` fails the test with where it was: its threads' names and kernel wait
    channels, their native stacks when gdb is installed, and its Python stacks (faulthandler,
    printed on SIGABRT)."""
    p = subprocess.Popen([sys.executable, "-X", "faulthandler", *args], env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, **kw)
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        where = hung_process_report(p.pid)
        p.send_signal(signal.SIGABRT)
        try:
            out, err = p.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()
            out, err = p.communicate()
        raise AssertionError(f"{' '.join(args)} still running after {timeout:g} s\n{where}\n"
                             f"stdout:\n{out[-3000:]}\nstderr (Python stacks at the end):\n{err[-6000:]}") from None
    return subprocess.CompletedProcess(p.args, p.returncode, out, err)


def hung_process_report(pid: int) -> str:
    """The threads of a process that does not end: name and kernel wait channel of each, and the
    native stacks when gdb is on the machine."""
    lines = []
    for task in sorted(Path(f"/proc/{pid}/task").glob("*"), key=lambda t: int(t.name)):
        try:
            comm = (task / "comm").read_text().strip()
            wchan = (task / "wchan").read_text().strip()
        except OSError:
            continue
        lines.append(f"  thread {task.name} {comm!r}: waiting in {wchan or '-'}")
    report = "threads:\n" + "\n".join(lines)
    gdb = shutil.which("gdb")
    if gdb:
        try:
            r = subprocess.run([gdb, "-p", str(pid), "-batch", "-ex", "thread apply all bt 30"],
                               capture_output=True, text=True, timeout=60)
            report += "\nnative stacks (gdb):\n" + r.stdout[-12000:]
        except subprocess.TimeoutExpired:
            report += "\ngdb did not answer within 60 s"
    return report


def run_solve(lines: Iterable[dict], *flags: str, timeout: float = 120.0) -> list[dict]:
    """`grasp_orient solve FLAGS` on these candidates; one parsed answer per input line."""
    lines = list(lines)
    inp = "".join(json.dumps(c, allow_nan=False) + "\n" for c in lines)
    r = subprocess.run([str(binary_path()), "solve", *flags], input=inp, capture_output=True, text=True,
                       timeout=timeout)
    assert r.returncode == 0, f"grasp_orient solve {' '.join(flags)} exited {r.returncode}: {r.stderr[-2000:]}"
    out = [json.loads(l) for l in r.stdout.splitlines() if l.strip()]
    assert len(out) == len(lines), f"solve printed {len(out)} answers for {len(lines)} lines: {r.stderr[-2000:]}"
    return out


# ---------------------------------------------------------------------------------------------------
# The node as a subprocess
# ---------------------------------------------------------------------------------------------------
class NodeProcess:
    """`grasp_orient node ARGS` with its stderr collected; ready when a line contains "waiting for".
    `binary` defaults to the one under test (GRASP_ORIENT_BIN)."""

    def __init__(self, args: list[str], env: dict, cwd: Path, name: str = "grasp_orient node",
                 binary: Path | None = None, preexec_fn: Callable[[], None] | None = None):
        self.args = [str(binary or binary_path()), "node", *args]
        self.name = name
        self.lines: list[str] = []
        self._ready = threading.Event()
        self._lock = threading.Lock()
        self.proc = subprocess.Popen(self.args, env=env, cwd=str(cwd), stdin=subprocess.DEVNULL,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     errors="replace", bufsize=1, preexec_fn=preexec_fn)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            with self._lock:
                self.lines.append(line.rstrip("\n"))
            if READY_MARK in line:
                self._ready.set()

    def all_lines(self) -> list[str]:
        with self._lock:
            return list(self.lines)

    def wait_for_line(self, pattern: str, timeout: float = 10.0, after: int = 0) -> str:
        """The first line from index `after` on that matches the regex `pattern`; fails after `timeout`."""
        rx = re.compile(pattern)
        deadline = time.monotonic() + timeout
        while True:
            for line in self.all_lines()[after:]:
                if rx.search(line):
                    return line
            if time.monotonic() > deadline:
                raise AssertionError(f"{self.name}: no line matching {pattern!r} within {timeout} s; "
                                     f"output:\n{self.output()}")
            time.sleep(0.02)

    def output(self, last: int = 60) -> str:
        with self._lock:
            return "\n".join(l if len(l) <= 400 else l[:400] + " [...]" for l in self.lines[-last:])

    def wait_ready(self, timeout: float = READY_TIMEOUT_S):
        t0 = time.monotonic()
        while not self._ready.wait(0.1):
            if self.proc.poll() is not None:
                self._reader.join(2)
                pytest.fail(f"{self.name} exited with {self.proc.returncode} before printing "
                            f"{READY_MARK!r}; command {self.args}; output:\n{self.output()}", pytrace=False)
            if time.monotonic() - t0 > timeout:
                self.kill()
                pytest.fail(f"{self.name} did not print {READY_MARK!r} on stderr within {timeout:.0f} s; "
                            f"command {self.args}; output:\n{self.output()}", pytrace=False)

    def stop(self, sig=signal.SIGINT, timeout: float = EXIT_TIMEOUT_S) -> int:
        """Send `sig`, wait for the exit; returns the exit code (None-safe: kills after the timeout)."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.kill()
                self._reader.join(2)
                raise AssertionError(f"{self.name} did not exit within {timeout:.0f} s of {sig.name}; "
                                     f"output:\n{self.output()}")
        self._reader.join(2)
        return self.proc.returncode

    def stop_and_check(self, sig=signal.SIGINT):
        rc = self.stop(sig)
        assert rc == 0, f"{self.name} exited with {rc} after {sig.name} (expected 0); output:\n{self.output()}"

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)


@pytest.fixture(scope="session")
def grasp_bin() -> Path:
    return require_environment()


@pytest.fixture(scope="session")
def node_workdir(tmp_path_factory) -> Path:
    # The node records to record_dir (relative to its working directory): keep that out of the repository.
    return tmp_path_factory.mktemp("node_cwd")


@pytest.fixture(scope="session")
def start_node(grasp_bin, node_workdir):
    """Factory: start_node(*ros_args_or_flags) -> ready NodeProcess; every one is stopped (SIGINT, exit 0
    asserted) at the end of the session unless the test stopped it."""
    started: list[NodeProcess] = []

    def start(*args: str, name: str = "grasp_orient node", ready: bool = True,
              preexec_fn: Callable[[], None] | None = None) -> NodeProcess:
        n = NodeProcess(list(args), ros_env(DOMAIN_ID), node_workdir, name, preexec_fn=preexec_fn)
        started.append(n)
        _ALL_NODES.append(n)
        if ready:
            n.wait_ready()
        return n

    yield start
    errors = []
    for n in started:
        try:
            if n.proc.poll() is None:
                n.stop_and_check()
        except AssertionError as e:
            errors.append(str(e))
    assert not errors, "\n\n".join(errors)


@pytest.fixture(scope="session")
def grasp_node(start_node) -> NodeProcess:
    """The node under test with its defaults (`grasp_orient node`), shared by the session."""
    return start_node(name="grasp_orient node (default)")


# ---------------------------------------------------------------------------------------------------
# The rclpy peer
# ---------------------------------------------------------------------------------------------------
def reliable_qos(depth: int = 1000) -> "QoSProfile":
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                      durability=DurabilityPolicy.VOLATILE)


class Peer:
    """One rclpy node and its executor, spun by the caller (single thread)."""

    def __init__(self, name: str = "grasp_orient_test_peer", executor_factory: Callable | None = None):
        self.node = rclpy.create_node(name)
        self.executor = (executor_factory or SingleThreadedExecutor)()
        self.executor.add_node(self.node)

    def spin_until(self, cond: Callable[[], bool], timeout: float, step: float = 0.02) -> bool:
        deadline = time.monotonic() + timeout
        while True:
            if cond():
                return True
            if time.monotonic() >= deadline:
                return False
            self.executor.spin_once(timeout_sec=min(step, max(0.0, deadline - time.monotonic())))

    def spin_for(self, seconds: float):
        self.spin_until(lambda: False, seconds)

    def call(self, client, request, timeout: float = 10.0):
        assert client.wait_for_service(timeout_sec=timeout), f"service {client.srv_name} not available"
        fut = client.call_async(request)
        assert self.spin_until(fut.done, timeout), f"no reply from {client.srv_name} within {timeout} s"
        return fut.result()

    def destroy(self):
        self.executor.shutdown()
        self.node.destroy_node()


class GraspClient:
    """Publisher on NS/grasp_candidates, subscriber on NS/grip_recommendations; answers by candidate_id."""

    def __init__(self, peer: Peer, ns: str = "", depth: int = 1000):
        self.peer = peer
        self.ns = ns.rstrip("/")
        self.pub = peer.node.create_publisher(GraspCandidate, f"{self.ns}/grasp_candidates" if self.ns
                                              else "grasp_candidates", reliable_qos(depth))
        self.answers: dict[str, list] = {}
        self.order: list = []
        self.sub = peer.node.create_subscription(
            GripRecommendation, f"{self.ns}/grip_recommendations" if self.ns else "grip_recommendations",
            self._on_answer, reliable_qos(depth))
        self._probe = 0
        self.hook: Callable[[Any], None] | None = None  # when set, receives answers instead of the dicts

    def _on_answer(self, msg):
        if self.hook is not None:
            self.hook(msg)
            return
        self.answers.setdefault(msg.candidate_id, []).append(msg)
        self.order.append(msg)

    def matched(self) -> bool:
        return self.pub.get_subscription_count() > 0 and self.sub.get_publisher_count() > 0

    def wait_matched(self, timeout: float = 15.0):
        ok = self.peer.spin_until(self.matched, timeout)
        assert ok, (f"no match on {self.ns}/grasp_candidates within {timeout} s: "
                    f"{self.pub.get_subscription_count()} subscriptions matched our publisher, "
                    f"{self.sub.get_publisher_count()} publishers matched our subscriber "
                    f"(ROS_DOMAIN_ID={DOMAIN_ID}); graph: {self.peer.node.get_node_names_and_namespaces()}")

    def ensure_roundtrip(self, timeout: float = 15.0):
        """Match, then send a probe (`probe_candidate`, ids probe-N) until one is answered: both directions
        are live."""
        self.wait_matched(timeout)
        self._send_probes(timeout, None)

    def ensure_markers(self, markers: list, timeout: float = 15.0) -> int:
        """Send probes until one is answered and a probe's marker array has arrived in `markers` (the list a
        grip_markers subscription of this peer appends to). `get_publisher_count() > 0` on that subscription
        says only that we matched the node's writer; the node matches our reader when our announcement
        reaches it, a little later, and what it answers in between gets no published markers. Once a
        probe's markers are here, every later answer's are sent to us. Leave PROBE_FRAME out of the checks.
        Returns the number of probes sent."""
        self.wait_matched(timeout)
        return self._send_probes(timeout, markers)

    def _send_probes(self, timeout: float, markers: list | None) -> int:
        deadline = time.monotonic() + timeout
        sent = 0
        while time.monotonic() < deadline:
            self._probe += 1
            sent += 1
            probe = probe_candidate(f"probe-{self._probe}")
            self.pub.publish(candidate_msg(probe))
            if self.peer.spin_until(lambda: probe["id"] in self.answers and (
                    markers is None or any(is_probe_markers(m) for m in markers)), 1.0):
                return sent
        raise AssertionError(f"no answer to a probe on {self.ns}/grasp_candidates within {timeout} s"
                             if markers is None else
                             f"no probe answered with its markers on {self.ns}/grip_markers within {timeout} s "
                             f"({sent} probes sent, {len(markers)} marker arrays received)")

    def send_and_collect(self, cands: list[dict], timeout: float = 60.0, window: int = 50) -> dict[str, Any]:
        """Publish every candidate, at most `window` unanswered at a time (below the node's depth 100, so
        none can be pushed out of a keep-last history), and wait for one answer to each. Returns
        {id: answer}; asserts none is missing and none is answered twice."""
        ids = [c["id"] for c in cands]
        assert len(set(ids)) == len(ids), "candidate ids must be unique"
        for i in ids:
            self.answers.pop(i, None)
        pending = set()
        deadline = time.monotonic() + timeout
        idx = 0
        while idx < len(cands) or pending:
            while idx < len(cands) and len(pending) < window:
                self.pub.publish(candidate_msg(cands[idx]))
                pending.add(ids[idx])
                idx += 1
            self.peer.executor.spin_once(timeout_sec=0.05)
            pending = {i for i in pending if i not in self.answers}
            if time.monotonic() > deadline:
                break
        missing = [i for i in ids if i not in self.answers]
        assert not missing, (f"{len(missing)} of {len(ids)} candidates not answered within {timeout} s "
                             f"(first missing: {missing[:5]})")
        self.peer.spin_for(0.2)  # late duplicates would show up here
        dup = [i for i in ids if len(self.answers[i]) != 1]
        assert not dup, f"{len(dup)} candidates answered more than once: {dup[:5]}"
        return {i: self.answers[i][0] for i in ids}

    def send_one(self, cand: dict, timeout: float = 10.0):
        """Publish one candidate and return its answer (ids over 1024 bytes may come back cut)."""
        cid = cand["id"]

        def mine(a) -> bool:
            return a.candidate_id == cid or (len(cid) > 1024 and bool(a.candidate_id) and cid.startswith(a.candidate_id))

        n = len(self.order)
        self.pub.publish(candidate_msg(cand))
        ok = self.peer.spin_until(lambda: any(mine(a) for a in self.order[n:]), timeout)
        others = [a.candidate_id[:40] for a in self.order[n:] if not mine(a)]
        assert ok, f"no answer within {timeout} s to candidate {cid[:40]!r} (other answers: {others})"
        return next(a for a in self.order[n:] if mine(a))


@pytest.fixture(scope="session")
def rclpy_context():
    require_environment()
    rclpy.init()
    yield
    rclpy.try_shutdown()


@pytest.fixture(scope="session")
def peer(rclpy_context) -> Peer:
    p = Peer()
    yield p
    p.destroy()


@pytest.fixture(scope="session")
def client(peer, grasp_node) -> GraspClient:
    """A GraspClient talking to the default node, with the round trip checked once."""
    c = GraspClient(peer)
    c.ensure_roundtrip()
    return c


_ALL_NODES: list = []


def pytest_configure(config):
    # lark (pulled in by the rosidl tooling of the wheels) imports deprecated sre_* modules: not ours
    config.addinivalue_line("filterwarnings", "ignore:module 'sre_:DeprecationWarning")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """On a failure, attach the last lines of every node's stderr to the report."""
    outcome = yield
    rep = outcome.get_result()
    if rep.failed:
        for n in _ALL_NODES:
            rep.sections.append((f"{n.name} stderr (last lines, exit code {n.proc.poll()})", n.output(80)))
