# ---- render: PNG pictures of mesh boundaries (tools/viz) ------------------------------
# The PNG is checked byte-wise: signature, IHDR with the requested size (8-bit RGB, no
# interlace), and the IEND chunk at the very end. The unit tests decode the pixels.
set(TC_DATA_MESHES ${CMAKE_SOURCE_DIR}/data/meshes)
set(png_1024x768 "^89504e470d0a1a0a0000000d494844520000040000000300080200000[0-9a-f]+0000000049454e44ae426082$")
tc_cli_test(NAME render.torus
            ARGS render ${TC_DATA_MESHES}/torus.msh --out ${TC_CLI_OUT}/render_torus.png
            EXIT 0 STDERR "wrote [^\n]*render_torus.png \\(1024x768, 1 objects, [0-9]+ triangles"
            OUTPUT ${TC_CLI_OUT}/render_torus.png OUTPUT_HEX_REGEX "${png_1024x768}")
tc_cli_test(NAME render.torus_over_box_field
            ARGS render ${TC_DATA_MESHES}/torus.msh ${TC_DATA_MESHES}/box.msh --offset 0,0,0.27
                 --field z --wireframe --view 0 1 -0.5 --size 320x240 --title "torus over box"
                 --out ${TC_CLI_OUT}/render_torus_box.png
            EXIT 0 STDERR "wrote [^\n]*render_torus_box.png \\(320x240, 2 objects"
            OUTPUT ${TC_CLI_OUT}/render_torus_box.png
            OUTPUT_HEX_REGEX "^89504e470d0a1a0a0000000d4948445200000140000000f0080200000[0-9a-f]+0000000049454e44ae426082$")
tc_cli_test(NAME render.tetgen
            ARGS render ${TC_MESHES}/tetgen_cube.1.node --field quality --size 200x150
                 --out ${TC_CLI_OUT}/render_tetgen.png
            EXIT 0 OUTPUT ${TC_CLI_OUT}/render_tetgen.png
            OUTPUT_HEX_REGEX "^89504e470d0a1a0a0000000d49484452000000c800000096080200000")
# A .vtu the project wrote (mesh convert writes the point field "boundary").
tc_cli_test(NAME render.vtu
            ARGS render ${TC_CLI_OUT}/box.vtu --field boundary --size 200x150
                 --out ${TC_CLI_OUT}/render_vtu.png
            EXIT 0 OUTPUT ${TC_CLI_OUT}/render_vtu.png
            OUTPUT_HEX_REGEX "^89504e470d0a1a0a0000000d49484452000000c800000096080200000")
set_tests_properties(cli.convert.box_v41_bin.msh PROPERTIES FIXTURES_SETUP box_vtu)
set_tests_properties(cli.render.vtu PROPERTIES FIXTURES_REQUIRED box_vtu)

# Bad input: exit 3 with the reader's message; bad options: exit 2; unwritable: exit 1.
tc_cli_test(NAME render.bad_file ARGS render ${TC_MESHES}/broken_nan.msh --out ${TC_CLI_OUT}/x.png
            EXIT 3 STDERR "^tetcollide: error: [^\n]*broken_nan.msh:8: node tag 3 has a non-finite coordinate")
tc_cli_test(NAME render.missing_file ARGS render ${TC_MESHES}/nowhere.msh --out ${TC_CLI_OUT}/x.png
            EXIT 3 STDERR "^tetcollide: error: [^\n]*nowhere.msh: cannot open file")
tc_cli_test(NAME render.no_tets ARGS render ${TC_MESHES}/box_order2_v22.msh --out ${TC_CLI_OUT}/x.png
            EXIT 3 STDERR "box_order2_v22.msh: no tetrahedra")
tc_cli_test(NAME render.unknown_field
            ARGS render ${TC_MESHES}/box_v41.msh --field bogus --out ${TC_CLI_OUT}/x.png
            EXIT 3 STDERR "box_v41.msh: no point field 'bogus'")
tc_cli_test(NAME render.unwritable
            ARGS render ${TC_MESHES}/box_v41.msh --out /nonexistent-dir/x.png
            EXIT 1 STDERR "^tetcollide: error: /nonexistent-dir/x.png: cannot open file")
tc_cli_test(NAME render.usage.no_out ARGS render ${TC_MESHES}/box_v41.msh EXIT 2)
tc_cli_test(NAME render.usage.bad_size
            ARGS render ${TC_MESHES}/box_v41.msh --out ${TC_CLI_OUT}/x.png --size 10x10
            EXIT 2 STDERR "--size '10x10'")
tc_cli_test(NAME render.usage.bad_offset
            ARGS render ${TC_MESHES}/box_v41.msh --out ${TC_CLI_OUT}/x.png --offset 1,2
            EXIT 2 STDERR "--offset '1,2': expected X,Y,Z")
tc_cli_test(NAME render.usage.zero_view
            ARGS render ${TC_MESHES}/box_v41.msh --out ${TC_CLI_OUT}/x.png --view 0 0 0
            EXIT 2 STDERR "--view must be a non-zero direction")
