#include "config.hpp"

#include <arpa/inet.h>
#include <fnmatch.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>

#include "tetcollide.h"

namespace tc::daemon {
namespace {

/// Error that unwinds the parser; converted to an Error at the boundary.
struct ConfigError {
  ErrorCode code;
  std::string message;
};

class Parser {
 public:
  explicit Parser(std::string name) : name_(std::move(name)) {}

  [[nodiscard]] std::string where(const YAML::Mark& mark) const {
    if (mark.is_null()) return name_;
    return name_ + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
  }

  [[noreturn]] void fail(ErrorCode code, const YAML::Node& node, const std::string& what) const {
    throw ConfigError{code, where(node.Mark()) + ": " + what};
  }

  template <typename T>
  T scalar(const YAML::Node& node, const std::string& key, const char* type_name) const {
    if (!node.IsScalar()) fail(ErrorCode::kParse, node, "'" + key + "' must be " + type_name);
    try {
      return node.as<T>();
    } catch (const YAML::Exception&) {
      fail(ErrorCode::kParse, node,
           "'" + key + "' must be " + type_name + ", got '" + node.Scalar() + "'");
    }
  }

  bool boolean(const YAML::Node& node, const std::string& key) const {
    return scalar<bool>(node, key, "true or false");
  }

  std::int64_t integer(const YAML::Node& node, const std::string& key, std::int64_t lo,
                       std::int64_t hi) const {
    const auto v = scalar<std::int64_t>(node, key, "an integer");
    if (v < lo || v > hi)
      fail(ErrorCode::kInvalidArgument, node,
           "'" + key + "' must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
               "], got " + std::to_string(v));
    return v;
  }

  double real(const YAML::Node& node, const std::string& key, double lo, double hi) const {
    const auto v = scalar<double>(node, key, "a number");
    if (!std::isfinite(v) || v < lo || v > hi) {
      std::ostringstream os;
      os << "'" << key << "' must be in [" << lo << ", " << hi << "], got " << node.Scalar();
      fail(ErrorCode::kInvalidArgument, node, os.str());
    }
    return v;
  }

  std::string text(const YAML::Node& node, const std::string& key) const {
    if (node.IsNull()) return {};
    return scalar<std::string>(node, key, "a string");
  }

  std::string choice(const YAML::Node& node, const std::string& key,
                     const std::vector<std::string>& choices) const {
    const std::string v = text(node, key);
    for (const auto& c : choices)
      if (c == v) return v;
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "\"" : ", \"") + c + "\"";
    fail(ErrorCode::kInvalidArgument, node,
         "'" + key + "' must be one of " + list + ", got '" + v + "'");
  }

  std::vector<std::string> text_list(const YAML::Node& node, const std::string& key) const {
    std::vector<std::string> out;
    if (node.IsNull()) return out;
    if (!node.IsSequence()) fail(ErrorCode::kParse, node, "'" + key + "' must be a list");
    for (const auto& item : node) out.push_back(text(item, key + "[]"));
    return out;
  }

  using Setter = std::function<void(const YAML::Node&, const std::string&)>;
  struct Key {
    const char* name;
    Setter set;
  };

  /// Applies every key of the map `node` through `keys`; unknown keys are errors.
  void section(const YAML::Node& node, const std::string& prefix,
               const std::vector<Key>& keys) const {
    if (node.IsNull()) return;
    if (!node.IsMap()) fail(ErrorCode::kParse, node, "'" + prefix + "' must be a map of keys");
    for (const auto& entry : node) {
      const std::string key = entry.first.as<std::string>();
      const std::string full = prefix.empty() ? key : prefix + "." + key;
      const Key* found = nullptr;
      for (const auto& k : keys)
        if (key == k.name) found = &k;
      if (found == nullptr) {
        std::string known;
        for (const auto& k : keys) known += (known.empty() ? "" : ", ") + std::string(k.name);
        fail(ErrorCode::kParse, entry.first, "unknown key '" + full + "' (known: " + known + ")");
      }
      found->set(entry.second, full);
    }
  }

