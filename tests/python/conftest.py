"""Fixtures of the Python module's tests: a real tetcollided on a private DDS domain.

CTest runs each test file in its own process (and private network namespace when
tests/integration/run_isolated.sh can make one) with these variables set:
PYTHONPATH (the build tree's module), TC_DAEMON, TC_FORCES_REFERENCE, TC_SOURCE_DIR,
TC_TEST_TMP and CYCLONEDDS_URI (config/cyclonedds.xml, loopback only).
"""
import ctypes
import os
import re
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

import tetcollide

SOURCE_DIR = Path(os.environ.get("TC_SOURCE_DIR", Path(__file__).resolve().parents[2]))
MESHES = SOURCE_DIR / "data" / "meshes"

# The daemon of these tests: stiffness blocks on (the (k, 3, 3) path is tested too),
# status heartbeats often (a restarted service is seen quickly).
DAEMON_CONFIG = """version: 1
dds:
  status_period_s: 0.2
frames:
  assembly_wait_ms: 50
pipeline:
  compute_stiffness: true
log:
  level: info
  timing_summary_period_s: 0
"""


def private_domain():
    """A domain no other test process uses at the same time (as the C++ tests: from the
    pid, in [10, 229])."""
    return 10 + os.getpid() % 220


def _die_with_parent():
    # PR_SET_PDEATHSIG = 1: the daemon is killed when the test process dies.
    ctypes.CDLL(None).prctl(1, signal.SIGKILL)


class Daemon:
    """tetcollided as a child process; every wait is for its log line, bounded."""

    def __init__(self, directory, domain, config=DAEMON_CONFIG):
        self.dir = Path(directory)
        self.domain = domain
        self.config = self.dir / "tetcollided.yaml"
        self.config.write_text(config)
        self.log = self.dir / "daemon.log"
        self.proc = None
        self.starts = 0

    def start(self, timeout=20.0):
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                [os.environ["TC_DAEMON"], "--config", str(self.config), "--domain", str(self.domain)],
                stdout=log, stderr=log, preexec_fn=_die_with_parent)
        self.starts += 1
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.log_text().count("tetcollided ready") >= self.starts:
                return
            if self.proc.poll() is not None:
                break
            time.sleep(0.01)
        raise RuntimeError("tetcollided did not become ready:\n" + self.log_text())

    def kill_hard(self):
        self.proc.kill()
        self.proc.wait(timeout=20)

    def stop(self):
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    def log_text(self):
        return self.log.read_text(errors="replace") if self.log.exists() else ""


@pytest.fixture(scope="session")
def domain():
    return private_domain()


@pytest.fixture(scope="session")
def tmp_base():
    base = Path(os.environ.get("TC_TEST_TMP", tempfile.gettempdir()))
    base.mkdir(parents=True, exist_ok=True)
    return base


@pytest.fixture
def workdir(tmp_base):
    with tempfile.TemporaryDirectory(prefix="python-", dir=tmp_base) as d:
        yield Path(d)


def running_daemon(domain, tmp_base, prefix):
    """A started Daemon in a fresh directory under tmp_base; stopped when the generator
    closes (yield from it in a fixture)."""
    with tempfile.TemporaryDirectory(prefix=prefix, dir=tmp_base) as d:
        daemon = Daemon(d, domain)
        daemon.start()
        yield daemon
        daemon.stop()


@pytest.fixture(scope="module")
def daemon(domain, tmp_base):
    yield from running_daemon(domain, tmp_base, "python-daemon-")


@pytest.fixture
def scene(request):
    """A scene name of its own per test (one daemon serves a whole test file)."""
    return re.sub(r"[^A-Za-z0-9_]", "_", request.node.name)[:60]


@pytest.fixture
def client(daemon, scene):
    with tetcollide.Client(scene, domain=daemon.domain) as c:
        assert c.wait_for_service(20.0), "no READY service on domain %d" % daemon.domain
        yield c


@pytest.fixture(scope="session")
def ball():
    return tetcollide.read_mesh(MESHES / "ball.msh")


@pytest.fixture(scope="session")
def box():
    return tetcollide.read_mesh(MESHES / "box.msh")


def ball_at(ball_nodes, z_bottom):
    """The ball (radius 0.2, centred at the origin in ball.msh) with its lowest point at
    z_bottom; the box's top face is z = 0.15."""
    return ball_nodes + np.array([0.0, 0.0, z_bottom - ball_nodes[:, 2].min()])
