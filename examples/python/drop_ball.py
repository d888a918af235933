#!/usr/bin/env python3
"""Drops a soft ball on the box through tetcollided: a small NumPy simulator.

The ball (data/meshes/ball.msh, radius 0.2 m) is a mass-spring network on the edges of
its tets, integrated explicitly in substeps; the box (data/meshes/box.msh, top face at
z = 0.15 m) is static. Every frame the simulator publishes the ball's positions and
velocities, waits for that frame's contact forces and 3x3 stiffness blocks, and applies
them linearly implicitly per node:

    (m I - h^2 K_i) dv_i = h f_i + h^2 K_i v_i        (h: the frame's step)

so that a stiff contact does not need a small step. Writes <out>/trajectory.csv (one row
per frame) and <out>/drop_ball.png (heights and contact force over time).

    python3 examples/python/drop_ball.py                  # starts build/bin/tetcollided
    python3 examples/python/drop_ball.py --connect --domain 7   # a daemon already running

Needs the module on the path: PYTHONPATH=build/python (the build tree) or an installed
tetcollide. Exit code 0 when the ball came to rest on the box, 1 otherwise.
"""
import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import tetcollide

ROOT = Path(__file__).resolve().parents[2]
BOX_TOP = 0.15  # m, the top face of data/meshes/box.msh

DAEMON_CONFIG = """version: 1
dds:
  status_period_s: 0.5
pipeline:
  compute_stiffness: true   # the 3x3 blocks this simulator integrates with
log:
  level: warn
  timing_summary_period_s: 0
"""


class Ball:
    """A mass-spring ball: lumped tet masses, one damped spring per tet edge."""

    def __init__(self, nodes, tets, density=1000.0, spring=2.0e4, spring_damping=5.0, bulk=2.0e5):
        self.x = nodes.copy()
        self.v = np.zeros_like(nodes)
        self.tets = tets
        self.volume = self.volumes_and_gradients()[0]
        self.mass = np.bincount(tets.ravel(), np.repeat(density * self.volume / 4.0, 4), len(nodes))
        self.bulk = bulk
        pairs = tets[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]].reshape(-1, 2)
        self.edges = np.unique(np.sort(pairs, axis=1), axis=0)
        self.rest = np.linalg.norm(nodes[self.edges[:, 1]] - nodes[self.edges[:, 0]], axis=1)
        self.spring = spring
        self.spring_damping = spring_damping

    def volumes_and_gradients(self):
        """Signed tet volumes (m,) and their gradients by node (m, 4, 3)."""
        a, b, c, d = (self.x[self.tets[:, i]] for i in range(4))
        gb = np.cross(c - a, d - a) / 6.0
        gc = np.cross(d - a, b - a) / 6.0
        gd = np.cross(b - a, c - a) / 6.0
        volume = np.einsum("ij,ij->i", gd, d - a)
        return volume, np.stack([-(gb + gc + gd), gb, gc, gd], axis=1)

    def internal_forces(self):
        i, j = self.edges[:, 0], self.edges[:, 1]
        d = self.x[j] - self.x[i]
        length = np.linalg.norm(d, axis=1)
        u = d / length[:, None]
        rate = np.einsum("ij,ij->i", self.v[j] - self.v[i], u)
        f = (self.spring * (length - self.rest) + self.spring_damping * rate)[:, None] * u
        n = len(self.x)
        total = np.stack([np.bincount(i, f[:, k], n) - np.bincount(j, f[:, k], n) for k in range(3)],
                         axis=1)
        # Volume springs, E = bulk / 2 (V - V0)^2 / V0 per tet: they keep tets from inverting
        # where edge springs alone would let a tet flatten through itself.
        volume, gradient = self.volumes_and_gradients()
        fv = -(self.bulk * (volume - self.volume) / self.volume)[:, None, None] * gradient
        nodes = self.tets.ravel()
        fv = fv.reshape(-1, 3)
        return total + np.stack([np.bincount(nodes, fv[:, k], n) for k in range(3)], axis=1)

    def apply_contact(self, nodes, forces, stiffness, h):
        """Linearly implicit contact impulse on the nodes in contact (k,), (k, 3), (k, 3, 3)."""
        if len(nodes) == 0:
            return
        m = self.mass[nodes][:, None, None] * np.eye(3)
        lhs = m - h * h * stiffness
        rhs = h * forces + h * h * np.einsum("kij,kj->ki", stiffness, self.v[nodes])
        self.v[nodes] += np.linalg.solve(lhs, rhs[:, :, None])[:, :, 0]

    def step(self, h, substeps, gravity=9.81):
        dt = h / substeps
        for _ in range(substeps):
            a = self.internal_forces() / self.mass[:, None]
            a[:, 2] -= gravity
            self.v += dt * a
            self.x += dt * self.v