 private:
  std::string name_;
};

constexpr std::int64_t kMaxDomainId = 232;  // Cyclone's default port mapping limit

void parse_document(const Parser& p, const YAML::Node& root, DaemonConfig& c) {
  if (!root.IsMap()) p.fail(ErrorCode::kParse, root, "the configuration must be a map of keys");
  const YAML::Node version = root["version"];
  if (!version) p.fail(ErrorCode::kParse, root, "missing 'version: 1'");
  if (p.integer(version, "version", 0, std::numeric_limits<int>::max()) != 1)
    throw ConfigError{ErrorCode::kUnsupported,
                      p.where(version.Mark()) + ": configuration version " + version.Scalar() +
                          " is not supported (this daemon reads version 1)"};

  const auto dds = [&](const YAML::Node& n, const std::string& k) {
    p.section(
        n, k,
        {{"domain",
          [&](const YAML::Node& v, const std::string& kk) {
            c.domain = static_cast<std::uint32_t>(p.integer(v, kk, 0, kMaxDomainId));
          }},
         {"service_id",
          [&](const YAML::Node& v, const std::string& kk) {
            c.service_id = p.text(v, kk);
            if (c.service_id.size() > tetcollide_MAX_SERVICE_ID)
              p.fail(ErrorCode::kInvalidArgument, v,
                     "'" + kk + "' is longer than " + std::to_string(tetcollide_MAX_SERVICE_ID) +
                         " characters");
          }},
         {"partition",
          [&](const YAML::Node& v, const std::string& kk) { c.partition = p.text(v, kk); }},
         {"scenes",
          [&](const YAML::Node& v, const std::string& kk) { c.scenes = p.text_list(v, kk); }},
         {"cyclonedds_config",
          [&](const YAML::Node& v, const std::string& kk) { c.cyclonedds_config = p.text(v, kk); }},
         {"status_period_s",
          [&](const YAML::Node& v, const std::string& kk) {
            c.status_period_s = p.real(v, kk, 0.01, 3600.0);
          }},
         {"ownership_strength",
          [&](const YAML::Node& v, const std::string& kk) {
            c.ownership_strength = static_cast<std::int32_t>(
                p.integer(v, kk, 0, std::numeric_limits<std::int32_t>::max()));
          }},
         {"answer_lease_ms",
          [&](const YAML::Node& v, const std::string& kk) {
            c.answer_lease_ms = p.real(v, kk, 10.0, 1000.0);
          }},
         {"shard_strengths", [&](const YAML::Node& v, const std::string& kk) {
            c.shard_strengths.clear();
            if (v.IsNull()) return;
            if (!v.IsMap())
              p.fail(ErrorCode::kParse, v,
                     "'" + kk + "' must be a map of scene pattern: ownership strength");
            for (const auto& entry : v) {
              const std::string pattern = p.text(entry.first, kk);
              if (pattern.empty())
                p.fail(ErrorCode::kInvalidArgument, entry.first,
                       "'" + kk + "': empty scene pattern");
              c.shard_strengths.emplace_back(
                  pattern,
                  static_cast<std::int32_t>(p.integer(entry.second, kk + "." + pattern, 0,
                                                      std::numeric_limits<std::int32_t>::max())));
            }
          }}});
  };
  const auto frames = [&](const YAML::Node& n, const std::string& k) {
    p.section(n, k,
              {{"assembly_wait_ms",
                [&](const YAML::Node& v, const std::string& kk) {
                  c.assembly_wait_ms = p.real(v, kk, 0.0, 60000.0);
                }},
               {"unknown_object_grace_ms",
                [&](const YAML::Node& v, const std::string& kk) {
                  c.unknown_object_grace_ms = p.real(v, kk, 0.0, 60000.0);
                }},
               {"max_queued", [&](const YAML::Node& v, const std::string& kk) {
                  c.max_queued_frames = static_cast<int>(p.integer(v, kk, 1, 64));
                }}});
  };
  const auto pipeline = [&](const YAML::Node& n, const std::string& k) {
    p.section(n, k,
              {{"broad_phase",
                [&](const YAML::Node& v, const std::string& kk) {
                  c.pipeline.broad_phase = p.choice(v, kk, {"", "grid", "hash", "sap", "bvh"});
                }},
               {"compute_stiffness",
                [&](const YAML::Node& v, const std::string& kk) {
                  c.pipeline.compute_stiffness = p.boolean(v, kk);
                }},
               {"density_threshold",
                [&](const YAML::Node& v, const std::string& kk) {
                  c.pipeline.density_threshold = p.real(v, kk, 0.0, 1.0);
                }},
               {"max_inverted_tets",
                [&](const YAML::Node& v, const std::string& kk) {
                  c.pipeline.max_inverted_tets =
                      static_cast<std::size_t>(p.integer(v, kk, 0, tetcollide_MAX_TETS));
                }},
               {"max_inverted_fraction", [&](const YAML::Node& v, const std::string& kk) {
                  c.pipeline.max_inverted_fraction = p.real(v, kk, 0.0, 1.0);
                }}});
  };
  const auto limits = [&](const YAML::Node& n, const std::string& k) {
    p.section(n, k,
              {{"max_nodes",
                [&](const YAML::Node& v, const std::string& kk) {
                  c.limits.max_nodes = p.integer(v, kk, 4, tetcollide_MAX_NODES);
                }},
               {"max_tets",
                [&](const YAML::Node& v, const std::string& kk) {
                  c.limits.max_tets = p.integer(v, kk, 1, tetcollide_MAX_TETS);
                }},
               {"max_objects_per_scene",
                [&](const YAML::Node& v, const std::string& kk) {
                  c.limits.max_objects_per_scene = p.integer(v, kk, 1, 100000);
                }},
               {"max_scenes", [&](const YAML::Node& v, const std::string& kk) {
                  c.limits.max_scenes = p.integer(v, kk, 1, 100000);
                }}});
  };
  const auto log = [&](const YAML::Node& n, const std::string& k) {
    p.section(
        n, k,
        {{"level",
          [&](const YAML::Node& v, const std::string& kk) {
            c.log_level = p.choice(v, kk, {"trace", "debug", "info", "warn", "error", "off"});
          }},
         {"file", [&](const YAML::Node& v, const std::string& kk) { c.log_file = p.text(v, kk); }},
         {"timing_summary_period_s", [&](const YAML::Node& v, const std::string& kk) {
            c.timing_summary_period_s = p.real(v, kk, 0.0, 86400.0);
          }}});
  };

  p.section(root, "",
            {{"version", [](const YAML::Node&, const std::string&) {}},
             {"dds", dds},
             {"threads",
              [&](const YAML::Node& v, const std::string& kk) {
                c.threads = static_cast<int>(p.integer(v, kk, 0, 1024));
              }},
             {"frames", frames},
             {"pipeline", pipeline},
             {"limits", limits},
             {"log", log},
             {"metrics", [&](const YAML::Node& n, const std::string& k) {
                p.section(n, k, {{"listen", [&](const YAML::Node& v, const std::string& kk) {
                                    c.metrics_listen = p.text(v, kk);
                                    if (c.metrics_listen.empty()) return;
                                    if (auto a = parse_listen_address(c.metrics_listen); !a)
                                      p.fail(ErrorCode::kInvalidArgument, v, a.error().message);
                                  }}});
              }}});
}

}  // namespace

