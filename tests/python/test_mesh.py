"""tetcollide.read_mesh: shapes, dtypes, arrays that own the reader's buffers, errors."""
import sys

import numpy as np
import pytest

import tetcollide
from conftest import MESHES, SOURCE_DIR

TEST_MESHES = SOURCE_DIR / "tests" / "data" / "meshes"


def test_box_has_the_documented_counts_and_bounds():
    nodes, tets = tetcollide.read_mesh(str(MESHES / "box.msh"))
    assert nodes.shape == (907, 3) and nodes.dtype == np.float64
    assert tets.shape == (3276, 4) and tets.dtype == np.int32
    assert nodes.flags["C_CONTIGUOUS"] and tets.flags["C_CONTIGUOUS"]
    # data/meshes/README.md: box 1.0 x 1.0 x 0.3 centred at the origin
    np.testing.assert_allclose(nodes.min(axis=0), [-0.5, -0.5, -0.15], atol=1e-12)
    np.testing.assert_allclose(nodes.max(axis=0), [0.5, 0.5, 0.15], atol=1e-12)
    assert tets.min() == 0 and tets.max() == 906
    # Positively oriented tets (the reader never flips them; the file's are).
    a, b, c, d = (nodes[tets[:, i]] for i in range(4))
    volumes = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0
    assert (volumes > 0).all()
    assert volumes.sum() == pytest.approx(0.3, rel=1e-9)


def test_arrays_own_the_readers_buffers_without_a_copy():
    nodes, tets = tetcollide.read_mesh(MESHES / "ball.msh")  # a pathlib.Path works too
    # Not a copy into NumPy's own memory: a base object (the capsule) owns the buffer,
    # and the arrays outlive everything else of the reader.
    assert not nodes.flags["OWNDATA"] and nodes.base is not None
    assert not tets.flags["OWNDATA"] and tets.base is not None
    assert sys.getrefcount(nodes.base) >= 2
    nodes_copy = nodes.copy()
    del tets
    assert np.array_equal(nodes, nodes_copy)
    nodes[0, 0] = 42.0  # writable, and really the array's own
    assert nodes[0, 0] == 42.0


def test_tetgen_pair_is_read():
    nodes, tets = tetcollide.read_mesh(TEST_MESHES / "tetgen_cube.1.node")
    assert nodes.ndim == 2 and nodes.shape[1] == 3 and len(nodes) > 0
    assert tets.ndim == 2 and tets.shape[1] == 4 and len(tets) > 0
    assert tets.min() >= 0 and tets.max() < len(nodes)


def test_a_missing_file_is_an_oserror_naming_it():
    with pytest.raises(OSError, match="no_such_mesh.msh"):
        tetcollide.read_mesh("no_such_mesh.msh")


@pytest.mark.parametrize("name, line", [("broken_garbage.msh", r":1: expected \$MeshFormat"),
                                        ("broken_tet_3_nodes.msh", r":\d+: ")])
def test_a_malformed_file_is_a_value_error_naming_file_and_line(name, line):
    with pytest.raises(ValueError, match=name + line):
        tetcollide.read_mesh(TEST_MESHES / name)


def test_a_path_of_the_wrong_type_is_a_type_error():
    with pytest.raises(TypeError):
        tetcollide.read_mesh(42)


def test_read_surface_reads_the_probe_and_refuses_a_tet_mesh(tmp_path):
    nodes, triangles = tetcollide.read_surface(MESHES / "probe.stl")
    # make_probe.py: 674 vertices, a closed surface (2V - 4 triangles), tip at the origin.
    assert nodes.shape == (674, 3) and nodes.dtype == np.float64
    assert triangles.shape == (1344, 3) and triangles.dtype == np.int32
    assert triangles.min() == 0 and triangles.max() == 673
    np.testing.assert_allclose(nodes.min(axis=0), [-0.03, -0.03, 0.0], atol=1e-12)
    np.testing.assert_allclose(nodes.max(axis=0), [0.03, 0.03, 0.25], atol=1e-12)
    # Closed: every edge in exactly two triangles.
    edges = np.sort(triangles[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()
    with pytest.raises(ValueError, match="box.msh.*tet mesh, not a surface"):
        tetcollide.read_surface(MESHES / "box.msh")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
    with pytest.raises(ValueError, match="bad.obj:3"):
        tetcollide.read_surface(bad)
    with pytest.raises(OSError):
        tetcollide.read_surface(tmp_path / "missing.stl")


def test_node_weights_and_the_explicit_bound_match_the_client_library():
    """tetcollide.node_weights / max_explicit_stiffness (docs/INTEGRATORS.md) on the unit
    tet: the hand-computed weights and the bound (4 m - 2 c w dt) / (w dt^2) of its node
    with the smallest m / w; bad masses named."""
    nodes = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    tets = np.array([[0, 1, 2, 3]])
    w = tetcollide.node_weights(nodes, tets)
    assert w.shape == (4,)
    assert w[0] == 1.5 and abs(w[1] - 0.5 * (1 + 2 * np.sqrt(2))) < 1e-15
    masses = np.array([0.02, 0.05, 0.05, 0.05])
    k = tetcollide.max_explicit_stiffness(nodes, tets, masses, 1e-3, damping=1.0)
    assert abs(k - (4 * 0.02 - 2 * 1.0 * 1.5 * 1e-3) / (1.5 * 1e-6)) < 1e-9 * k
    tri = tetcollide.node_weights(nodes[:3], np.array([[0, 1, 2]]))
    assert tri.shape == (3,) and tri[0] == 1.0
    with pytest.raises(ValueError, match="node 2 has mass"):
        tetcollide.max_explicit_stiffness(nodes, tets, np.array([1, 1, 0, 1.0]), 1e-3)
    with pytest.raises(ValueError, match="cells"):
        tetcollide.node_weights(nodes, np.array([[0, 1, 2, 9]]))
