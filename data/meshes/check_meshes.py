#!/usr/bin/env python3
"""Check the tetcollide meshes (Gmsh 4.1 ASCII .msh, or TetGen .node/.ele).

Standard library only. For every 3D mesh (linear tets, Gmsh element type 4) it checks:
  * every tet positively oriented: det(x1-x0, x2-x0, x3-x0) > 0;
  * no orphan nodes (nodes used by no tet), unless listed in EXPECTED_ORPHANS;
  * one connected component (tets connected through shared faces);
  * a closed 2-manifold boundary (every interior face in exactly two tets, every boundary
    edge in exactly two boundary faces), outward oriented (sum of the boundary faces'
    flux of x equals 3 * volume);
  * boundary Euler characteristic V - E + F equal to the expected value (2 for a ball-like
    object, 0 for a torus);
  * for extruded meshes (slab), the number of distinct z values (layers + 1);
  * if the file carries boundary triangles (element type 2), that they are exactly the
    boundary faces of the tets.
It also reports tets whose four nodes are all on the boundary (paper Sec. 6.2), the
quality 6*sqrt(2)*V/l_rms^3 (same as tc::tet_quality), mean edge length and bounding box.

For a 2D mesh (linear triangles, element type 2, no tets) it checks that the triangles lie
in z = 0 and are counter-clockwise seen from +z, that there are no orphans, one component,
a manifold boundary, and Euler characteristic V - E + F = 1 (a disc).

Usage:
  check_meshes.py [--markdown] [--expect NAME=CHI ...] FILE...
Exit status 0 if every check passed, 1 otherwise.
"""

import math
import os
import sys

# Expected Euler characteristic of the boundary surface (3D) or the mesh (2D) by file stem.
EXPECTED = {
    "torus": 0,
    "box": 2,
    "ball": 2,
    "ellipsoid": 2,
    "slab": 2,
    "large": 2,
    "large_box": 2,
    "disc2d": 1,
    "rect2d": 1,
    # tests/data/meshes/foreign/
    "cylinder_hxt": 2,
    "lblock.1": 2,
    "tube.1": 0,
}

# Nodes used by no tet that a file is known to carry on purpose (default 0).
EXPECTED_ORPHANS = {"cylinder_hxt": 2}  # Gmsh circle centres saved as point elements

# Expected number of distinct node z values (tet layers + 1) for extruded meshes.
EXPECTED_Z_LEVELS = {"slab": 3}

# Face opposite local node i, right-hand normal pointing out of a positive tet
# (same as tc::kTetFaces).
TET_FACES = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))
TET_EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


class MeshError(Exception):
    pass


def edge_and_box_fields(lengths, lo, hi):
    """The report's edge-length statistics and bounding box."""
    return {"mean_edge": sum(lengths) / len(lengths), "min_edge": min(lengths),
            "max_edge": max(lengths), "lo": lo, "hi": hi}


