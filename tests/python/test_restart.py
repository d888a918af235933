"""The daemon SIGKILLed and restarted mid-run. The Python client does what the C++ client
does: nothing by hand. Its topologies are transient-local, so the new service gets them
back and reports them REGISTERED again (status events); with resend_after, wait_forces
re-publishes the unanswered frame's states, and the run goes on. The same states give
the same forces bit for bit before and after the restart."""
import time

import numpy as np
import pytest

import tetcollide
from conftest import ball_at, running_daemon


@pytest.fixture
def own_daemon(domain, tmp_base):
    yield from running_daemon(domain, tmp_base, "python-restart-")


def test_the_run_survives_a_daemon_restart(own_daemon, ball, box):
    def states(f):  # frames 6..11 repeat the states of frames 0..5, 3 of them in contact
        return {"ball": ball_at(ball[0], 0.16 - 0.004 * (f % 6)), "box": box[0]}

    with tetcollide.Client("restart", domain=own_daemon.domain, resend_after=0.3) as c:
        assert c.wait_for_service(20.0)
        c.register("box", box[0], box[1], static=True)
        c.register("ball", ball[0], ball[1])
        assert c.wait_registered("box", 20.0).ok and c.wait_registered("ball", 20.0).ok
        before = {}
        for f in range(6):
            c.publish(f, states(f))
            answer = c.wait_forces(f, 20.0)
            assert answer is not None and answer.frame == f and answer.ok
            before[f] = answer
        # In contact: the comparison after the restart means something.
        assert all(len(before[f]["ball"].nodes) > 0 for f in (3, 4, 5))
        old_services = {e.service_id for e in c.status_events()}

        killed = time.monotonic()
        own_daemon.kill_hard()
        own_daemon.start()
        # The frames go on; the first one is answered once the new service has the
        # topologies back and wait_forces has re-sent its states.
        for f in range(6, 12):
            c.publish(f, states(f))
            answer = c.wait_forces(f, 30.0)
            assert answer is not None and answer.frame == f, own_daemon.log_text()
            assert answer.ok, answer
            if f == 6:
                recovery = time.monotonic() - killed
            old = before[f - 6]
            for name in ("ball", "box"):
                assert answer[name].nodes.tobytes() == old[name].nodes.tobytes()
                assert answer[name].forces.tobytes() == old[name].forces.tobytes()
                assert answer[name].stiffness.tobytes() == old[name].stiffness.tobytes()
        # The new service announced itself and registered both objects again by itself.
        events = c.status_events()
        new_services = {e.service_id for e in events
                        if e.state == tetcollide.StatusEvent.State.READY} - old_services
        assert len(new_services) == 1, events
        reregistered = {e.object for e in events if e.service_id in new_services
                        and e.kind == tetcollide.StatusEvent.Kind.REGISTERED and e.scene == "restart"}
        assert reregistered == {"ball", "box"}
        assert c.version("ball") == 1  # nothing was re-sent by the client
        print("[ figure ] daemon SIGKILLed and restarted: next frame answered %.0f ms after the kill"
              % (recovery * 1e3))
