"""tetcollide.Client against a real tetcollided: registration, lock-step frames whose
forces equal the C++ client's bit for bit, a cut, the service's rejections as values, the
GIL released while waiting, closing."""
import os
import subprocess
import threading
import time

import numpy as np
import pytest

import tetcollide
from conftest import ball_at

FRAMES = 8


def ball_states(ball_nodes):
    """The ball sinking into the box's top face (z = 0.15) by 4 mm a frame, squashed a
    little so the states are not rigid motions, from 4 mm above it to 24 mm inside."""
    out = []
    for f in range(FRAMES):
        p = ball_at(ball_nodes, 0.154 - 0.004 * f)
        p[:, 0] *= 1.0 + 0.01 * f
        out.append(p)
    return out


def register_ball_and_box(c, ball, box):
    assert c.register("box", box[0], box[1], static=True) == 1
    assert c.register("ball", ball[0], ball[1]) == 1
    for name in ("box", "ball"):
        r = c.wait_registered(name, 20.0)
        assert r.done and r.ok, r
        r.check(name)


def test_registration_is_reported_and_versioned(client, scene, ball, box):
    register_ball_and_box(client, ball, box)
    assert client.version("ball") == 1 and client.version("box") == 1
    assert client.version("unknown") == 0
    registered = {(e.object, e.topology_version) for e in client.status_events()
                  if e.scene == scene and e.kind == tetcollide.StatusEvent.Kind.REGISTERED}
    assert {("ball", 1), ("box", 1)} <= registered
    # The answers of the rest positions: no contact, an empty (0, 3) array per object.
    client.publish(0, {"ball": ball_at(ball[0], 0.3), "box": box[0]})
    answer = client.wait_forces(0, 20.0)
    assert answer is not None and answer.frame == 0 and answer.ok
    assert sorted(answer) == ["ball", "box"] and len(answer) == 2 and "ball" in answer
    assert answer["ball"].forces.shape == (0, 3) and answer["ball"].nodes.shape == (0,)
    with pytest.raises(KeyError, match="nope"):
        answer["nope"]


def test_forces_equal_the_cpp_client_bit_for_bit(daemon, client, scene, ball, box, workdir):
    """The same lock-step frames through this module (this scene) and through
    libtetcollide_client (tests/python/forces_reference.cpp, another scene of the same
    daemon): nodes, forces and stiffness blocks byte for byte."""
    states = ball_states(ball[0])
    with open(workdir / "objects.txt", "w") as f:
        for name, (nodes, tets), static in (("box", box, 1), ("ball", ball, 0)):
            f.write("%s %d %d %d\n" % (name, len(nodes), len(tets), static))
            nodes.astype(np.float64).tofile(workdir / (name + ".nodes.f64"))
            tets.astype(np.int32).tofile(workdir / (name + ".tets.i32"))
    (workdir / "frames.txt").write_text("%d\n" % FRAMES)
    for f, p in enumerate(states):
        p.tofile(workdir / ("state_%d_ball.f64" % f))
        box[0].tofile(workdir / ("state_%d_box.f64" % f))
    reference = subprocess.run(
        [os.environ["TC_FORCES_REFERENCE"], "--domain", str(daemon.domain), "--scene", scene + "_cpp",
         "--dir", str(workdir)], capture_output=True, text=True, timeout=120)
    assert reference.returncode == 0, reference.stderr

    register_ball_and_box(client, ball, box)
    contacts = 0
    for f, p in enumerate(states):
        client.publish(f, {"ball": p, "box": box[0]})
        answer = client.wait_forces(f, 30.0)
        assert answer is not None and answer.frame == f and answer.ok, answer
        for name in ("ball", "box"):
            mine = answer[name]
            stem = workdir / ("cpp_%d_%s" % (f, name))
            cpp_nodes = np.fromfile(str(stem) + ".nodes.i32", dtype=np.int32)
            cpp_forces = np.fromfile(str(stem) + ".forces.f64", dtype=np.float64)
            cpp_stiffness = np.fromfile(str(stem) + ".stiffness.f64", dtype=np.float64)
            assert mine.nodes.dtype == np.int32 and mine.forces.dtype == np.float64
            assert mine.nodes.tobytes() == cpp_nodes.tobytes(), (f, name)
            assert mine.forces.shape == (len(cpp_nodes), 3)
            assert mine.forces.tobytes() == cpp_forces.tobytes(), (f, name)
            assert mine.stiffness.shape == (len(cpp_nodes), 3, 3)
            assert mine.stiffness.tobytes() == cpp_stiffness.tobytes(), (f, name)
            contacts += len(cpp_nodes)
        # Newton's third law over the pair: what the ball gets, the box gets back.
        total = answer["ball"].forces.sum(axis=0) + answer["box"].forces.sum(axis=0)
        scale = max(1.0, np.abs(answer["ball"].forces).sum())
        assert np.abs(total).max() <= 1e-9 * scale
    summary = (workdir / "cpp_summary.txt").read_text().split("\n")
    assert len([line for line in summary if line]) == 2 * FRAMES
    assert contacts > 100, "the frames must have contact for the comparison to mean anything"
    # The ball is pushed up, out of the box.
    assert answer["ball"].forces[:, 2].sum() > 0


