#!/usr/bin/env python3
"""Cut a piece out of a tetrahedral mesh: keep the tets whose centroid lies above a plane.

The piece has exactly the element sizes of the original where it was cut from, so a
contact in it can be compared with the same contact in the whole mesh (issue 13: "cost
that follows the contact"). Reads Gmsh 4.1 ASCII (4-node tets), writes Gmsh 2.2 ASCII
with the nodes renumbered 1..n in their original order.

Usage: crop_mesh.py IN.msh OUT.msh --axis z --above VALUE
       crop_mesh.py IN.msh OUT.msh --axis z --top-fraction 0.1   (keep ~10% of the tets)
"""
import argparse
import sys


def read_msh41(path):
    nodes = {}
    tets = []
    with open(path) as f:
        lines = iter(f.read().split("\n"))
    for line in lines:
        line = line.strip()
        if line == "$MeshFormat":
            version = next(lines).split()
            if not version or not version[0].startswith("4.1") or version[1] != "0":
                sys.exit(f"{path}: only Gmsh 4.1 ASCII is read, found {' '.join(version)}")
        elif line == "$Nodes":
            blocks = int(next(lines).split()[0])
            for _ in range(blocks):
                _, _, parametric, count = map(int, next(lines).split())
                if parametric:
                    sys.exit(f"{path}: parametric node blocks are not read")
                tags = [int(next(lines)) for _ in range(count)]
                for tag in tags:
                    nodes[tag] = tuple(float(v) for v in next(lines).split()[:3])
        elif line == "$Elements":
            blocks = int(next(lines).split()[0])
            for _ in range(blocks):
                _, _, etype, count = map(int, next(lines).split())
                for _ in range(count):
                    fields = next(lines).split()
                    if etype == 4:
                        tets.append(tuple(int(v) for v in fields[1:5]))
    if not tets:
        sys.exit(f"{path}: no 4-node tetrahedra")
    return nodes, tets


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("input")
    parser.add_argument("output")
    parser.add_argument("--axis", choices="xyz", default="z")
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--above", type=float, help="keep tets whose centroid is above this")
    group.add_argument("--top-fraction", type=float, help="keep this fraction of the tets")
    args = parser.parse_args()
    nodes, tets = read_msh41(args.input)
    axis = "xyz".index(args.axis)
    centroid = [sum(nodes[v][axis] for v in t) / 4.0 for t in tets]
    if args.above is not None:
        cut = args.above
    else:
        if not 0.0 < args.top_fraction <= 1.0:
            sys.exit("--top-fraction must be in (0, 1]")
        order = sorted(centroid, reverse=True)
        cut = order[max(0, int(args.top_fraction * len(order)) - 1)] - 1e-12
    kept = [t for t, c in zip(tets, centroid) if c > cut]
    used = sorted({v for t in kept for v in t})
    index = {tag: i + 1 for i, tag in enumerate(used)}
    with open(args.output, "w") as f:
        f.write("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n")
        f.write(f"{len(used)}\n")
        for tag in used:
            x, y, z = nodes[tag]
            f.write(f"{index[tag]} {x!r} {y!r} {z!r}\n")
        f.write("$EndNodes\n$Elements\n")
        f.write(f"{len(kept)}\n")
        for i, t in enumerate(kept):
            f.write(f"{i + 1} 4 2 1 1 {' '.join(str(index[v]) for v in t)}\n")
        f.write("$EndElements\n")
    print(f"{args.output}: {len(kept)} of {len(tets)} tets, {len(used)} nodes, "
          f"{args.axis} centroid > {cut:.6g}")


if __name__ == "__main__":
    main()
