#!/usr/bin/env python3
"""Presses a rigid STL tool into a soft organ and drags it across, through tetcollided.

The tool is data/meshes/probe.stl (a 3 cm-radius probe with a round tip, 674 vertices),
registered as a *surface object* (docs/SURFACES.md); the organ is data/meshes/box.msh
(1 x 1 x 0.3 m, top face at z = 0.15 m) as a mass-spring body (mass_spring.py) pinned at
its bottom face, without gravity (it lies on a rigid table). The tool is kinematic: a
scripted trajectory moves it down onto the organ, presses it 2 cm in, drags it 15 cm
along x, and lifts it off. Every frame the simulator publishes both states, waits for
the forces and applies the organ's (with its stiffness blocks, linearly implicitly); the
forces on the tool's vertices, summed, are what a haptic loop would read and render.

Writes <out>/tool_forces.csv (one row per frame: the tool's pose, the force on it, the
organ's energy, the driver's work, the round trip) and <out>/tool_drag.png.

    python3 examples/python/tool_drag.py                  # starts build/bin/tetcollided
    python3 examples/python/tool_drag.py --connect --domain 7   # a daemon already running

Exit code 0 when the physics checks pass, 1 (naming the check) otherwise: no force
before the tip reaches the organ, an upward force while pressed, action = reaction on
every frame, no inverted organ tet, no energy from nowhere (the organ ends with no
more than the driver's work on it), and Coulomb's law while the tool slides: with
--friction MU (default 0.3) the force against the drag is MU times the force pressing
the tool up, within 5 % (0 = frictionless: then under 1 % of it).
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

ORGAN_TOP = 0.15  # m, the top face of data/meshes/box.msh
START_X = -0.1    # m, where the tool comes down


def waypoints(press):
    """The tool tip's scripted trajectory: (time s, x, y, z) corners, moved linearly."""
    top = ORGAN_TOP
    return np.array([
        [0.00, START_X, 0.0, top + 0.03],          # 3 cm above the organ
        [0.10, START_X, 0.0, top],                 # touching
        [0.20, START_X, 0.0, top - press],         # pressed in
        [0.25, START_X, 0.0, top - press],         # held
        [0.75, START_X + 0.15, 0.0, top - press],  # dragged 15 cm along x
        [0.85, START_X + 0.15, 0.0, top + 0.02],   # lifted off
        [0.95, START_X + 0.15, 0.0, top + 0.02],   # away: the organ settles
    ])


