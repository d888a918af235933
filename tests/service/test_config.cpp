// service/daemon/config: defaults, the shipped file, and every kind of bad input.
#include "config.hpp"

#include <gtest/gtest.h>

#include <fstream>

namespace tc::daemon {
namespace {

DaemonConfig parse_ok(const std::string& text) {
  auto c = parse_config(text, "test.yaml");
  EXPECT_TRUE(c.has_value()) << (c ? "" : c.error().message);
  DaemonConfig out;
  if (c) out = std::move(*c);
  return out;
}

Error parse_error(const std::string& text) {
  auto c = parse_config(text, "test.yaml");
  EXPECT_FALSE(c.has_value());
  return c ? Error{ErrorCode::kIo, "parsed"} : c.error();
}

void expect_same(const DaemonConfig& a, const DaemonConfig& b) {
  EXPECT_EQ(a.domain, b.domain);
  EXPECT_EQ(a.service_id, b.service_id);
  EXPECT_EQ(a.partition, b.partition);
  EXPECT_EQ(a.scenes, b.scenes);
  EXPECT_EQ(a.cyclonedds_config, b.cyclonedds_config);
  EXPECT_EQ(a.status_period_s, b.status_period_s);
  EXPECT_EQ(a.ownership_strength, b.ownership_strength);
  EXPECT_EQ(a.answer_lease_ms, b.answer_lease_ms);
  EXPECT_EQ(a.shard_strengths, b.shard_strengths);
  EXPECT_EQ(a.threads, b.threads);
  EXPECT_EQ(a.assembly_wait_ms, b.assembly_wait_ms);
  EXPECT_EQ(a.unknown_object_grace_ms, b.unknown_object_grace_ms);
  EXPECT_EQ(a.max_queued_frames, b.max_queued_frames);
  EXPECT_EQ(a.pipeline.broad_phase, b.pipeline.broad_phase);
  EXPECT_EQ(a.pipeline.compute_stiffness, b.pipeline.compute_stiffness);
  EXPECT_EQ(a.pipeline.density_threshold, b.pipeline.density_threshold);
  EXPECT_EQ(a.pipeline.max_inverted_tets, b.pipeline.max_inverted_tets);
  EXPECT_EQ(a.pipeline.max_inverted_fraction, b.pipeline.max_inverted_fraction);
  EXPECT_EQ(a.limits.max_nodes, b.limits.max_nodes);
  EXPECT_EQ(a.limits.max_tets, b.limits.max_tets);
  EXPECT_EQ(a.limits.max_objects_per_scene, b.limits.max_objects_per_scene);
  EXPECT_EQ(a.limits.max_scenes, b.limits.max_scenes);
  EXPECT_EQ(a.log_level, b.log_level);
  EXPECT_EQ(a.log_file, b.log_file);
  EXPECT_EQ(a.timing_summary_period_s, b.timing_summary_period_s);
  EXPECT_EQ(a.metrics_listen, b.metrics_listen);
}

TEST(Config, ShippedFileEqualsEmbeddedDefaults) {
  auto c = load_config(std::string(TC_SOURCE_DIR) + "/config/tetcollided.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  const DaemonConfig defaults;
  expect_same(*c, defaults);
}

TEST(Config, VersionOnlyGivesDefaults) {
  const DaemonConfig defaults;
  expect_same(parse_ok("version: 1\n"), defaults);
}

TEST(Config, EveryKeyIsRead) {
  const DaemonConfig c = parse_ok(R"(version: 1
dds:
  domain: 42
  service_id: svc-a
  partition: lab
  scenes: [ "surgery*", "demo" ]
  cyclonedds_config: "file:///etc/x.xml"
  status_period_s: 0.5
  ownership_strength: 20
  answer_lease_ms: 250
  shard_strengths: {"surgery-a*": 20, "surgery*": 10}
threads: 3
frames:
  assembly_wait_ms: 2.5
  unknown_object_grace_ms: 50
  max_queued: 4
pipeline:
  broad_phase: sap
  compute_stiffness: true
  density_threshold: 0.05
  max_inverted_tets: 0
  max_inverted_fraction: 0.5
limits:
  max_nodes: 5000
  max_tets: 20000
  max_objects_per_scene: 8
  max_scenes: 2
log:
  level: debug
  file: /tmp/x.log
  timing_summary_period_s: 0
metrics:
  listen: 127.0.0.1:9464
)");
  EXPECT_EQ(c.domain, 42u);
  EXPECT_EQ(c.service_id, "svc-a");
  EXPECT_EQ(c.partition, "lab");
  EXPECT_EQ(c.scenes, (std::vector<std::string>{"surgery*", "demo"}));
  EXPECT_EQ(c.cyclonedds_config, "file:///etc/x.xml");
  EXPECT_DOUBLE_EQ(c.status_period_s, 0.5);
  EXPECT_EQ(c.ownership_strength, 20);
  EXPECT_DOUBLE_EQ(c.answer_lease_ms, 250.0);
  EXPECT_EQ(c.shard_strengths, (std::vector<std::pair<std::string, std::int32_t>>{
                                   {"surgery-a*", 20}, {"surgery*", 10}}));
  // First matching pattern, in the file's order; the rest keep ownership_strength.
  EXPECT_EQ(scene_strength(c.shard_strengths, c.ownership_strength, "surgery-a1"), 20);
  EXPECT_EQ(scene_strength(c.shard_strengths, c.ownership_strength, "surgery-b1"), 10);
  EXPECT_EQ(scene_strength(c.shard_strengths, c.ownership_strength, "demo"), 20);
  EXPECT_EQ(c.threads, 3);
  EXPECT_DOUBLE_EQ(c.assembly_wait_ms, 2.5);
  EXPECT_DOUBLE_EQ(c.unknown_object_grace_ms, 50.0);
  EXPECT_EQ(c.max_queued_frames, 4);
  EXPECT_EQ(c.pipeline.broad_phase, "sap");
  EXPECT_TRUE(c.pipeline.compute_stiffness);
  EXPECT_DOUBLE_EQ(c.pipeline.density_threshold, 0.05);
  EXPECT_EQ(c.pipeline.max_inverted_tets, 0u);
  EXPECT_DOUBLE_EQ(c.pipeline.max_inverted_fraction, 0.5);
  EXPECT_EQ(c.limits.max_nodes, 5000);
  EXPECT_EQ(c.limits.max_tets, 20000);
  EXPECT_EQ(c.limits.max_objects_per_scene, 8);
  EXPECT_EQ(c.limits.max_scenes, 2);
  EXPECT_EQ(c.log_level, "debug");
  EXPECT_EQ(c.log_file, "/tmp/x.log");
  EXPECT_EQ(c.timing_summary_period_s, 0.0);
  EXPECT_EQ(c.metrics_listen, "127.0.0.1:9464");
}

struct BadCase {
  const char* name;
  const char* text;
  ErrorCode code;
  const char* location;  ///< expected "file:line:col" prefix of the message
  const char* mentions;  ///< text the message must contain
};

class ConfigBad : public ::testing::TestWithParam<BadCase> {};

TEST_P(ConfigBad, IsRejectedWithLocation) {
  const BadCase& c = GetParam();
  const Error e = parse_error(c.text);
  EXPECT_EQ(e.code, c.code) << e.message;
  EXPECT_EQ(e.message.rfind(c.location, 0), 0u) << e.message;
  EXPECT_NE(e.message.find(c.mentions), std::string::npos) << e.message;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, ConfigBad,
    ::testing::Values(
        BadCase{"missing_version", "dds:\n  domain: 1\n", ErrorCode::kParse, "test.yaml:1:1",
                "version"},
        BadCase{"version_2", "version: 2\n", ErrorCode::kUnsupported, "test.yaml:1:10",
                "version 2"},
        BadCase{"unknown_top", "version: 1\nthread: 4\n", ErrorCode::kParse, "test.yaml:2:1",
                "unknown key 'thread'"},
        BadCase{"unknown_nested", "version: 1\nframes:\n  assembly_wait: 3\n", ErrorCode::kParse,
                "test.yaml:3:3", "unknown key 'frames.assembly_wait'"},
        BadCase{"domain_range", "version: 1\ndds:\n  domain: 300\n", ErrorCode::kInvalidArgument,
                "test.yaml:3:11", "dds.domain"},
        BadCase{"negative_strength", "version: 1\ndds:\n  ownership_strength: -1\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:23", "dds.ownership_strength"},
        BadCase{"strength_over_int32", "version: 1\ndds:\n  ownership_strength: 2147483648\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:23", "dds.ownership_strength"},
        BadCase{"answer_lease_over_protocol", "version: 1\ndds:\n  answer_lease_ms: 1500\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:20", "dds.answer_lease_ms"},
        BadCase{"answer_lease_too_short", "version: 1\ndds:\n  answer_lease_ms: 5\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:20", "dds.answer_lease_ms"},
        BadCase{"shard_strengths_not_map", "version: 1\ndds:\n  shard_strengths: [1, 2]\n",
                ErrorCode::kParse, "test.yaml:3:20", "dds.shard_strengths"},
        BadCase{"shard_strength_negative", "version: 1\ndds:\n  shard_strengths: {\"a*\": -1}\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:27", "dds.shard_strengths.a*"},
        BadCase{"domain_type", "version: 1\ndds:\n  domain: abc\n", ErrorCode::kParse,
                "test.yaml:3:11", "an integer"},
        BadCase{"negative_wait", "version: 1\nframes:\n  assembly_wait_ms: -1\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:21", "frames.assembly_wait_ms"},
        BadCase{"broad_phase", "version: 1\npipeline:\n  broad_phase: octree\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:16",
                "\"\", \"grid\", \"hash\", \"sap\", \"bvh\""},
        BadCase{"bool", "version: 1\npipeline:\n  compute_stiffness: maybe\n", ErrorCode::kParse,
                "test.yaml:3:22", "true or false"},
        BadCase{"inverted_fraction", "version: 1\npipeline:\n  max_inverted_fraction: 2\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:26", "pipeline.max_inverted_fraction"},
        BadCase{"inverted_tets", "version: 1\npipeline:\n  max_inverted_tets: -1\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:22", "pipeline.max_inverted_tets"},
        BadCase{"level", "version: 1\nlog:\n  level: loud\n", ErrorCode::kInvalidArgument,
                "test.yaml:3:10", "log.level"},
        BadCase{"limit_over_idl", "version: 1\nlimits:\n  max_nodes: 2000000\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:14", "limits.max_nodes"},
        BadCase{"section_not_map", "version: 1\ndds: 5\n", ErrorCode::kParse, "test.yaml:2:6",
                "'dds' must be a map"},
        BadCase{"scenes_not_list", "version: 1\ndds:\n  scenes: abc\n", ErrorCode::kParse,
                "test.yaml:3:11", "must be a list"},
        BadCase{"yaml_syntax", "version: 1\ndds: [\n", ErrorCode::kParse,
                "test.yaml:", "test.yaml"},
        BadCase{"not_a_map", "- 1\n- 2\n", ErrorCode::kParse, "test.yaml:1:1", "map"},
        BadCase{"metrics_no_port", "version: 1\nmetrics:\n  listen: 127.0.0.1\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:11", "metrics.listen"},
        BadCase{"metrics_host_name", "version: 1\nmetrics:\n  listen: prometheus.lan:9464\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:11", "host names are not resolved"},
        BadCase{"metrics_port_range", "version: 1\nmetrics:\n  listen: 127.0.0.1:70000\n",
                ErrorCode::kInvalidArgument, "test.yaml:3:11", "port in [0, 65535]"},
        BadCase{"metrics_unknown_key", "version: 1\nmetrics:\n  port: 9464\n", ErrorCode::kParse,
                "test.yaml:3:3", "unknown key 'metrics.port'"}),
    [](const ::testing::TestParamInfo<BadCase>& p) { return std::string(p.param.name); });

TEST(Config, MissingFileIsIo) {
  auto c = load_config("/nonexistent/tetcollided.yaml");
  ASSERT_FALSE(c.has_value());
  EXPECT_EQ(c.error().code, ErrorCode::kIo);
}

TEST(Config, MetricsListenAddresses) {
  const auto loopback = parse_listen_address("127.0.0.1:9464");
  ASSERT_TRUE(loopback.has_value());
  EXPECT_EQ(loopback->host, "127.0.0.1");
  EXPECT_EQ(loopback->port, 9464);
  EXPECT_TRUE(loopback->loopback);
  const auto localhost = parse_listen_address("localhost:0");
  ASSERT_TRUE(localhost.has_value());
  EXPECT_EQ(localhost->host, "127.0.0.1");
  EXPECT_EQ(localhost->port, 0);
  EXPECT_TRUE(localhost->loopback);
  const auto v6 = parse_listen_address("[::1]:9464");
  ASSERT_TRUE(v6.has_value());
  EXPECT_EQ(v6->host, "[::1]");
  EXPECT_TRUE(v6->loopback);
  // Allowed, but not loopback: the daemon warns at the start.
  for (const char* open : {"0.0.0.0:9464", "10.1.2.3:9464", "[::]:9464"}) {
    const auto a = parse_listen_address(open);
    ASSERT_TRUE(a.has_value()) << open;
    EXPECT_FALSE(a->loopback) << open;
  }
  for (const char* bad : {"", ":9464", "127.0.0.1:", "127.0.0.1:x", "1.2.3:80", "[::1:80",
                          "[zz]:80", "127.0.0.1:123456"}) {
    const auto a = parse_listen_address(bad);
    ASSERT_FALSE(a.has_value()) << bad;
    EXPECT_EQ(a.error().message.rfind("metrics.listen: ", 0), 0u) << a.error().message;
  }
  EXPECT_EQ(parse_ok("version: 1\nmetrics:\n  listen: \"\"\n").metrics_listen, "");
  DaemonConfig c;
  c.metrics_listen = "nowhere";
  EXPECT_FALSE(check_config(c));
}

TEST(Config, CheckConfigCatchesOverrides) {
  DaemonConfig c;
  c.domain = 233;
  EXPECT_FALSE(check_config(c));
  c.domain = 232;
  EXPECT_TRUE(check_config(c));
}

TEST(Config, SceneSelection) {
  EXPECT_TRUE(scene_selected({}, "anything"));
  const std::vector<std::string> p{"surgery*", "demo"};
  EXPECT_TRUE(scene_selected(p, "surgery-3"));
  EXPECT_TRUE(scene_selected(p, "demo"));
  EXPECT_FALSE(scene_selected(p, "demo2"));
  EXPECT_FALSE(scene_selected(p, "other"));
}

}  // namespace
}  // namespace tc::daemon
