// tools/replay/recording: every record type survives the file bit for bit, including
// non-finite numbers; bad files are rejected with the line at fault.
#include "recording.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

namespace tc::replay {
namespace {

std::filesystem::path temp_file(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         ("tc-recording-" + std::to_string(getpid()) + "-" + name);
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

std::vector<double> awkward_doubles() {
  std::vector<double> v{0.0,
                        -0.0,
                        1.0 / 3.0,
                        std::nextafter(1.0, 2.0),
                        5e-324,
                        std::numeric_limits<double>::min(),
                        std::numeric_limits<double>::max(),
                        -1e300,
                        123456789.123456789,
                        std::numeric_limits<double>::quiet_NaN(),
                        std::numeric_limits<double>::infinity(),
                        -std::numeric_limits<double>::infinity()};
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1e6, 1e6);
  for (int i = 0; i < 200; ++i) v.push_back(u(rng) * std::pow(10.0, (i % 40) - 20));
  return v;
}

bool same_doubles_nan_aware(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(a[i]) && std::isnan(b[i])) continue;
    if (std::memcmp(&a[i], &b[i], sizeof(double)) != 0) return false;
  }
  return true;
}

// A surface object's topology keeps its triangles; a tet object's record has no
// "triangles" key at all (older recordings and readers are unaffected).
TEST(Recording, SurfaceTopologiesKeepTheirTrianglesAndTetOnesHaveNoKey) {
  TopologyRecord surface;
  surface.scene = "s";
  surface.object = "tool";
  surface.version = 2;
  surface.mesh.rest_positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
  surface.mesh.triangles = {0, 1, 2, 1, 3, 2};
  TopologyRecord tets = surface;
  tets.object = "box";
  tets.mesh.triangles.clear();
  tets.mesh.tets = {0, 1, 2, 3};
  const auto path = temp_file("surface.jsonl");
  RecordingWriter w;
  ASSERT_TRUE(w.open(path, 1));
  ASSERT_TRUE(w.write(surface));
  ASSERT_TRUE(w.write(tets));
  ASSERT_TRUE(w.close());
  std::ostringstream text_stream;
  text_stream << std::ifstream(path).rdbuf();
  const std::string text = text_stream.str();
  const auto back = read_recording(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(back) << back.error().message;
  ASSERT_EQ(back->size(), 2u);
  EXPECT_EQ(std::get<TopologyRecord>((*back)[0]).mesh.triangles, surface.mesh.triangles);
  EXPECT_TRUE(std::get<TopologyRecord>((*back)[0]).mesh.tets.empty());
  EXPECT_TRUE(std::get<TopologyRecord>((*back)[1]).mesh.triangles.empty());
  EXPECT_EQ(text.find("triangles"), text.rfind("triangles")) << "one key, the surface's";
  EXPECT_NE(text.find("\"triangles\":[0,1,2,1,3,2]"), std::string::npos) << text;
}

TEST(Recording, EveryRecordTypeRoundTrips) {
  TopologyRecord topo;
  topo.t = 0.125;
  topo.scene = "s";
  topo.object = "o";
  topo.version = 3;
  topo.mesh.node_ids = {10, 20, 30, 40};
  topo.mesh.rest_positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1.0 / 3.0};
  topo.mesh.tets = {0, 1, 2, 3};
  topo.params.stiffness = 12.5;
  topo.params.damping = 0.25;
  topo.params.max_force = 3.0;
  topo.params.is_static = true;
  topo.params.depth = client::DepthMethod::kCffm;
  topo.params.response = client::ResponseKind::kSegment;
  StateRecord state;
  state.t = 1.5;
  state.scene = "s";
  state.object = "o";
  state.frame = 1234567890123;
  state.topology_version = 3;
  state.positions = awkward_doubles();
  ForcesRecord forces;
  forces.t = 2.0;
  forces.scene = "s";
  forces.object = "o";
  forces.frame = 7;
  forces.topology_version = 3;
  forces.status = 4;
  forces.nodes = {1, 5, 9};
  forces.forces = {0.1, -0.2, 1e-300, 4, 5, 6, 7, 8, 9};
  forces.stiffness = std::vector<double>(27, -2.5);
  StatusRecord status;
  status.t = 3.0;
  status.event.service_id = "svc";
  status.event.sequence_number = 99;
  status.event.state = client::StatusEvent::State::kReady;
  status.event.kind = client::StatusEvent::Kind::kError;
  status.event.code = 6;
  status.event.scene = "s";
  status.event.object = "ghost";
  status.event.topology_version = 2;
  status.event.frame = 11;
  status.event.message = "quote \" backslash \\ newline \n tab \t";
  status.event.topology_timestamp = 1795322045221727123;
  const RemoveRecord remove{4.0, "s", "o"};

  const auto path = temp_file("roundtrip.jsonl");
  RecordingWriter w;
  ASSERT_TRUE(w.open(path, 42));
  for (const Record& r : std::vector<Record>{topo, state, forces, status, remove})
    ASSERT_TRUE(w.write(r));
  ASSERT_TRUE(w.close());
  const auto back = read_recording(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(back) << back.error().message;
  ASSERT_EQ(back->size(), 5u);

  const auto& t2 = std::get<TopologyRecord>((*back)[0]);
  EXPECT_EQ(t2.t, 0.125);
  EXPECT_EQ(t2.version, 3u);
  EXPECT_EQ(t2.mesh.node_ids, topo.mesh.node_ids);
  EXPECT_TRUE(same_bits(t2.mesh.rest_positions, topo.mesh.rest_positions));
  EXPECT_EQ(t2.mesh.tets, topo.mesh.tets);
  EXPECT_EQ(t2.params.stiffness, 12.5);
  EXPECT_TRUE(t2.params.is_static);
  EXPECT_EQ(t2.params.depth, client::DepthMethod::kCffm);
  EXPECT_EQ(t2.params.response, client::ResponseKind::kSegment);
  const auto& s2 = std::get<StateRecord>((*back)[1]);
  EXPECT_EQ(s2.frame, 1234567890123);
  EXPECT_TRUE(same_doubles_nan_aware(s2.positions, state.positions));
  EXPECT_TRUE(std::isnan(s2.positions[9]));
  EXPECT_EQ(s2.positions[10], std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::signbit(s2.positions[1]));  // -0.0 kept
  const auto& f2 = std::get<ForcesRecord>((*back)[2]);
  EXPECT_EQ(f2.status, 4);
  EXPECT_EQ(f2.nodes, forces.nodes);
  EXPECT_TRUE(same_bits(f2.forces, forces.forces));
  EXPECT_TRUE(same_bits(f2.stiffness, forces.stiffness));
  const auto& st2 = std::get<StatusRecord>((*back)[3]);
  EXPECT_EQ(st2.event.message, status.event.message);
  EXPECT_EQ(st2.event.kind, client::StatusEvent::Kind::kError);
  EXPECT_EQ(st2.event.sequence_number, 99u);
  EXPECT_EQ(st2.event.topology_timestamp, 1795322045221727123);
  const auto& r2 = std::get<RemoveRecord>((*back)[4]);
  EXPECT_EQ(r2.object, "o");
}

TEST(Recording, HeaderIsExactlyTheDocumentedLine) {
  const auto path = temp_file("header.jsonl");
  RecordingWriter w;
  ASSERT_TRUE(w.open(path, 1));
  ASSERT_TRUE(w.close());
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::filesystem::remove(path);
  EXPECT_EQ(line, R"({"format":"tetcollide-recording","version":1})");
}

struct BadFile {
  const char* name;
  const char* text;
  ErrorCode code;
  const char* mentions;
};

class RecordingBad : public ::testing::TestWithParam<BadFile> {};

TEST_P(RecordingBad, IsRejected) {
  const auto path = temp_file(std::string(GetParam().name) + ".jsonl");
  std::ofstream(path) << GetParam().text;
  const auto r = read_recording(path);
  std::filesystem::remove(path);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, GetParam().code) << r.error().message;
  EXPECT_NE(r.error().message.find(GetParam().mentions), std::string::npos) << r.error().message;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, RecordingBad,
    ::testing::Values(
        BadFile{"empty", "", ErrorCode::kParse, ":1: empty file"},
        BadFile{"not_json", "hello\n", ErrorCode::kParse, ":1:"},
        BadFile{"other_format", "{\"format\":\"x\",\"version\":1}\n", ErrorCode::kParse,
                "not a tetcollide recording"},
        BadFile{"version_2", "{\"format\":\"tetcollide-recording\",\"version\":2}\n",
                ErrorCode::kUnsupported, "version 2"},
        // Found by fuzz/fuzz_recording: a header without "version" read a missing key
        // of a const json (undefined behaviour, a heap overflow under ASan).
        BadFile{"no_version", "{\"format\":\"tetcollide-recording\"}\n", ErrorCode::kParse,
                ":1: the header has no \"version\""},
        BadFile{"version_string", "{\"format\":\"tetcollide-recording\",\"version\":\"1\"}\n",
                ErrorCode::kUnsupported, "recording version \"1\" is not supported"},
        BadFile{"bad_line",
                "{\"format\":\"tetcollide-recording\",\"version\":1}\n{\"type\":\"state\"}\n",
                ErrorCode::kParse, ":2:"},
        BadFile{"unknown_type",
                "{\"format\":\"tetcollide-recording\",\"version\":1}\n\n"
                "{\"type\":\"bogus\",\"t\":0}\n",
                ErrorCode::kParse, ":3: unknown record type 'bogus'"},
        BadFile{"bad_number_string",
                "{\"format\":\"tetcollide-recording\",\"version\":1}\n"
                "{\"type\":\"state\",\"t\":0,\"scene\":\"s\",\"object\":\"o\",\"frame\":1,"
                "\"topology_version\":1,\"positions\":[\"nope\"],\"velocities\":[]}\n",
                ErrorCode::kParse, "bad number string 'nope'"}),
    [](const ::testing::TestParamInfo<BadFile>& p) { return std::string(p.param.name); });

TEST(Recording, MissingFileIsIo) {
  const auto r = read_recording("/nonexistent/recording.jsonl");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::kIo);
}

}  // namespace
}  // namespace tc::replay