def read_msh41(path):
    """Return (nodes: dict tag -> (x, y, z), elements: dict type -> list of node-tag tuples)."""
    with open(path, "r") as f:
        tokens_by_line = f.read().split("\n")
    lines = iter(enumerate(tokens_by_line, start=1))
    nodes = {}
    elements = {}
    version = None

    def next_line():
        try:
            num, text = next(lines)
        except StopIteration:
            raise MeshError(f"{path}: unexpected end of file")
        return num, text.strip()

    while True:
        try:
            num, text = next(lines)
        except StopIteration:
            break
        text = text.strip()
        if text == "$MeshFormat":
            num, text = next_line()
            parts = text.split()
            version = parts[0]
            if parts[1] != "0":
                raise MeshError(f"{path}:{num}: binary .msh is not supported by this checker")
            if not version.startswith("4.1"):
                raise MeshError(f"{path}:{num}: version {version}, expected 4.1")
        elif text == "$Nodes":
            num, text = next_line()
            num_blocks, num_nodes, _, _ = (int(v) for v in text.split())
            for _ in range(num_blocks):
                num, text = next_line()
                _, _, parametric, count = (int(v) for v in text.split())
                if parametric:
                    raise MeshError(f"{path}:{num}: parametric nodes not supported")
                tags = [int(next_line()[1]) for _ in range(count)]
                for tag in tags:
                    num, text = next_line()
                    x, y, z = (float(v) for v in text.split())
                    if tag in nodes:
                        raise MeshError(f"{path}:{num}: duplicate node tag {tag}")
                    nodes[tag] = (x, y, z)
            if len(nodes) != num_nodes:
                raise MeshError(f"{path}: header says {num_nodes} nodes, read {len(nodes)}")
        elif text == "$Elements":
            num, text = next_line()
            num_blocks, num_elements, _, _ = (int(v) for v in text.split())
            read = 0
            for _ in range(num_blocks):
                num, text = next_line()
                _, _, etype, count = (int(v) for v in text.split())
                lst = elements.setdefault(etype, [])
                for _ in range(count):
                    num, text = next_line()
                    vals = [int(v) for v in text.split()]
                    lst.append(tuple(vals[1:]))
                read += count
            if read != num_elements:
                raise MeshError(f"{path}: header says {num_elements} elements, read {read}")
    if version is None:
        raise MeshError(f"{path}: no $MeshFormat section")
    return nodes, elements


def read_tetgen(node_path):
    """Read a TetGen .node/.ele pair (node numbering as in the file, 0- or 1-based)."""
    ele_path = node_path[: -len(".node")] + ".ele"

    def data_lines(p):
        with open(p) as f:
            for raw in f:
                raw = raw.split("#", 1)[0].strip()
                if raw:
                    yield raw.split()

    it = data_lines(node_path)
    n, dim, nattr, nbnd = (int(v) for v in next(it))
    if dim != 3:
        raise MeshError(f"{node_path}: dimension {dim}, expected 3")
    nodes = {}
    for _ in range(n):
        parts = next(it)
        nodes[int(parts[0])] = tuple(float(v) for v in parts[1:4])
    it = data_lines(ele_path)
    ntet, npt, _ = (int(v) for v in next(it))
    if npt != 4:
        raise MeshError(f"{ele_path}: {npt} nodes per tet, expected 4")
    tets = []
    for _ in range(ntet):
        parts = next(it)
        tets.append(tuple(int(v) for v in parts[1:5]))
    return nodes, {4: tets}


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def dist2(a, b):
    d = sub(a, b)
    return dot(d, d)


class UnionFind:
    def __init__(self, n):
        self.parent = list(range(n))

    def find(self, i):
        while self.parent[i] != i:
            self.parent[i] = self.parent[self.parent[i]]
            i = self.parent[i]
        return i

    def union(self, a, b):
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[max(ra, rb)] = min(ra, rb)


def bbox(points):
    lo = [min(p[k] for p in points) for k in range(3)]
    hi = [max(p[k] for p in points) for k in range(3)]
    return lo, hi


