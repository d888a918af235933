#!/usr/bin/env python3
"""Drops a soft ball on the box through tetcollided: a small NumPy simulator.

The ball (data/meshes/ball.msh, radius 0.2 m) is a mass-spring network on the edges of
its tets (mass_spring.py), integrated explicitly in substeps; the box (data/meshes/box.msh, top face at
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
import sys
import time
from pathlib import Path

import numpy as np

import tetcollide
from example_daemon import ROOT, add_daemon_arguments, run_with_daemon
from mass_spring import MassSpring

BOX_TOP = 0.15  # m, the top face of data/meshes/box.msh


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
    ball = MassSpring(ball_nodes, ball_tets)
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
    add_daemon_arguments(p)
    p.add_argument("--frames", type=int, default=700, help="frames to simulate (default 700)")
    p.add_argument("--step", type=float, default=0.001, help="seconds per frame (default 0.001)")
    p.add_argument("--substeps", type=int, default=4, help="explicit substeps per frame (default 4)")
    p.add_argument("--height", type=float, default=0.05, help="drop height above the box, m")
    p.add_argument("--stiffness", type=float, default=3e5, help="contact stiffness, N/m^2")
    p.add_argument("--damping", type=float, default=100.0, help="contact damping, N s/m^2")
    p.add_argument("--out", default="out/python_drop_ball", help="output directory")
    p.add_argument("--no-plot", action="store_true", help="write the CSV only")
    args = p.parse_args()
    return run_with_daemon(args, run)


if __name__ == "__main__":
    sys.exit(main())