Expected<DaemonConfig> parse_config(std::string_view text, const std::string& name) {
  DaemonConfig config;
  const Parser parser(name);
  try {
    const YAML::Node root = YAML::Load(std::string(text));
    parse_document(parser, root, config);
  } catch (const ConfigError& e) {
    return Error{e.code, e.message};
  } catch (const YAML::Exception& e) {
    return Error{ErrorCode::kParse, parser.where(e.mark) + ": " + e.msg};
  }
  if (Status st = check_config(config); !st)
    return Error{st.error().code, name + ": " + st.error().message};
  return config;
}

Expected<DaemonConfig> load_config(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{ErrorCode::kIo, path.string() + ": cannot open the configuration file"};
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) return Error{ErrorCode::kIo, path.string() + ": read error"};
  return parse_config(buffer.str(), path.string());
}

Status check_config(const DaemonConfig& c) {
  if (c.domain > kMaxDomainId)
    return Error{ErrorCode::kInvalidArgument,
                 "dds.domain must be in [0, 232], got " + std::to_string(c.domain)};
  if (c.service_id.size() > tetcollide_MAX_SERVICE_ID)
    return Error{ErrorCode::kInvalidArgument, "dds.service_id is too long"};
  for (const auto& pattern : c.scenes)
    if (pattern.empty() || pattern.size() > tetcollide_MAX_SCENE_NAME)
      return Error{ErrorCode::kInvalidArgument, "dds.scenes: a pattern must have 1 to " +
                                                    std::to_string(tetcollide_MAX_SCENE_NAME) +
                                                    " characters"};
  if (c.limits.max_nodes < 4 || c.limits.max_nodes > tetcollide_MAX_NODES)
    return Error{ErrorCode::kInvalidArgument, "limits.max_nodes is out of range"};
  if (c.limits.max_tets < 1 || c.limits.max_tets > tetcollide_MAX_TETS)
    return Error{ErrorCode::kInvalidArgument, "limits.max_tets is out of range"};
  if (!c.metrics_listen.empty())
    if (auto a = parse_listen_address(c.metrics_listen); !a) return a.error();
  return {};
}

