"""Every bad-input path of the module raises TypeError (wrong kind of object or dtype) or
ValueError (shape, range, name) naming the argument and what was expected, before
anything is sent. No daemon: the checks are the module's own."""
import numpy as np
import pytest

import tetcollide
from conftest import private_domain

N = 5  # nodes of the little mesh below
NODES = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=np.float64)
TETS = np.array([[0, 1, 2, 3], [1, 2, 3, 4]], dtype=np.int32)


@pytest.fixture(scope="module")
def client():
    with tetcollide.Client("bad_input", domain=private_domain()) as c:
        c.register("obj", NODES, TETS)
        yield c


REGISTER_CASES = [
    # (keyword arguments replacing the good ones, exception, message pattern)
    (dict(nodes=None), TypeError, r"nodes: expected a float64 array of shape \(n, 3\), got NoneType"),
    (dict(nodes=np.array([["a", "b", "c"]])), TypeError, r"nodes: expected .* got dtype <U1"),
    (dict(nodes=NODES[:, :2]), ValueError, r"nodes: expected shape \(n, 3\), got \(5, 2\)"),
    (dict(nodes=NODES.ravel()), ValueError, r"nodes: expected shape \(n, 3\), got \(15,\)"),
    (dict(nodes=NODES[None]), ValueError, r"nodes: expected shape \(n, 3\), got \(1, 5, 3\)"),
    (dict(nodes=np.zeros((0, 3))), ValueError, r"nodes: expected shape \(n, 3\) with n >= 4"),
    (dict(nodes=NODES[:3], tets=TETS[:1, :]), ValueError, r"nodes: expected shape \(n, 3\) with n >= 4, got \(3, 3\)"),
    (dict(nodes=NODES.astype(np.complex128)), TypeError, r"nodes: expected .* got dtype complex128"),
    (dict(tets=TETS.astype(np.float64)), TypeError,
     r"tets: expected an integer array of shape \(m, 4\), got dtype float64"),
    (dict(tets=TETS[:, :3]), ValueError, r"tets: expected shape \(m, 4\), got \(2, 3\)"),
    (dict(tets=TETS.ravel()), ValueError, r"tets: expected shape \(m, 4\), got \(8,\)"),
    (dict(tets=np.zeros((0, 4), dtype=np.int32)), ValueError, r"tets: expected shape \(m, 4\) with m >= 1"),
    (dict(tets=np.array([[0, 1, 2, 3], [1, 2, 3, 5]])), ValueError,
     r"tets\[1, 3\] = 5 is out of range: expected a node index in \[0, 5\)"),
    (dict(tets=np.array([[0, 1, -1, 3]])), ValueError, r"tets\[0, 2\] = -1 is out of range"),
    (dict(tets=np.array([[0, 1, 2, 2**40]])), ValueError, r"tets\[0, 3\] = 1099511627776 is out of range"),
    (dict(tets="0 1 2 3"), TypeError, r"tets: expected an integer array"),
    (dict(node_ids=np.arange(4)), ValueError, r"node_ids: expected shape \(5,\), got \(4,\)"),
    (dict(node_ids=np.zeros(5)), TypeError, r"node_ids: expected an integer array .* got dtype float64"),
    (dict(depth="fast"), ValueError, r"depth: expected 'cpfm', 'cffm' or 'exact', got 'fast'"),
    (dict(response="bounce"), ValueError, r"response: expected 'point', 'segment' or 'auto', got 'bounce'"),
    (dict(stiffness=-1.0), ValueError, r"stiffness: expected a finite value >= 0, got -1\.0$"),
    (dict(damping=float("nan")), ValueError, r"damping: expected a finite value >= 0, got nan$"),
    (dict(max_force=float("inf")), ValueError, r"max_force: expected a finite value >= 0"),
    (dict(object=""), ValueError, r"object: expected a non-empty name"),
    (dict(object="x" * 300), ValueError, r"object 'x+' is longer than \d+ bytes"),
]


@pytest.mark.parametrize("case", range(len(REGISTER_CASES)),
                         ids=[c[2][:40] for c in REGISTER_CASES])
def test_register_rejects(client, case):
    change, error, pattern = REGISTER_CASES[case]
    args = dict(object="case%d" % case, nodes=NODES, tets=TETS)  # a name of its own
    args.update(change)
    obj, nodes, tets = args.pop("object"), args.pop("nodes"), args.pop("tets")
    with pytest.raises(error, match=pattern):
        client.register(obj, nodes, tets, **args)
    assert client.version(obj) == 0  # nothing was sent