def check_3d(name, nodes, tets, surface_tris, expected_chi, expected_z_levels,
             expected_orphans):
    failures = []
    pos = nodes
    used = set()
    for t in tets:
        for v in t:
            if v not in pos:
                raise MeshError(f"{name}: tet references unknown node {v}")
            used.add(v)
    orphans = len(pos) - len(used)
    if orphans != expected_orphans:
        failures.append(f"{orphans} orphan nodes, expected {expected_orphans}")

    # Orientation, volume, quality.
    inverted = 0
    min_q = math.inf
    sum_q = 0.0
    min_vol = math.inf
    total_vol = 0.0
    for i, t in enumerate(tets):
        x0, x1, x2, x3 = (pos[v] for v in t)
        vol = dot(sub(x1, x0), cross(sub(x2, x0), sub(x3, x0))) / 6.0
        if not vol > 0.0:
            inverted += 1
        total_vol += vol
        min_vol = min(min_vol, vol)
        l2 = sum(dist2(pos[t[a]], pos[t[b]]) for a, b in TET_EDGES) / 6.0
        q = 6.0 * math.sqrt(2.0) * vol / (l2 * math.sqrt(l2)) if l2 > 0 else 0.0
        min_q = min(min_q, q)
        sum_q += q
    if inverted:
        failures.append(f"{inverted} tets with signed volume <= 0")

    # Faces: boundary = faces used once; interior = twice; more = non-manifold.
    face_count = {}
    face_oriented = {}
    face_tets = {}
    for i, t in enumerate(tets):
        for f in TET_FACES:
            tri = (t[f[0]], t[f[1]], t[f[2]])
            key = tuple(sorted(tri))
            face_count[key] = face_count.get(key, 0) + 1
            face_oriented[key] = tri
            face_tets.setdefault(key, []).append(i)
    nonmanifold_faces = sum(1 for c in face_count.values() if c > 2)
    if nonmanifold_faces:
        failures.append(f"{nonmanifold_faces} faces shared by more than two tets")
    boundary = [face_oriented[k] for k, c in face_count.items() if c == 1]

    # Components through shared faces.
    uf = UnionFind(len(tets))
    for k, ts in face_tets.items():
        for j in ts[1:]:
            uf.union(ts[0], j)
    components = len({uf.find(i) for i in range(len(tets))})
    if components != 1:
        failures.append(f"{components} face-connected components")

    # Boundary surface: manifold edges, Euler characteristic, outward orientation.
    bnodes = set()
    bedges = {}
    directed = {}
    flux = 0.0
    for tri in boundary:
        bnodes.update(tri)
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            key = (min(a, b), max(a, b))
            bedges[key] = bedges.get(key, 0) + 1
            directed[(a, b)] = directed.get((a, b), 0) + 1
        p0, p1, p2 = (pos[v] for v in tri)
        n = cross(sub(p1, p0), sub(p2, p0))  # 2 * area * normal
        centroid = tuple((p0[k] + p1[k] + p2[k]) / 3.0 for k in range(3))
        flux += dot(centroid, n) / 2.0  # integral of x . n over the face
    bad_edges = sum(1 for c in bedges.values() if c != 2)
    if bad_edges:
        failures.append(f"{bad_edges} boundary edges not in exactly two boundary faces")
    inconsistent = sum(1 for c in directed.values() if c != 1)
    if inconsistent:
        failures.append(f"{inconsistent} boundary half-edges used twice in one direction")
    chi = len(bnodes) - len(bedges) + len(boundary)
    if expected_chi is not None and chi != expected_chi:
        failures.append(f"boundary Euler characteristic {chi}, expected {expected_chi}")
    # Divergence theorem: the flux of x through the closed outward boundary is 3 * volume.
    if abs(flux - 3.0 * total_vol) > 1e-9 * max(1.0, abs(3.0 * total_vol)):
        failures.append(f"boundary not outward: flux {flux:.6g} vs 3*volume {3*total_vol:.6g}")

    if surface_tris is not None:
        from_file = {tuple(sorted(t)) for t in surface_tris}
        from_tets = {tuple(sorted(t)) for t in boundary}
        if from_file != from_tets:
            failures.append(
                f"file boundary triangles ({len(from_file)}) differ from tet boundary faces"
                f" ({len(from_tets)}): {len(from_file ^ from_tets)} in only one"
            )

    all_boundary_tets = sum(1 for t in tets if all(v in bnodes for v in t))

    # Unique edges for the mean edge length.
    edges = set()
    for t in tets:
        for a, b in TET_EDGES:
            u, v = t[a], t[b]
            edges.add((u, v) if u < v else (v, u))
    lengths = [math.sqrt(dist2(pos[u], pos[v])) for u, v in edges]
    lo, hi = bbox([pos[v] for v in used] or list(pos.values()))
    z_levels = len({p[2] for p in pos.values()})
    if expected_z_levels is not None and z_levels != expected_z_levels:
        failures.append(f"{z_levels} distinct z values, expected {expected_z_levels}")
    return {
        "dim": 3,
        "z_levels": z_levels,
        "nodes": len(pos),
        "elements": len(tets),
        "boundary_faces": len(boundary),
        "boundary_nodes": len(bnodes),
        "boundary_edges": len(bedges),
        "chi": chi,
        "components": components,
        "orphans": orphans,
        "inverted": inverted,
        "all_boundary": all_boundary_tets,
        "min_q": min_q,
        "mean_q": sum_q / len(tets),
        "volume": total_vol,
        "min_vol": min_vol,
        "edges": len(edges),
        **edge_and_box_fields(lengths, lo, hi),
        "failures": failures,
    }


