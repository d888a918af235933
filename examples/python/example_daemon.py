"""Runs an example against tetcollided: a private daemon it starts and stops, or one
already running (--connect), over loopback-only DDS unless CYCLONEDDS_URI says otherwise.
"""
import os
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

DAEMON_CONFIG = """version: 1
dds:
  status_period_s: 0.5
pipeline:
  compute_stiffness: true   # the 3x3 blocks the examples integrate with
log:
  level: warn
  timing_summary_period_s: 0
"""


def add_daemon_arguments(parser):
    parser.add_argument("--daemon", default=str(ROOT / "build" / "bin" / "tetcollided"),
                        help="tetcollided to start (default: the build tree's)")
    parser.add_argument("--connect", action="store_true",
                        help="use a daemon already running on --domain")
    parser.add_argument("--domain", type=int, default=None,
                        help="DDS domain (default: from the pid)")


def start_daemon(daemon, domain, directory):
    config = Path(directory) / "tetcollided.yaml"
    config.write_text(DAEMON_CONFIG)
    log = open(Path(directory) / "tetcollided.log", "wb")
    return subprocess.Popen([daemon, "--config", str(config), "--domain", str(domain)],
                            stdout=log, stderr=log)


def run_with_daemon(args, run):
    """Calls run(args) with a daemon on args.domain; returns its exit code."""
    if args.domain is None:
        args.domain = 10 + os.getpid() % 220
    # Loopback-only DDS unless the caller chose a configuration.
    os.environ.setdefault("CYCLONEDDS_URI", "file://" + str(ROOT / "config" / "cyclonedds.xml"))
    if args.connect:
        return run(args)
    with tempfile.TemporaryDirectory(prefix="tetcollide-example-") as d:
        daemon = start_daemon(args.daemon, args.domain, d)
        try:
            return run(args)
        finally:
            daemon.terminate()
            daemon.wait(timeout=20)
