#!/usr/bin/env python3
"""Writes the broken_* mesh files of this folder from the valid ones beside them.

Run from this folder: python3 make_broken.py. Deterministic: running it again gives
the same bytes. Each file holds exactly one defect, named by the file.
"""
import struct
from pathlib import Path

HERE = Path(__file__).resolve().parent


def read(name):
    return (HERE / name).read_bytes()


def write(name, data):
    if isinstance(data, str):
        data = data.encode()
    (HERE / name).write_bytes(data)


TWO_TETS_V22 = """$MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
5
1 0 0 0
2 1 0 0
3 0 1 0
4 0 0 1
5 1 1 1
$EndNodes
$Elements
2
11 4 2 0 1 1 2 3 4
12 4 2 0 1 5 2 4 3
$EndElements
"""


def replace_once(text, old, new):
    assert text.count(old) == 1, old
    return text.replace(old, new)


def main():
    # --- text (2.2 and 4.1 ASCII) ---------------------------------------------------
    write("broken_empty.msh", b"")
    write("broken_garbage.msh", "hello, this is not a mesh\n\x01\x02 1 2 3\n")
    box22 = read("box_v22.msh")
    cut = box22.index(b"$EndElements") - 12  # in the middle of the last tet line
    write("broken_truncated.msh", box22[:cut])
    # Header announces 6 nodes, only 5 follow.
    write("broken_wrong_count.msh", replace_once(TWO_TETS_V22, "$Nodes\n5\n", "$Nodes\n6\n"))
    # A tet refers to node tag 999, which no node has.
    write("broken_bad_node.msh", replace_once(TWO_TETS_V22, "5 2 4 3\n", "5 2 4 999\n"))
    # A NaN coordinate.
    write("broken_nan.msh", replace_once(TWO_TETS_V22, "3 0 1 0\n", "3 0 nan 0\n"))
    # Element 12 is a 4-node tet with 3 node tags (line 15).
    write("broken_tet_3_nodes.msh", replace_once(TWO_TETS_V22, "5 2 4 3\n", "5 2 4\n"))
    # Node tag 2 appears twice.
    write("broken_duplicate_tag.msh", replace_once(TWO_TETS_V22, "3 0 1 0\n", "2 0 1 0\n"))
    # A tet that uses node 4 twice: read fine, rejected by validation (mesh info: exit 3).
    write("broken_repeated_node.msh", replace_once(TWO_TETS_V22, "5 2 4 3\n", "5 2 4 4\n"))
    # MSH 4.0 (not supported).
    write("broken_version.msh", replace_once(TWO_TETS_V22, "2.2 0 8", "4 0 8"))
    # 4.1 ASCII whose $Elements block holds fewer lines than it announces.
    box41 = read("box_v41.msh").decode()
    start = box41.index("$Elements")
    last = box41.rindex("\n", 0, box41.index("$EndElements") - 1)
    write("broken_v41_short_block.msh",
          box41[:start] + box41[start:last + 1].rsplit("\n", 2)[0] + "\n" +
          box41[box41.index("$EndElements"):])

    # --- binary (4.1) ---------------------------------------------------------------
    box = read("box_v41_bin.msh")
    nodes = box.index(b"$Nodes\n") + len(b"$Nodes\n")
    # Cut inside the last element block (the tets).
    write("broken_truncated_bin.msh", box[:box.index(b"$EndElements") - 100])
    # Big-endian marker.
    marker = box.index(b"4.1 1 8\n") + len(b"4.1 1 8\n")
    assert box[marker:marker + 4] == struct.pack("<i", 1)
    write("broken_bin_endian.msh", box[:marker] + struct.pack(">i", 1) + box[marker + 4:])
    # data-size 4 in the header.
    write("broken_bin_datasize.msh", box.replace(b"4.1 1 8\n", b"4.1 1 4\n", 1))
    # $Nodes header announcing 2^60 nodes.
    huge = bytearray(box)
    huge[nodes + 8:nodes + 16] = struct.pack("<Q", 1 << 60)
    write("broken_bin_huge_count.msh", bytes(huge))
    # A tet in binary referring to node tag 4000 (the file has tags 1..45): the first
    # node of the first type-4 element.
    elements = box.index(b"$Elements\n") + len(b"$Elements\n")
    pos = elements + 32
    while True:
        _, _, etype, count = struct.unpack_from("<iiiQ", box, pos)
        per = {15: 1, 1: 2, 2: 3, 4: 4}[etype]
        if etype == 4:
            bad = bytearray(box)
            struct.pack_into("<Q", bad, pos + 20 + 8, 4000)
            write("broken_bin_bad_node.msh", bytes(bad))
            break
        pos += 20 + count * 8 * (1 + per)

    # --- TetGen ---------------------------------------------------------------------
    node = read("tetgen_cube.1.node").decode()
    ele = read("tetgen_cube.1.ele").decode()
    # A tet refers to point 12 of 11.
    write("broken_tetgen_range.node", node)
    write("broken_tetgen_range.ele", replace_once(ele, "    2       1    10    11     2\n",
                                                  "    2       1    10    12     2\n"))
    # The .ele file stops after 10 of 17 tets.
    write("broken_tetgen_truncated.node", node)
    write("broken_tetgen_truncated.ele", "".join(ele.splitlines(True)[:11]))


if __name__ == "__main__":
    main()
