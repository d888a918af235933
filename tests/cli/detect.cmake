# CLI tests of `tetcollide detect` (included from tests/cli/CMakeLists.txt; uses
# tc_cli_test, TC_MESHES and TC_CLI_OUT from there).
set(TC_DATA_MESHES ${CMAKE_SOURCE_DIR}/data/meshes)

# Two tets sharing a face, against themselves: each tet overlaps its copy; the two
# copies of the shared face only touch, which is not an overlap. The four box pairs
# all touch or overlap, so all four are candidates. The JSON has exactly five keys.
set(json_keys "^\\{\n  \"broad_ms\": [-+.e0-9]+,\n  \"candidates\": 4,\n  \"narrow_ms\": [-+.e0-9]+,\n  \"overlapping\": 2,\n  \"time_ms\": [-+.e0-9]+\n\\}\n$")
foreach(broad grid hash sap bvh)
  tc_cli_test(NAME detect.two_tets.${broad}
              ARGS detect ${TC_MESHES}/two_tets_v41.msh ${TC_MESHES}/two_tets_v22.msh
                   --broad ${broad} --json --repeat 3
              EXIT 0 STDOUT "${json_keys}" STDERR_EMPTY)
endforeach()
tc_cli_test(NAME detect.pairs_csv
            ARGS detect ${TC_MESHES}/two_tets_v41.msh ${TC_MESHES}/two_tets_v41.msh
                 --pairs ${TC_CLI_OUT}/two_tets_pairs.csv --threads 1
            EXIT 0 STDOUT "overlapping: +2\n"
            OUTPUT ${TC_CLI_OUT}/two_tets_pairs.csv OUTPUT_REGEX "^tet_a,tet_b\n0,0\n1,1\n$")
# Moved apart: nothing, not even a candidate.
tc_cli_test(NAME detect.moved_apart
            ARGS detect ${TC_MESHES}/box_v41.msh ${TC_MESHES}/box_v41.msh --move-b 5 0 0 --json
            EXIT 0 JSON "candidates=0,overlapping=0")
# The torus sunk 10 mm into the box: every broad phase finds the same overlaps.
foreach(broad grid hash sap bvh)
  tc_cli_test(NAME detect.torus_box.${broad}
              ARGS detect ${TC_DATA_MESHES}/box.msh ${TC_DATA_MESHES}/torus.msh
                   --move-b 0 0 0.24 --broad ${broad} --threads 2 --json --repeat 2
              EXIT 0 JSON "overlapping=2363")
endforeach()
# --turn-b: the torus tilted 60 degrees about (1, 0.5, 0) through its box's centre, then sunk:
# every broad phase, on one thread and two, finds the same overlaps. (Turned about the
# origin instead, the torus would miss the box.)
foreach(broad grid hash sap bvh)
  foreach(threads 1 2)
    tc_cli_test(NAME detect.torus_box_turned.${broad}.${threads}
                ARGS detect ${TC_DATA_MESHES}/box.msh ${TC_DATA_MESHES}/torus.msh
                     --turn-b 1 0.5 0 60 --move-b 0 0 0.24 --broad ${broad} --threads ${threads}
                     --json --repeat 1
                EXIT 0 JSON "overlapping=16255")
  endforeach()
endforeach()
tc_cli_test(NAME detect.turn_b_zero_axis
            ARGS detect ${TC_DATA_MESHES}/box.msh ${TC_DATA_MESHES}/torus.msh --turn-b 0 0 0 30
            EXIT 2 STDERR "--turn-b: the axis must not be zero")

# Bad input: exit 3 with the reader's message; usage errors: exit 2; unwritable: 1.
tc_cli_test(NAME detect.bad_file_a
            ARGS detect ${TC_MESHES}/broken_truncated.msh ${TC_MESHES}/box_v41.msh
            EXIT 3 STDERR "^tetcollide: error: [^\n]*broken_truncated.msh:269: expected 4 node tags")
tc_cli_test(NAME detect.bad_file_b
            ARGS detect ${TC_MESHES}/box_v41.msh ${TC_MESHES}/nowhere.msh
            EXIT 3 STDERR "^tetcollide: error: [^\n]*nowhere.msh: cannot open file")
tc_cli_test(NAME detect.no_tets
            ARGS detect ${TC_MESHES}/square_v41.msh ${TC_MESHES}/box_v41.msh
            EXIT 3 STDERR "^tetcollide: error: [^\n]*square_v41.msh: no tetrahedra")
tc_cli_test(NAME detect.repeated_node
            ARGS detect ${TC_MESHES}/box_v41.msh ${TC_MESHES}/broken_repeated_node.msh
            EXIT 3 STDERR "^tetcollide: error: [^\n]*broken_repeated_node.msh: 1 tets with a repeated node")
tc_cli_test(NAME detect.usage.bad_broad
            ARGS detect ${TC_MESHES}/box_v41.msh ${TC_MESHES}/box_v41.msh --broad octree EXIT 2)
tc_cli_test(NAME detect.usage.zero_threads
            ARGS detect ${TC_MESHES}/box_v41.msh ${TC_MESHES}/box_v41.msh --threads 0 EXIT 2)
tc_cli_test(NAME detect.usage.move_two_values
            ARGS detect ${TC_MESHES}/box_v41.msh ${TC_MESHES}/box_v41.msh --move-b 1 2 EXIT 2)
tc_cli_test(NAME detect.usage.one_file ARGS detect ${TC_MESHES}/box_v41.msh EXIT 2)
tc_cli_test(NAME detect.unwritable_pairs
            ARGS detect ${TC_MESHES}/box_v41.msh ${TC_MESHES}/box_v41.msh
                 --pairs /nonexistent-dir/pairs.csv
            EXIT 1 STDERR "^tetcollide: error: /nonexistent-dir/pairs.csv: cannot open file")