def check_2d(name, nodes, tris, expected_chi):
    failures = []
    pos = nodes
    used = {v for t in tris for v in t}
    orphans = len(pos) - len(used)
    if orphans:
        failures.append(f"{orphans} orphan nodes")
    off_plane = sum(1 for v in used if pos[v][2] != 0.0)
    if off_plane:
        failures.append(f"{off_plane} nodes off the plane z = 0")
    clockwise = 0
    min_q = math.inf
    sum_q = 0.0
    area = 0.0
    for t in tris:
        p0, p1, p2 = (pos[v] for v in t)
        a2 = (p1[0] - p0[0]) * (p2[1] - p0[1]) - (p1[1] - p0[1]) * (p2[0] - p0[0])
        if not a2 > 0.0:
            clockwise += 1
        area += a2 / 2.0
        l2 = dist2(p0, p1) + dist2(p1, p2) + dist2(p2, p0)
        q = 2.0 * math.sqrt(3.0) * a2 / l2 if l2 > 0 else 0.0  # 4*sqrt(3)*A / sum l^2
        min_q = min(min_q, q)
        sum_q += q
    if clockwise:
        failures.append(f"{clockwise} triangles not counter-clockwise seen from +z")
    edge_count = {}
    edge_tris = {}
    for i, t in enumerate(tris):
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            key = (min(a, b), max(a, b))
            edge_count[key] = edge_count.get(key, 0) + 1
            edge_tris.setdefault(key, []).append(i)
    nonmanifold = sum(1 for c in edge_count.values() if c > 2)
    if nonmanifold:
        failures.append(f"{nonmanifold} edges shared by more than two triangles")
    uf = UnionFind(len(tris))
    for ts in edge_tris.values():
        for j in ts[1:]:
            uf.union(ts[0], j)
    components = len({uf.find(i) for i in range(len(tris))})
    if components != 1:
        failures.append(f"{components} edge-connected components")
    boundary_edges = [k for k, c in edge_count.items() if c == 1]
    bnodes = {v for e in boundary_edges for v in e}
    chi = len(used) - len(edge_count) + len(tris)
    if expected_chi is not None and chi != expected_chi:
        failures.append(f"Euler characteristic {chi}, expected {expected_chi}")
    all_boundary = sum(1 for t in tris if all(v in bnodes for v in t))
    lengths = [math.sqrt(dist2(pos[u], pos[v])) for u, v in edge_count]
    lo, hi = bbox([pos[v] for v in used])
    return {
        "dim": 2,
        "z_levels": 1,
        "nodes": len(pos),
        "elements": len(tris),
        "boundary_faces": len(boundary_edges),
        "boundary_nodes": len(bnodes),
        "boundary_edges": len(boundary_edges),
        "chi": chi,
        "components": components,
        "orphans": orphans,
        "inverted": clockwise,
        "all_boundary": all_boundary,
        "min_q": min_q,
        "mean_q": sum_q / len(tris),
        "volume": area,
        "min_vol": None,
        "edges": len(edge_count),
        **edge_and_box_fields(lengths, lo, hi),
        "failures": failures,
    }