Expected<ListenAddress> parse_listen_address(std::string_view text) {
  const auto bad = [&](const std::string& why) {
    return Error{ErrorCode::kInvalidArgument,
                 "metrics.listen: '" + std::string(text) + "' " + why +
                     " (HOST:PORT with a numeric IPv4 address, a bracketed IPv6 address or "
                     "localhost, e.g. 127.0.0.1:9464; empty = no metrics)"};
  };
  const auto colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0) return bad("is not HOST:PORT");
  const std::string host(text.substr(0, colon));
  const std::string port_text(text.substr(colon + 1));
  if (port_text.empty() || port_text.size() > 5 ||
      port_text.find_first_not_of("0123456789") != std::string::npos ||
      std::stoi(port_text) > 65535)
    return bad("has no port in [0, 65535]");
  ListenAddress out;
  out.port = static_cast<std::uint16_t>(std::stoi(port_text));
  if (host == "localhost") {
    out.host = "127.0.0.1";
    out.loopback = true;
    return out;
  }
  if (host.front() == '[') {
    in6_addr a6{};
    if (host.size() < 3 || host.back() != ']' ||
        inet_pton(AF_INET6, host.substr(1, host.size() - 2).c_str(), &a6) != 1)
      return bad("has no valid IPv6 address in brackets");
    out.host = host;
    out.loopback = IN6_IS_ADDR_LOOPBACK(&a6);
    return out;
  }
  in_addr a4{};
  if (inet_pton(AF_INET, host.c_str(), &a4) != 1)
    return bad("has no numeric IPv4 address (host names are not resolved)");
  out.host = host;
  out.loopback = (ntohl(a4.s_addr) >> 24) == 127;
  return out;
}

std::int32_t scene_strength(const std::vector<std::pair<std::string, std::int32_t>>& shards,
                            std::int32_t fallback, std::string_view scene) {
  if (shards.empty()) return fallback;  // every answer comes here: no string without shards
  const std::string name(scene);
  for (const auto& [pattern, strength] : shards)
    if (fnmatch(pattern.c_str(), name.c_str(), 0) == 0) return strength;
  return fallback;
}

bool scene_selected(const std::vector<std::string>& patterns, std::string_view scene) {
  if (patterns.empty()) return true;
  const std::string name(scene);
  for (const auto& pattern : patterns)
    if (fnmatch(pattern.c_str(), name.c_str(), 0) == 0) return true;
  return false;
}

}  // namespace tc::daemon
