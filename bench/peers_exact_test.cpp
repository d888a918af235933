// tetcollide's narrow phase against an exact reference (issue 46, item 5): on the four
// heavy-contact scenes of bench/peer_scenes.hpp, at their pose and in two deforming frames
// (`--jitter 1e-6`), tc::detect_pair's overlapping tet pairs (default options) must be the
// pairs CGAL finds with box_intersection_d and the exact do_intersect of Tetrahedron_3
// (bench/peer_cgal.hpp). CGAL counts touching tets as intersecting and tetcollide does not
// (tolerance 1e-9 of the pair's size); on these poses no pair is that close, so the lists
// must be equal. Built when CGAL is found (libcgal-dev; bench/CMakeLists.txt).
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include "core/detect/detect.hpp"
#include "peer_cgal.hpp"
#include "peer_scenes.hpp"

namespace tc::peers {
namespace {

class PeersExactTest : public ::testing::TestWithParam<std::size_t> {};

TEST_P(PeersExactTest, OverlappingPairsAreCgals) {
  const SceneSpec& spec = kScenes[GetParam()];
  std::string error;
  const auto s = load_scene(spec, std::filesystem::path(TC_SOURCE_DIR) / "data/meshes", error);
  ASSERT_TRUE(s) << error;
  Positions xa, xb;
  // The pose itself, then frames 0 and 1 of `--jitter 1e-6`.
  for (std::int64_t frame = -1; frame < 2; ++frame) {
    if (frame < 0) {
      xa = s->a.mesh.positions;
      xb = s->b.mesh.positions;
    } else {
      jitter_positions(s->a.mesh.positions, kJitter, frame, 0, xa);
      jitter_positions(s->b.mesh.positions, kJitter, frame, 1, xb);
    }
    const PairContacts ours =
        detect_pair(xa, s->a.mesh.tets, s->a.topo, xb, s->b.mesh.tets, s->b.topo);
    const CgalResult cgal = cgal_overlapping(xa, s->a.mesh.tets, xb, s->b.mesh.tets);
    SCOPED_TRACE(std::string(spec.name) + (frame < 0 ? ", the pose" : ", jitter frame ") +
                 (frame < 0 ? "" : std::to_string(frame)));
    EXPECT_GT(cgal.overlapping.size(), 500u);  // many pairs to compare
    EXPECT_EQ(ours.overlapping.size(), cgal.overlapping.size());
    for (const TetPair& p : pairs_missing(ours.overlapping, cgal.overlapping))
      ADD_FAILURE() << "tetcollide has (" << p.tet_a << ", " << p.tet_b << "), CGAL not";
    for (const TetPair& p : pairs_missing(cgal.overlapping, ours.overlapping))
      ADD_FAILURE() << "CGAL has (" << p.tet_a << ", " << p.tet_b << "), tetcollide not";
  }
}

std::string scene_name(const ::testing::TestParamInfo<std::size_t>& param) {
  return kScenes[param.param].name;
}

INSTANTIATE_TEST_SUITE_P(HeavyContact, PeersExactTest, ::testing::Values(0u, 1u, 2u, 3u),
                         scene_name);

}  // namespace
}  // namespace tc::peers
