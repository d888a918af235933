#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets into fuzz/corpus/<target>/.

Seeds come from the repository's test data (tests/data/meshes, tests/data/recordings,
config/tetcollided.yaml) and from small hand-made inputs built here. Run from anywhere;
the output is committed, so this only needs re-running when the test data changes.
"""
import pathlib
import shutil
import struct

ROOT = pathlib.Path(__file__).resolve().parent.parent
MESHES = ROOT / "tests" / "data" / "meshes"
SURFACES = ROOT / "tests" / "data" / "surfaces"
CORPUS = ROOT / "fuzz" / "corpus"
MAX_SEED = 12 * 1024  # larger files only slow the fuzzer down


def fresh(target):
    d = CORPUS / target
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    return d


def gmsh():
    d = fresh("gmsh")
    for f in sorted(MESHES.glob("*.msh")):
        if f.stat().st_size <= MAX_SEED:
            shutil.copy(f, d / f.name)


def stl():
    d = fresh("stl")
    for f in sorted(SURFACES.glob("*.stl")):
        if 0 < f.stat().st_size <= MAX_SEED:
            shutil.copy(f, d / f.name)
    # One facet, binary, with a header that begins with "solid" (binary by its size).
    tri = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    rec = struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *p) for p in tri) + b"\0\0"
    (d / "one_solid_bin.stl").write_bytes(b"solid one".ljust(80, b" ") + struct.pack("<I", 1) + rec)
    (d / "two_solids.stl").write_text(
        "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
        "endloop\nendfacet\nendsolid a\nSOLID B\nFACET NORMAL 0 0 -1\nOUTER LOOP\n"
        "VERTEX 0 0 0\nVERTEX 0 1 0\nVERTEX 1 0 0\nENDLOOP\nENDFACET\nENDSOLID B\n")


def obj():
    d = fresh("obj")
    for f in sorted(SURFACES.glob("*.obj")):
        if 0 < f.stat().st_size <= MAX_SEED:
            shutil.copy(f, d / f.name)
    (d / "forms.obj").write_text(
        "v 0 0 0\nv 1 0 0 1\nv 0 1 0 0.5 0.5 0.5\nv 1 1 0\nvt 0 0\nvn 0 0 1\n"
        "f 1/1/1 2/1/1 4/1/1 3/1/1\nf 1//1 2//1 3//1\nf 1/1 2/1 3/1\nf -4 -3 -1\n"
        "f 4 3 2 # late comment\n")


def tetgen():
    d = fresh("tetgen")
    for node in sorted(MESHES.glob("*.node")):
        ele = node.with_suffix(".ele")
        if ele.exists():
            data = node.read_bytes() + b"\0" + ele.read_bytes()
            if len(data) <= MAX_SEED:
                (d / (node.stem + ".pair")).write_bytes(data)
    # A node file alone (the .ele part missing).
    (d / "node_only.pair").write_bytes((MESHES / "tetgen_cube.node").read_bytes())


def mesh_seed(nodes, tets):
    """Bytes the mesh target reads as these nodes (grid values) and tets."""
    grid = {-1.0: 0, -0.5: 1, 0.0: 2, 0.5: 3, 1.0: 4, 1.5: 5, 2.0: 6, 2.5: 7, 3.0: 8}
    out = bytes([len(nodes), len(tets)])
    for p in nodes:
        out += bytes(grid[c] for c in p)
    for t in tets:
        out += bytes(t)
    return out


CUBE = [(x, y, z) for z in (0.0, 1.0) for y in (0.0, 1.0) for x in (0.0, 1.0)]
CUBE_FIVE = [(0, 1, 3, 5), (0, 3, 2, 6), (0, 5, 6, 4), (3, 6, 5, 7), (0, 3, 6, 5)]
TET = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]


def mesh():
    d = fresh("mesh")
    (d / "single_tet").write_bytes(mesh_seed(TET, [(0, 1, 2, 3)]))
    (d / "single_tet_inverted").write_bytes(mesh_seed(TET, [(0, 2, 1, 3)]))
    (d / "two_tets_sharing_face").write_bytes(
        mesh_seed(TET + [(1.0, 1.0, 1.0)], [(0, 1, 2, 3), (1, 2, 3, 4)]))
    (d / "cube_five_tets").write_bytes(mesh_seed(CUBE, CUBE_FIVE))
    (d / "nonmanifold").write_bytes(
        mesh_seed(TET + [(1.0, 1.0, 1.0), (-1.0, -1.0, -1.0)],
                  [(0, 1, 2, 3), (1, 2, 3, 4), (1, 2, 3, 0)]))
    (d / "orphans").write_bytes(mesh_seed(TET + [(3.0, 3.0, 3.0)], [(0, 1, 2, 3)]))
    # The cube through the 8 one-node steps (node 0's x set to 0.0 again each time), then
    # turned and shifted six times (turn bytes: angle 0.02 * (b % 64) rad, axis b / 64 % 3;
    # from 192 on, one node moved as well: node 7's z to 1.5).
    steps = bytes([0, 0, 2]) * 8
    turns = bytes([10, 75, 140, 30, 200, 7, 2, 5, 250, 7, 2, 3])
    (d / "cube_turning").write_bytes(mesh_seed(CUBE, CUBE_FIVE) + steps + turns)


def samples_seed(rest, tets, state_moves, response=2, static=0):
    """Bytes the samples target reads as a good topology and a state moving the nodes
    by the given grid steps (selector % 9 * 0.25 - 1, so 4 = no move)."""
    grid = {-1.0: 0, -0.5: 1, 0.0: 2, 0.5: 3, 1.0: 4, 1.5: 5, 2.0: 6, 2.5: 7, 3.0: 8}
    out = bytes([0, 0, 0, 0, 0, len(rest), len(tets), 0, 0])
    out += bytes(grid[c] for p in rest for c in p)
    out += bytes([0]) + bytes(i for t in tets for i in t)
    out += bytes([0, 0, 0, static, 0, response])
    out += bytes([0, 0, 1, 0, 0]) + bytes(state_moves) + bytes([0])
    return out


def samples():
    d = fresh("samples")
    n = len(TET)
    (d / "tet_at_rest").write_bytes(samples_seed(TET, [(0, 1, 2, 3)], [4] * (3 * n)))
    # Moved by +1.75 in x into the fixed tet at x = 1.5 .. 2.5: a contact.
    (d / "tet_into_fixed").write_bytes(
        samples_seed(TET, [(0, 1, 2, 3)], [8, 5, 5] * n))
    (d / "cube_into_fixed").write_bytes(
        samples_seed(CUBE, CUBE_FIVE, [8, 4, 4] * len(CUBE), response=1))
    (d / "static_cube").write_bytes(
        samples_seed(CUBE, CUBE_FIVE, [4] * (3 * len(CUBE)), response=0, static=1))
    (d / "tight_limits").write_bytes(bytes([255, 0, 0]) + samples_seed(TET, [(0, 1, 2, 3)],
                                                                         [4] * 12)[1:])


def config():
    d = fresh("config")
    shutil.copy(ROOT / "config" / "tetcollided.yaml", d / "tetcollided.yaml")
    (d / "minimal.yaml").write_text("version: 1\n")
    (d / "flow.yaml").write_text(
        "version: 1\ndds: {domain: 7, scenes: [a*, 'b?'], partition: p}\n"
        "threads: 2\nlimits: {max_nodes: 1000, max_tets: 5000}\n")
    (d / "log.yaml").write_text(
        "version: 1\nlog:\n  level: debug\n  file: ''\n  timing_summary_period_s: 0\n"
        "pipeline:\n  broad_phase: bvh\n  compute_stiffness: true\n")
    (d / "anchors.yaml").write_text(
        "version: 1\nframes: &f {assembly_wait_ms: 5, max_queued: 3}\n")


def recording():
    d = fresh("recording")
    for f in sorted((ROOT / "tests" / "data" / "recordings").glob("*.jsonl")):
        lines = f.read_text().splitlines(keepends=True)
        # The header, the info line and the first records of each kind.
        kept, kinds = lines[:2], {}
        for line in lines[2:]:
            for kind in ("topology", "state", "forces", "status", "remove"):
                if f'"type":"{kind}"' in line and kinds.get(kind, 0) < 1 and len(line) < 3000:
                    kinds[kind] = kinds.get(kind, 0) + 1
                    kept.append(line)
        (d / (f.stem + ".jsonl")).write_text("".join(kept))
    (d / "header_only.jsonl").write_text('{"format":"tetcollide-recording","version":1}\n')
    (d / "nonfinite.jsonl").write_text(
        '{"format":"tetcollide-recording","version":1}\n'
        '{"type":"state","t":0.5,"scene":"s","object":"a","frame":3,"topology_version":1,'
        '"positions":["NaN","Infinity","-Infinity"],"velocities":[]}\n'
        '{"type":"remove","t":0.75,"scene":"s","object":"a"}\n')


if __name__ == "__main__":
    gmsh()
    stl()
    obj()
    tetgen()
    mesh()
    samples()
    config()
    recording()
    for d in sorted(CORPUS.iterdir()):
        print(f"{d.name}: {len(list(d.iterdir()))} seeds")