def tip_at(path, t):
    """Tip position and velocity at time t (piecewise linear; velocity of the segment)."""
    k = min(max(np.searchsorted(path[:, 0], t, side="right") - 1, 0), len(path) - 2)
    t0, t1 = path[k, 0], path[k + 1, 0]
    velocity = (path[k + 1, 1:] - path[k, 1:]) / (t1 - t0)
    return path[k, 1:] + (min(t, t1) - t0) * velocity, velocity


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t = np.array([r["time_s"] for r in rows])
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    top.plot(t, [r["tool_z_m"] for r in rows], label="tool tip z")
    top.axhline(ORGAN_TOP, color="grey", linestyle="--", label="organ top at rest")
    top.set_ylabel("height (m)")
    top.legend()
    top.set_title("A rigid STL tool pressed into and dragged across a soft organ")
    for key, label in (("force_x_n", "x"), ("force_y_n", "y"), ("force_z_n", "z")):
        bottom.plot(t, [r[key] for r in rows], label="force on the tool, " + label)
    bottom.set_ylabel("force (N)")
    bottom.set_xlabel("time (s)")
    bottom.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def run(args):
    organ_nodes, organ_tets = tetcollide.read_mesh(ROOT / "data" / "meshes" / "box.msh")
    tool_rest, tool_triangles = tetcollide.read_surface(ROOT / "data" / "meshes" / "probe.stl")
    # probe.stl has its tip's lowest point at the origin: the tool's nodes are the tip
    # position plus these offsets.
    pinned = organ_nodes[:, 2] < organ_nodes[:, 2].min() + 1e-9
    organ = MassSpring(organ_nodes, organ_tets, pinned=pinned)
    path = waypoints(args.press)
    h = args.step
    frames = int(round(path[-1, 0] / h))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    failures = []
    rows = []
    energy0 = organ.energy(gravity=0.0)
    work = 0.0  # done by the driver moving the tool against the contact force, J
    with tetcollide.Client("tool_drag", domain=args.domain, resend_after=0.5) as client:
        if not client.wait_for_service(20.0):
            print("tool_drag: no tetcollided on domain %d" % args.domain, file=sys.stderr)
            return 1
        tip, tip_velocity = tip_at(path, 0.0)
        client.register("organ", organ_nodes, organ_tets, stiffness=args.stiffness,
                        damping=args.damping, friction=args.friction, blocks=True)
        client.register_surface("tool", tool_rest + tip, tool_triangles,
                                stiffness=args.stiffness, damping=args.damping,
                                friction=args.friction)
        for name in ("organ", "tool"):
            client.wait_registered(name, 20.0).check(name)
        tool_velocity = np.zeros_like(tool_rest)
        for frame in range(frames):
            t = frame * h
            tip, tip_velocity = tip_at(path, t)
            tool_x = tool_rest + tip
            tool_velocity[:] = tip_velocity
            start = time.perf_counter()
            client.publish(frame, {"organ": organ.x, "tool": tool_x},
                           {"organ": organ.v, "tool": tool_velocity})
            answer = client.wait_forces(frame, 10.0)
            round_trip = time.perf_counter() - start
            if answer is None:
                print("tool_drag: no answer to frame %d" % frame, file=sys.stderr)
                return 1
            answer.raise_for_status()
            on_tool = answer["tool"].forces.sum(axis=0)
            on_organ = answer["organ"]
            organ_total = on_organ.forces.sum(axis=0)
            organ.apply_contact(on_organ.nodes, on_organ.forces, on_organ.stiffness, h,
                                on_organ.damping)
            organ.step(h, args.substeps, gravity=0.0)
            next_tip = tip_at(path, t + h)[0]
            work -= float(on_tool @ (next_tip - tip))
            energy = organ.energy(gravity=0.0) - energy0
            rows.append({"frame": frame, "time_s": t, "tool_x_m": tip[0], "tool_y_m": tip[1],
                         "tool_z_m": tip[2], "force_x_n": on_tool[0], "force_y_n": on_tool[1],
                         "force_z_n": on_tool[2], "contact_vertices": len(answer["tool"].nodes),
                         "organ_force_z_n": organ_total[2], "organ_energy_j": energy,
                         "driver_work_j": work, "round_trip_ms": round_trip * 1e3})
            # Action = reaction: the service's forces of one pair sum to zero.
            scale = max(1.0, float(np.abs(on_tool).max()))
            if np.abs(on_tool + organ_total).max() > 1e-9 * scale:
                failures.append("frame %d: force on the tool %s and on the organ %s do not balance"
                                % (frame, on_tool, organ_total))
            if not np.isfinite(organ.x).all():
                failures.append("frame %d: the organ's positions went non-finite" % frame)
                break
            if organ.min_volume_ratio() <= 0.0:
                failures.append("frame %d: an organ tet inverted" % frame)
                break
    with open(out / "tool_forces.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    if not args.no_plot:
        plot(rows, out / "tool_drag.png")

    col = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    t, z = col["time_s"], col["tool_z_m"]
    force = np.stack([col["force_x_n"], col["force_y_n"], col["force_z_n"]], axis=1)
    approach = (t < path[1, 0]) & (z > ORGAN_TOP + 1e-3)
    if np.any(force[approach] != 0.0):
        failures.append("force on the tool before its tip reached the organ")
    pressed = (t >= path[2, 0]) & (t < path[4, 0])
    if not np.all(force[pressed, 2] > 0.0):
        failures.append("the organ did not push the pressed tool up on every frame")
    # Driver work: the organ cannot end with more energy than the tool put in (the tool
    # is off the organ at the end, so no contact energy is left over).
    if force[-1].any():
        failures.append("the tool still touches the organ at the end")
    if col["organ_energy_j"][-1] > work + 1e-3 * abs(work) + 1e-9:
        failures.append("the organ ends with %.6g J, more than the %.6g J the tool did on it"
                        % (col["organ_energy_j"][-1], work))
    trips = col["round_trip_ms"]
    hold = (t >= path[2, 0]) & (t < path[3, 0])
    drag = (t >= path[3, 0]) & (t < path[4, 0])
    # Sliding: the drag after its first 50 ms (the organ's surface has caught up).
    sliding = (t >= path[3, 0] + 0.05) & (t < path[4, 0])
    against = -force[sliding, 0].mean()  # friction on the tool opposes its +x motion
    pressing = force[sliding, 2].mean()
    ratio = against / pressing
    if args.friction > 0.0 and abs(ratio - args.friction) > 0.05 * args.friction:
        failures.append("while sliding the force against the drag is %.4g x the normal force,"
                        " not mu = %.4g within 5 %%" % (ratio, args.friction))
    if args.friction == 0.0 and abs(ratio) > 0.01:
        failures.append("frictionless, yet the force against the drag is %.4g x the normal"
                        " force" % ratio)
    print("tool_drag: %d frames of %.1f ms; tool pressed %.0f mm: force on it %.1f N up while held,"
          " %.1f N along x while dragged (mean), peak %.1f N; sliding: %.4g x the normal force"
          " (mu = %.3g); driver work %.4g J, organ energy at the end %.4g J; round trip p50"
          " %.2f ms, max %.2f ms; outputs in %s"
          % (len(rows), h * 1e3, args.press * 1e3, force[hold, 2].mean(), force[drag, 0].mean(),
             np.linalg.norm(force, axis=1).max(), ratio, args.friction, work,
             col["organ_energy_j"][-1], np.median(trips), trips.max(), out))
    for failure in failures:
        print("tool_drag: FAILED: " + failure, file=sys.stderr)
    return 1 if failures else 0


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_daemon_arguments(p)
    p.add_argument("--step", type=float, default=0.001, help="seconds per frame (default 0.001)")
    p.add_argument("--substeps", type=int, default=4, help="explicit substeps per frame (default 4)")
    p.add_argument("--press", type=float, default=0.02, help="how deep the tip goes, m (default 0.02)")
    p.add_argument("--stiffness", type=float, default=3e5, help="contact stiffness, N/m^2")
    p.add_argument("--damping", type=float, default=100.0, help="contact damping, N s/m^2")
    p.add_argument("--friction", type=float, default=0.3,
                   help="Coulomb coefficient of the tool and the organ (default 0.3)")
    p.add_argument("--out", default="out/python_tool_drag", help="output directory")
    p.add_argument("--no-plot", action="store_true", help="write the CSV only")
    return run_with_daemon(p.parse_args(), run)


if __name__ == "__main__":
    sys.exit(main())