def start_daemon(daemon, domain, directory):
    config = Path(directory) / "tetcollided.yaml"
    config.write_text(DAEMON_CONFIG)
    log = open(Path(directory) / "tetcollided.log", "wb")
    proc = subprocess.Popen([daemon, "--config", str(config), "--domain", str(domain)],
                            stdout=log, stderr=log)
    return proc


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t = np.array([r["time_s"] for r in rows])
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    top.plot(t, [r["centre_z_m"] for r in rows], label="centre")
    top.plot(t, [r["lowest_z_m"] for r in rows], label="lowest node")
    top.axhline(BOX_TOP, color="grey", linestyle="--", label="box top")
    top.set_ylabel("height (m)")
    top.legend()
    top.set_title("Ball dropped on the box through tetcollided")
    bottom.plot(t, [r["contact_force_z_n"] for r in rows], color="C3")
    bottom.axhline(rows[0]["weight_n"], color="grey", linestyle="--", label="weight")
    bottom.set_ylabel("contact force z (N)")
    bottom.set_xlabel("time (s)")
    bottom.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def run(args):
    ball_nodes, ball_tets = tetcollide.read_mesh(ROOT / "data" / "meshes" / "ball.msh")
    box_nodes, box_tets = tetcollide.read_mesh(ROOT / "data" / "meshes" / "box.msh")
    ball_nodes = ball_nodes + np.array([0.0, 0.0, args.height + BOX_TOP - ball_nodes[:, 2].min()])
    ball = Ball(ball_nodes, ball_tets)
    weight = ball.mass.sum() * 9.81
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tetcollide.Client("drop_ball", domain=args.domain, resend_after=0.5) as client:
        if not client.wait_for_service(20.0):
            print("drop_ball: no tetcollided on domain %d" % args.domain, file=sys.stderr)
            return 1
        client.register("box", box_nodes, box_tets, static=True)
        client.register("ball", ball_nodes, ball_tets, stiffness=args.stiffness,
                        damping=args.damping)
        for name in ("box", "ball"):
            client.wait_registered(name, 20.0).check(name)
        h = args.step
        for frame in range(args.frames):
            start = time.perf_counter()
            client.publish(frame, {"ball": ball.x}, {"ball": ball.v})
            answer = client.wait_forces(frame, 10.0)
            round_trip = time.perf_counter() - start
            if answer is None:
                print("drop_ball: no answer to frame %d" % frame, file=sys.stderr)
                return 1
            if not answer.ok:  # the reason is on the status topic
                client.poll(0.5)
                for e in client.status_events():
                    if e.kind == tetcollide.StatusEvent.Kind.ERROR and e.scene == "drop_ball":
                        print("drop_ball: the service: %s" % e.message, file=sys.stderr)
                answer.raise_for_status()
            contact = answer["ball"]
            ball.apply_contact(contact.nodes, contact.forces, contact.stiffness, h)
            ball.step(h, args.substeps)
            rows.append({"frame": frame, "time_s": (frame + 1) * h,
                         "centre_z_m": ball.x[:, 2].mean(), "lowest_z_m": ball.x[:, 2].min(),
                         "velocity_z_m_s": ball.v[:, 2].mean(), "contact_nodes": len(contact.nodes),
                         "contact_force_z_n": contact.forces[:, 2].sum(), "weight_n": weight,
                         "round_trip_ms": round_trip * 1e3})
            if not np.isfinite(ball.x).all():
                print("drop_ball: the simulation blew up at frame %d" % frame, file=sys.stderr)
                return 1
    with open(out / "trajectory.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    if not args.no_plot:
        plot(rows, out / "drop_ball.png")
    last = rows[-1]
    trips = np.array([r["round_trip_ms"] for r in rows])
    print("drop_ball: %d frames of %.1f ms; lowest node %.4f m (box top %.2f), centre speed %.3f m/s;"
          " round trip p50 %.2f ms, max %.2f ms; outputs in %s"
          % (len(rows), h * 1e3, last["lowest_z_m"], BOX_TOP, abs(last["velocity_z_m_s"]),
             np.median(trips), trips.max(), out))
    resting = abs(last["velocity_z_m_s"]) < 0.05 and BOX_TOP - 0.03 < last["lowest_z_m"] < BOX_TOP + 0.01
    if not resting:
        print("drop_ball: the ball did not come to rest on the box", file=sys.stderr)
    return 0 if resting else 1


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--daemon", default=str(ROOT / "build" / "bin" / "tetcollided"),
                   help="tetcollided to start (default: the build tree's)")
    p.add_argument("--connect", action="store_true", help="use a daemon already running on --domain")
    p.add_argument("--domain", type=int, default=None, help="DDS domain (default: from the pid)")
    p.add_argument("--frames", type=int, default=700, help="frames to simulate (default 700)")
    p.add_argument("--step", type=float, default=0.001, help="seconds per frame (default 0.001)")
    p.add_argument("--substeps", type=int, default=4, help="explicit substeps per frame (default 4)")
    p.add_argument("--height", type=float, default=0.05, help="drop height above the box, m")
    p.add_argument("--stiffness", type=float, default=3e5, help="contact stiffness, N/m^2")
    p.add_argument("--damping", type=float, default=100.0, help="contact damping, N s/m^2")
    p.add_argument("--out", default="out/python_drop_ball", help="output directory")
    p.add_argument("--no-plot", action="store_true", help="write the CSV only")
    args = p.parse_args()
    if args.domain is None:
        args.domain = 10 + os.getpid() % 220
    # Loopback-only DDS unless the caller chose a configuration.
    os.environ.setdefault("CYCLONEDDS_URI", "file://" + str(ROOT / "config" / "cyclonedds.xml"))
    if args.connect:
        return run(args)
    with tempfile.TemporaryDirectory(prefix="drop_ball-") as d:
        daemon = start_daemon(args.daemon, args.domain, d)
        try:
            return run(args)
        finally:
            daemon.terminate()
            daemon.wait(timeout=20)


if __name__ == "__main__":
    sys.exit(main())