def test_a_cut_replaces_the_topology(client, ball, box):
    register_ball_and_box(client, ball, box)
    nodes, tets = box
    # The cut: the box loses every tet with its centroid at x > 0.1; the nodes no tet
    # uses any more are dropped and the rest renumbered.
    keep = nodes[tets].mean(axis=1)[:, 0] <= 0.1
    used = np.unique(tets[keep])
    renumber = np.full(len(nodes), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    cut_nodes, cut_tets = nodes[used], renumber[tets[keep]]
    assert client.register("box", cut_nodes, cut_tets, static=True) == 2
    r = client.wait_registered("box", 20.0)
    assert r.ok, r
    assert client.version("box") == 2
    # The old node count is bad input now, locally.
    with pytest.raises(ValueError, match=r"positions\['box'\]: expected shape \(%d, 3\)" % len(used)):
        client.publish(1, {"box": nodes, "ball": ball[0]})
    # A ball over the part that was cut away touches nothing; over the rest it does.
    for frame, x in ((1, 0.35), (2, -0.25)):
        p = ball_at(ball[0], 0.13) + np.array([x, 0.0, 0.0])
        client.publish(frame, {"box": cut_nodes, "ball": p})
        answer = client.wait_forces(frame, 30.0)
        assert answer is not None and answer.ok, answer
        assert answer["box"].topology_version == 2 and answer["ball"].topology_version == 1
        touching = len(answer["ball"].nodes) > 0
        assert touching == (x < 0), (x, answer["ball"])
        assert answer["box"].nodes.max(initial=0) < len(used)
    # Explicit version numbers are sent as given.
    assert client.register("box", cut_nodes, cut_tets, static=True, version=7) == 7
    assert client.wait_registered("box", 20.0).ok


def test_service_rejections_are_values_and_check_raises(client, scene, ball, box):
    register_ball_and_box(client, ball, box)
    # Inverted tets: accepted locally (indices in range), rejected by the service.
    inverted = ball[1][:, [1, 0, 2, 3]]
    client.register("inverted", ball[0], inverted)
    r = client.wait_registered("inverted", 20.0)
    assert r.done and not r.ok and r.code == tetcollide.Status.INVALID_MESH
    assert "inverted" in r.message
    with pytest.raises(tetcollide.RejectedError, match="invalid_mesh") as e:
        r.check("inverted")
    assert e.value.object == "inverted" and e.value.code == 4 and e.value.code_name == "invalid_mesh"
    assert isinstance(e.value, RuntimeError)
    # A non-finite position: the answer carries the rejection, the status topic the reason.
    p = ball[0].copy()
    p[3, 1] = np.nan
    client.publish(0, {"ball": p, "box": box[0]})
    answer = client.wait_forces(0, 20.0)
    assert answer is not None and not answer.ok
    assert answer["ball"].status == tetcollide.Status.INVALID_MESH
    assert answer["ball"].status_name == "invalid_mesh"
    assert answer["box"].status == 0
    with pytest.raises(tetcollide.RejectedError, match="'ball': invalid_mesh"):
        answer.raise_for_status()
    deadline = time.monotonic() + 10
    errors = []
    while not errors and time.monotonic() < deadline:
        client.poll(0.1)
        errors = [e for e in client.status_events() if e.scene == scene and e.object == "ball"
                  and e.kind == tetcollide.StatusEvent.Kind.ERROR and e.frame == 0]
    assert errors and "node 3 has a non-finite position" in errors[0].message


def test_waiting_releases_the_gil(client, ball, box):
    register_ball_and_box(client, ball, box)
    ticks = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(time.monotonic())
            time.sleep(0.001)

    t = threading.Thread(target=tick)
    t.start()
    try:
        start = time.monotonic()
        assert client.wait_forces(99, 0.5) is None  # never published: a timeout
        end = time.monotonic()
    finally:
        stop.set()
        t.join()
    assert 0.45 <= end - start < 5.0
    # The thread ran all through the wait (it could not, were the GIL held by it).
    during = [x for x in ticks if start + 0.1 < x < end - 0.1]
    assert len(during) > 50, len(during)


def test_closing_removes_the_objects(daemon, scene, ball, box):
    with tetcollide.Client(scene, domain=daemon.domain) as watcher:
        assert watcher.wait_for_service(20.0)
        with tetcollide.Client(scene, domain=daemon.domain) as c:
            assert not c.closed
            c.register("ball", ball[0], ball[1])
            assert c.wait_registered("ball", 20.0).ok
            c.register("other", box[0], box[1], static=True)
            assert c.wait_registered("other", 20.0).ok
            c.unregister("other")
            with pytest.raises(ValueError, match="'other' is not registered"):
                c.publish(0, {"other": box[0]})
        assert c.closed
        c.close()  # idempotent
        for call in (lambda: c.wait_for_service(0.1), lambda: c.publish(0, {"ball": ball[0]}),
                     lambda: c.wait_forces(0, 0.1), lambda: c.status_events()):
            with pytest.raises(tetcollide.ClientError, match="closed"):
                call()
        removed = set()
        deadline = time.monotonic() + 20
        while removed != {"ball", "other"} and time.monotonic() < deadline:
            watcher.poll(0.1)
            removed |= {e.object for e in watcher.status_events()
                        if e.scene == scene and e.kind == tetcollide.StatusEvent.Kind.REMOVED}
        assert removed == {"ball", "other"}


def test_frame_stats_come_with_the_answers(client, ball, box):
    register_ball_and_box(client, ball, box)
    client.publish(0, {"ball": ball_at(ball[0], 0.14), "box": box[0]})
    assert client.wait_forces(0, 20.0) is not None
    deadline = time.monotonic() + 10
    stats = []
    while not stats and time.monotonic() < deadline:
        client.poll(0.1)
        stats = [s for s in client.frame_stats() if s.frame == 0]
    assert stats and stats[0].objects == 2 and stats[0].contacts > 0 and stats[0].max_depth > 0


def test_static_objects_are_written_first(client, ball, box):
    """A static object's state written after the non-static ones would be answered by a
    second computation after frames.assembly_wait_ms (50 ms here); the module writes static
    states first whatever the dict's order."""
    register_ball_and_box(client, ball, box)
    p = ball_at(ball[0], 0.3)
    times = []
    for f in range(12):
        start = time.monotonic()
        client.publish(f, {"ball": p, "box": box[0]})  # the static box last
        answer = client.wait_forces(f, 20.0)
        times.append(time.monotonic() - start)
        assert answer is not None and answer.frame == f and sorted(answer) == ["ball", "box"]
    assert np.median(times[2:]) < 0.025, times


def plate(n=4, width=0.2, z=0.14):
    """A square surface (n x n cells, two triangles each) centred on the box's top face
    (z = 0.15), at height z."""
    xs = np.linspace(-width / 2, width / 2, n + 1)
    nodes = np.array([[x, y, z] for y in xs for x in xs], dtype=np.float64)
    tris = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            tris += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    return nodes, np.array(tris, dtype=np.int32)


def test_a_surface_object_is_pushed_out_of_the_box(client, box):
    """register_surface (issue 19): every vertex of a plate 1 cm inside the box is pushed
    up, the box takes the reactions."""
    nodes, tris = plate()
    assert client.register("box", box[0], box[1], static=True) == 1
    assert client.register_surface("plate", nodes, tris, response="point") == 1
    for name in ("box", "plate"):
        client.wait_registered(name, 20.0).check(name)
    client.publish(0, {"plate": nodes})
    answer = client.wait_forces(0, 20.0)
    assert answer is not None and answer.ok
    on_plate, on_box = answer["plate"], answer["box"]
    assert on_plate.nodes.shape == (len(nodes),)
    assert np.all(on_plate.forces[:, 2] > 0.0)
    total = on_plate.forces.sum(axis=0) + on_box.forces.sum(axis=0)
    assert np.linalg.norm(total) < 1e-9 * np.linalg.norm(on_plate.forces.sum(axis=0))
    with pytest.raises(ValueError, match=r"triangles: expected shape \(m, 3\)"):
        client.register_surface("bad", nodes, np.zeros((2, 4), dtype=np.int32))
    with pytest.raises(ValueError, match=r"triangles\[1, 2\] = 99 is out of range"):
        client.register_surface("bad", nodes, np.array([[0, 1, 2], [1, 2, 99]]))


def test_friction_blocks_and_contacts_on_request(client, ball, box):
    """Protocol 3 from Python: a ball sinking into the box while sliding along x, friction
    0.5 on both, the ball asking for its blocks and its contacts, the box for neither."""
    assert client.register("box", box[0], box[1], static=True, friction=0.5) == 1
    assert client.register("ball", ball[0], ball[1], friction=0.5, blocks=True,
                           contacts=True) == 1
    for name in ("box", "ball"):
        client.wait_registered(name, 20.0).check(name)
    x = ball_at(ball[0], 0.14)  # 1 cm into the box's top face
    v = np.zeros_like(x)
    v[:, 0] = 0.2
    client.publish(0, {"ball": x, "box": box[0]}, {"ball": v})
    answer = client.wait_forces(0, 20.0)
    assert answer is not None and answer.ok
    on_ball = answer["ball"]
    k = len(on_ball.nodes)
    assert k > 0
    total = on_ball.forces.sum(axis=0)
    assert total[2] > 0 and total[0] < 0  # pushed up, held back against the slide
    assert on_ball.stiffness.shape == (k, 3, 3) and on_ball.damping.shape == (k, 3, 3)
    assert np.allclose(on_ball.damping, on_ball.damping.transpose(0, 2, 1))
    # (This daemon has pipeline.compute_stiffness on, so the box gets blocks too; that
    # only the asking object gets them is ServiceTest.FrictionAndPerObjectBlocks.)
    c = on_ball.contacts
    n = len(c)
    assert n > 0 and len(answer["box"].contacts) == 0
    assert c.node.shape == (n,) and c.nodes.shape == (n, 2) and c.weights.shape == (n, 2)
    assert c.tet.shape == (n,) and c.barycentric.shape == (n, 4) and c.depth.shape == (n,)
    assert c.normal.shape == (n, 3) and c.intrudes.shape == (n,) and c.other.shape == (n,)
    assert set(c.other) == {"box"}
    assert (c.depth >= 0).all() and np.allclose(np.linalg.norm(c.normal, axis=1), 1.0)
    assert np.allclose(c.barycentric.sum(axis=1), 1.0)
    # A point of the ball inside the box: its place from the ball's nodes is its place
    # from the box's tet.
    mine = c.intrudes
    assert mine.any()
    second = np.where(c.nodes[mine, 1] >= 0, c.nodes[mine, 1], 0)  # -1: a point contact
    point = (c.weights[mine, :1] * x[c.nodes[mine, 0]]
             + c.weights[mine, 1:] * x[second] * (c.nodes[mine, 1:] >= 0))
    corners = box[0][box[1][c.tet[mine]]]  # (m, 4, 3)
    inside = np.einsum("mk,mkj->mj", c.barycentric[mine], corners)
    assert np.allclose(point, inside, atol=1e-9)


def test_self_contact_of_one_object_made_of_two_balls(client, ball):
    """Self-contact from Python (issue 45): two balls overlapping by 2 cm registered as ONE
    object with self_contact=True are pushed apart along the line between their centres,
    the forces sum to zero, and the contact rows name the object itself."""
    nodes, tets = ball
    n = len(nodes)
    shift = 2 * 0.2 - 0.02  # radius 0.2: centres 38 cm apart, 2 cm of overlap
    two = np.vstack([nodes, nodes + [shift, 0.0, 0.0]])
    both = np.vstack([tets, tets + n])
    assert client.register("pair", two, both, self_contact=True, contacts=True,
                           response="point") == 1
    client.wait_registered("pair", 20.0).check("pair")
    client.publish(0, {"pair": two})
    answer = client.wait_forces(0, 20.0)
    assert answer is not None and answer.ok
    f = answer["pair"]
    assert len(f.nodes) > 0
    left = f.forces[f.nodes < n].sum(axis=0)
    right = f.forces[f.nodes >= n].sum(axis=0)
    assert left[0] < 0 < right[0]  # apart along x
    assert np.linalg.norm(left + right) < 1e-9 * np.linalg.norm(left)
    c = f.contacts
    assert len(c) > 0 and set(c.other) == {"pair"} and c.intrudes.all()
    assert (c.depth > 0).all() and (c.depth <= 0.02 + 1e-9).all()