def check_file(path, expected_overrides):
    base = os.path.basename(path)
    stem = base.rsplit(".", 1)[0]
    expected = expected_overrides.get(stem, EXPECTED.get(stem))
    if path.endswith(".node"):
        nodes, elements = read_tetgen(path)
    else:
        nodes, elements = read_msh41(path)
    if elements.get(4):
        return check_3d(base, nodes, elements[4], elements.get(2), expected,
                        EXPECTED_Z_LEVELS.get(stem), EXPECTED_ORPHANS.get(stem, 0))
    if elements.get(2):
        return check_2d(base, nodes, elements[2], expected)
    raise MeshError(f"{path}: no tetrahedra (type 4) or triangles (type 2)")


def fmt_box(lo, hi):
    return "[" + ", ".join(f"{a:.4g}..{b:.4g}" for a, b in zip(lo, hi)) + "]"


def main(argv):
    markdown = False
    overrides = {}
    files = []
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == "--markdown":
            markdown = True
        elif a == "--expect":
            i += 1
            k, v = argv[i].split("=")
            overrides[k] = int(v)
        elif a in ("-h", "--help"):
            print(__doc__)
            return 0
        else:
            files.append(a)
        i += 1
    if not files:
        print(__doc__, file=sys.stderr)
        return 2

    ok = True
    results = []
    for path in files:
        try:
            r = check_file(path, overrides)
        except (MeshError, OSError, ValueError) as e:
            print(f"ERROR {e}", file=sys.stderr)
            ok = False
            continue
        results.append((os.path.basename(path), r))
        if r["failures"]:
            ok = False

    if markdown:
        print("| mesh | dim | nodes | elements | boundary faces (2D: edges) | boundary nodes "
              "| Euler char. | components | orphans | inverted | all-boundary elements "
              "| min quality | mean quality | volume (2D: area) | edge length min / mean / max | bounding box |"
              " status |")
        print("|" + "---|" * 17)
        for name, r in results:
            print(
                f"| {name} | {r['dim']} | {r['nodes']} | {r['elements']} | {r['boundary_faces']}"
                f" | {r['boundary_nodes']} | {r['chi']} | {r['components']} | {r['orphans']}"
                f" | {r['inverted']} | {r['all_boundary']} | {r['min_q']:.3f}"
                f" | {r['mean_q']:.3f} | {r['volume']:.5g}"
                f" | {r['min_edge']:.4g} / {r['mean_edge']:.4g} / {r['max_edge']:.4g}"
                f" | {fmt_box(r['lo'], r['hi'])} | {'ok' if not r['failures'] else 'FAIL'} |"
            )
    else:
        for name, r in results:
            kind = "tets" if r["dim"] == 3 else "triangles"
            bkind = "boundary faces" if r["dim"] == 3 else "boundary edges"
            print(
                f"{name}: {r['nodes']} nodes, {r['elements']} {kind}, {r['boundary_faces']}"
                f" {bkind}, {r['boundary_nodes']} boundary nodes, chi {r['chi']},"
                f" {r['components']} component(s), {r['orphans']} orphans,"
                f" {r['inverted']} inverted, {r['all_boundary']} all-boundary elements,"
                f" quality min {r['min_q']:.3f} mean {r['mean_q']:.3f},"
                f" {'volume' if r['dim'] == 3 else 'area'} {r['volume']:.6g},"
                f" edge length mean {r['mean_edge']:.4g} min {r['min_edge']:.4g}"
                f" max {r['max_edge']:.4g}, bbox {fmt_box(r['lo'], r['hi'])}"
                + (f", {r['z_levels']} z levels" if r["dim"] == 3 and r["z_levels"] <= 16 else "")
            )
            for f in r["failures"]:
                print(f"  FAIL: {f}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
