"""examples/python/drop_ball.py, run as the README says (it starts its own daemon): the
ball falls, bounces and comes to rest on the box with the contact carrying its weight."""
import csv
import os
import subprocess
import sys

import numpy as np

from conftest import SOURCE_DIR, private_domain


def run_example(script, out):
    """Runs examples/python/<script> as the README says (its own daemon, a private domain),
    writing into `out`; asserts it exited 0."""
    run = subprocess.run(
        [sys.executable, str(SOURCE_DIR / "examples" / "python" / script),
         "--daemon", os.environ["TC_DAEMON"], "--domain", str(private_domain()), "--out", str(out)],
        capture_output=True, text=True, timeout=150)
    assert run.returncode == 0, run.stdout + run.stderr
    return run


def test_drop_ball_comes_to_rest_on_the_box(workdir):
    out = workdir / "out"
    run = run_example("drop_ball.py", out)
    assert "outputs in" in run.stdout
    assert (out / "drop_ball.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with open(out / "trajectory.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 700
    col = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
    weight = col["weight_n"][0]
    # Free fall first (no contact, g within 1%), then contact: the force peaks above the
    # weight at the impact, the ball goes up again, and at the end the contact carries
    # the weight (mean of the last 0.2 s within 30%) with the ball nearly still.
    free = col["contact_nodes"] == 0
    assert free[:50].all()
    v, t = col["velocity_z_m_s"], col["time_s"]
    assert abs((v[50] - v[10]) / (t[50] - t[10]) + 9.81) < 0.1
    assert col["contact_force_z_n"].max() > 2 * weight
    assert (v[np.argmax(col["contact_force_z_n"]):] > 0.1).any()  # a bounce
    assert abs(col["contact_force_z_n"][-200:].mean() / weight - 1.0) < 0.3
    assert abs(v[-1]) < 0.05
    assert 0.12 < col["lowest_z_m"][-1] < 0.15


def test_tool_drag_reports_the_forces_on_a_rigid_stl_tool(workdir):
    """examples/python/tool_drag.py: a surface object (probe.stl) moved by a script into and
    across a soft organ. Checked here from its CSV, apart from the script's own checks."""
    out = workdir / "out"
    run_example("tool_drag.py", out)
    assert (out / "tool_drag.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with open(out / "tool_forces.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 950
    col = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
    t, z = col["time_s"], col["tool_z_m"]
    fx, fy, fz = col["force_x_n"], col["force_y_n"], col["force_z_n"]
    # Nothing before the tip reaches the organ's top (z = 0.15 m), nothing once lifted off.
    away = z > 0.151
    assert (fz[away & (t < 0.5)] == 0).all() and (col["contact_vertices"][away & (t < 0.5)] == 0).all()
    assert fz[-50:].max() == 0
    # Held 2 cm in on the flat top: pushed up, and the sideways part (the friction of the
    # organ's surface settling under the tip, mu = 0.3) inside the Coulomb cone.
    hold = (t >= 0.2) & (t < 0.25)
    assert (fz[hold] > 100).all()
    assert (np.hypot(fx[hold], fy[hold]) <= 0.3 * fz[hold]).all()
    # Pressed all along the drag; the organ got the opposite force. Sliding (after the
    # first 50 ms of the drag), the mean force against the +x motion is mu = 0.3 times the
    # mean push within 5 %. Frame by frame it swings (0.18-0.41 of the push in one run) as
    # the tip crosses the coarse organ's tilted faces, whose normal pushes have an x part.
    drag = (t >= 0.25) & (t < 0.75)
    assert (fz[drag] > 0).all()
    sliding = (t >= 0.30) & (t < 0.75)
    assert abs(-fx[sliding].mean() / fz[sliding].mean() - 0.3) <= 0.05 * 0.3
    assert np.allclose(col["organ_force_z_n"], -fz, rtol=1e-9, atol=1e-9)
    # The driver did positive work; the organ keeps no more than that.
    work = col["driver_work_j"][-1]
    assert work > 0
    assert col["organ_energy_j"][-1] <= work