def test_register_converts_other_numeric_layouts_once(client):
    # Lists, int coordinates, Fortran order, int64/uint16 tets: accepted (converted).
    assert client.register("lists", NODES.astype(int).tolist(), TETS.tolist()) == 1
    assert client.register("fortran", np.asfortranarray(NODES), TETS.astype(np.uint16)) == 1
    assert client.register("strided", np.repeat(NODES, 2, axis=0)[::2], TETS.astype(np.int64),
                           node_ids=np.arange(N, dtype=np.uint8) + 1) == 1


GOOD = NODES + 0.5

PUBLISH_CASES = [
    (dict(frame=-1), ValueError, r"frame: expected a frame number >= 0, got -1"),
    (dict(positions=[GOOD]), TypeError, r"positions: expected a dict \{object: \(n, 3\) float64 array\}"),
    (dict(positions={}), ValueError, r"positions: expected at least one object"),
    (dict(positions={"nobody": GOOD}), ValueError, r"positions: object 'nobody' is not registered"),
    (dict(positions={1: GOOD}), TypeError, r"positions: expected str object names as keys"),
    (dict(positions={"obj": GOOD[:4]}), ValueError, r"positions\['obj'\]: expected shape \(5, 3\), got \(4, 3\)"),
    (dict(positions={"obj": GOOD.T}), ValueError, r"positions\['obj'\]: expected shape \(5, 3\), got \(3, 5\)"),
    (dict(positions={"obj": GOOD.ravel()}), ValueError, r"positions\['obj'\]: expected shape \(5, 3\), got \(15,\)"),
    (dict(positions={"obj": None}), TypeError, r"positions\['obj'\]: expected a float64 array of shape \(5, 3\)"),
    (dict(positions={"obj": GOOD.astype(bool)}), TypeError, r"positions\['obj'\]: .* got dtype bool"),
    (dict(velocities=[GOOD]), TypeError, r"velocities: expected a dict"),
    (dict(velocities={"other": GOOD}), ValueError, r"velocities: object 'other' has velocities but no positions"),
    (dict(velocities={"obj": GOOD[:, :1]}), ValueError, r"velocities\['obj'\]: expected shape \(5, 3\), got \(5, 1\)"),
]


@pytest.mark.parametrize("change, error, pattern", PUBLISH_CASES,
                         ids=[c[2][:40] for c in PUBLISH_CASES])
def test_publish_rejects(client, change, error, pattern):
    args = dict(frame=0, positions={"obj": GOOD}, velocities=None)
    args.update(change)
    with pytest.raises(error, match=pattern):
        client.publish(args["frame"], args["positions"], args["velocities"])


def test_publish_accepts_other_numeric_layouts(client):
    client.publish(1, {"obj": np.asfortranarray(GOOD)}, {"obj": np.zeros((N, 3), dtype=np.float32)})
    client.publish(2, {"obj": GOOD.astype(np.int64)})
    client.publish(3, {"obj": GOOD.tolist()})


@pytest.mark.parametrize("call, pattern", [
    (lambda c: c.wait_forces(0, -1.0), r"timeout: expected seconds in \[0, 1e9\], got -1\.0$"),
    (lambda c: c.wait_forces(0, float("nan")), r"timeout: expected seconds"),
    (lambda c: c.wait_registered("obj", 1e12), r"timeout: expected seconds"),
    (lambda c: c.wait_for_service(-0.5), r"timeout: expected seconds"),
    (lambda c: c.poll(-1.0), r"timeout: expected seconds"),
    (lambda c: c.unregister("nobody"), r"object: 'nobody' is not registered with this client"),
])
def test_waits_and_names_are_checked(client, call, pattern):
    with pytest.raises(ValueError, match=pattern):
        call(client)


@pytest.mark.parametrize("kwargs, error, pattern", [
    (dict(scene=""), ValueError, r"scene: expected a non-empty name"),
    (dict(scene="s" * 300), ValueError, r"scene '.*' is longer than \d+ bytes"),
    (dict(domain=233), ValueError, r"domain: expected a DDS domain id in \[0, 232\], got 233"),
    (dict(domain=-1), TypeError, r"incompatible constructor arguments"),
    (dict(config="/no/such/cyclonedds.xml"), ValueError, r"config: no such file: '/no/such/cyclonedds.xml'"),
    (dict(config=42), TypeError, r"config: expected a path, a file:// URI or Cyclone DDS XML"),
    (dict(resend_after=-1.0), ValueError, r"resend_after: expected seconds in \[0, 1e9\], got -1\.0$"),
])
def test_client_arguments_are_checked(kwargs, error, pattern):
    args = dict(scene="bad_input_ctor", domain=private_domain())
    args.update(kwargs)
    scene = args.pop("scene")
    with pytest.raises(error, match=pattern):
        tetcollide.Client(scene, **args)


def test_a_bad_cyclone_config_is_a_client_error():
    with pytest.raises(tetcollide.ClientError, match="dds_create_domain"):
        tetcollide.Client("bad_config", domain=private_domain(), config="<CycloneDDS><Nonsense/>")
