#!/usr/bin/env python3
"""Add orphan nodes (used by no element) to a Gmsh MSH 4.1 ASCII mesh, for benchmarks.

Usage: add_orphans.py IN.msh OUT.msh --count K [--layout end|front|interleave]
                      [--coords inside|far|zero] [--seed S]

  --layout end         the orphans get tags after the last node (one extra node block)
  --layout front       the orphans get tags 1..K, every existing tag is shifted by K
  --layout interleave  the orphans are spread evenly among the existing nodes: tags are
                       renumbered so that one orphan follows every n/K existing nodes
  --coords inside      uniform random points in the mesh's bounding box (default)
  --coords far         random points 100 bounding-box diagonals away
  --coords zero        all at the origin

Tets, triangles and every other element keep their nodes (their tags are remapped when
the layout renumbers). Deterministic for a given seed. Nodes are written in one extra
block (entity dim 3, the first volume's tag) for the orphans; the other blocks keep
their order. Used by docs/DEPTH_MAPS.md, "CFFM on the pawn with orphan nodes".
"""
import argparse
import random
import sys


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--count", type=int, required=True)
    ap.add_argument("--layout", choices=["end", "front", "interleave"], default="end")
    ap.add_argument("--coords", choices=["inside", "far", "zero"], default="inside")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()

    lines = open(a.inp).read().split("\n")
    i_nodes = lines.index("$Nodes")
    i_end_nodes = lines.index("$EndNodes")
    i_elems = lines.index("$Elements")
    i_end_elems = lines.index("$EndElements")

    # Parse node blocks.
    hdr = lines[i_nodes + 1].split()
    nblocks = int(hdr[0])
    blocks = []  # (dim, tag, param, tags, coord_lines)
    p = i_nodes + 2
    for _ in range(nblocks):
        dim, etag, param, cnt = lines[p].split()
        cnt = int(cnt)
        tags = [int(t) for t in lines[p + 1:p + 1 + cnt]]
        coords = lines[p + 1 + cnt:p + 1 + 2 * cnt]
        blocks.append((dim, etag, param, tags, coords))
        p += 1 + 2 * cnt
    assert p == i_end_nodes, "unexpected $Nodes layout"
    all_tags = sorted(t for b in blocks for t in b[3])
    n = len(all_tags)
    xs = [[float(v) for v in c.split()[:3]] for b in blocks for c in b[4]]
    lo = [min(x[k] for x in xs) for k in range(3)]
    hi = [max(x[k] for x in xs) for k in range(3)]
    diag = sum((hi[k] - lo[k]) ** 2 for k in range(3)) ** 0.5

    # New tags of the existing nodes, and the orphans' tags.
    K = a.count
    if a.layout == "end":
        remap = {t: t for t in all_tags}
        orphan_tags = list(range(all_tags[-1] + 1, all_tags[-1] + 1 + K))
    elif a.layout == "front":
        remap = {t: t + K for t in all_tags}
        orphan_tags = list(range(1, K + 1))
    else:
        remap = {}
        orphan_tags = []
        nxt = 1
        placed = 0
        for idx, t in enumerate(all_tags):
            remap[t] = nxt
            nxt += 1
            # one orphan after every n/K existing nodes
            while placed < K and (idx + 1) * K >= (placed + 1) * n:
                orphan_tags.append(nxt)
                nxt += 1
                placed += 1
        while placed < K:
            orphan_tags.append(nxt)
            nxt += 1
            placed += 1

    rng = random.Random(a.seed)

    def coord():
        if a.coords == "zero":
            return (0.0, 0.0, 0.0)
        if a.coords == "far":
            return tuple(hi[k] + 100 * diag + rng.random() * diag for k in range(3))
        return tuple(lo[k] + rng.random() * (hi[k] - lo[k]) for k in range(3))

    vol_tag = next((b[1] for b in blocks if b[0] == "3"), "1")
    out = lines[:i_nodes + 1]
    max_tag = max(max(remap.values()), max(orphan_tags) if orphan_tags else 0)
    out.append(f"{nblocks + (1 if K else 0)} {n + K} 1 {max_tag}")
    for dim, etag, param, tags, coords in blocks:
        out.append(f"{dim} {etag} {param} {len(tags)}")
        out.extend(str(remap[t]) for t in tags)
        out.extend(coords)
    if K:
        out.append(f"3 {vol_tag} 0 {K}")
        out.extend(str(t) for t in orphan_tags)
        out.extend("%.17g %.17g %.17g" % coord() for _ in range(K))
    out.append("$EndNodes")
    out.extend(lines[i_end_nodes + 1:i_elems + 2])  # ... $Elements and its header
    q = i_elems + 2
    while q < i_end_elems:
        dim, etag, etype, cnt = lines[q].split()
        out.append(lines[q])
        for line in lines[q + 1:q + 1 + int(cnt)]:
            f = line.split()
            out.append(" ".join([f[0]] + [str(remap[int(v)]) for v in f[1:]]) + " ")
        q += 1 + int(cnt)
    out.extend(lines[i_end_elems:])
    open(a.out, "w").write("\n".join(out))
    print(f"{a.out}: {n} nodes + {K} orphans ({a.layout}, {a.coords})", file=sys.stderr)


if __name__ == "__main__":
    main()
