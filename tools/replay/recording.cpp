#include "recording.hpp"

#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <utility>

namespace tc::replay {
namespace {

using nlohmann::json;

/// JSON array of doubles; non-finite values (which JSON cannot hold) become the strings
/// "NaN", "Infinity", "-Infinity". Finite values are written in the shortest form that
/// reads back to the same bits.
json doubles(const std::vector<double>& values) {
  json a = json::array();
  for (const double v : values) {
    if (std::isnan(v)) {
      a.push_back("NaN");
    } else if (std::isinf(v)) {
      a.push_back(v > 0 ? "Infinity" : "-Infinity");
    } else {
      a.push_back(v);
    }
  }
  return a;
}

/// An integer field of type T: a JSON integer within T's range. nlohmann's get<T>() would
/// also accept a float and convert it with a cast that is undefined out of range (found
/// by the recording fuzzer: 1.2e21 as a node index).
template <typename T>
T integer(const json& v, const char* what) {
  if (!v.is_number_integer())
    throw std::invalid_argument(std::string("'") + what + "' must be an integer");
  const bool in_range = v.is_number_unsigned() ? std::in_range<T>(v.get<std::uint64_t>())
                                               : std::in_range<T>(v.get<std::int64_t>());
  if (!in_range) throw std::invalid_argument(std::string("'") + what + "' is out of range");
  return v.is_number_unsigned() ? static_cast<T>(v.get<std::uint64_t>())
                                : static_cast<T>(v.get<std::int64_t>());
}

template <typename T>
std::vector<T> integers(const json& a, const char* what) {
  if (!a.is_array()) throw std::invalid_argument(std::string("'") + what + "' must be an array");
  std::vector<T> out;
  out.reserve(a.size());
  for (const auto& v : a) out.push_back(integer<T>(v, what));
  return out;
}

std::vector<double> read_doubles(const json& a) {
  std::vector<double> out;
  out.reserve(a.size());
  for (const auto& v : a) {
    if (v.is_string()) {
      const auto& s = v.get_ref<const std::string&>();
      if (s == "NaN") {
        out.push_back(std::numeric_limits<double>::quiet_NaN());
      } else if (s == "Infinity") {
        out.push_back(std::numeric_limits<double>::infinity());
      } else if (s == "-Infinity") {
        out.push_back(-std::numeric_limits<double>::infinity());
      } else {
        throw std::invalid_argument("bad number string '" + s + "'");
      }
    } else {
      out.push_back(v.get<double>());
    }
  }
  return out;
}

client::DepthMethod depth_of(const std::string& s) {
  if (const auto m = client::parse_depth_method(s)) return *m;
  throw std::invalid_argument("unknown depth method '" + s + "'");
}

client::ResponseKind response_of(const std::string& s) {
  if (const auto k = client::parse_response_kind(s)) return *k;
  throw std::invalid_argument("unknown response kind '" + s + "'");
}

json encode(const TopologyRecord& r) {
  json j = {{"type", "topology"},
            {"t", r.t},
            {"scene", r.scene},
            {"object", r.object},
            {"version", r.version},
            {"node_ids", r.mesh.node_ids},
            {"rest_positions", doubles(r.mesh.rest_positions)},
            {"tets", r.mesh.tets},
            {"params",
             {{"stiffness", r.params.stiffness},
              {"damping", r.params.damping},
              {"max_force", r.params.max_force},
              {"is_static", r.params.is_static},
              {"depth", client::depth_method_name(r.params.depth)},
              {"response", client::response_kind_name(r.params.response)},
              {"friction", r.params.friction},
              {"friction_velocity", r.params.friction_velocity},
              {"blocks", r.params.blocks},
              {"contacts", r.params.contacts}}}};
  // Written only when on: recordings of objects without self-contact stay as they were.
  if (r.params.self_contact) j["params"]["self_contact"] = true;
  // Only surface objects carry triangles: tet recordings stay as they were.
  if (!r.mesh.triangles.empty()) j["triangles"] = r.mesh.triangles;
  return j;
}

json encode(const RemoveRecord& r) {
  return {{"type", "remove"}, {"t", r.t}, {"scene", r.scene}, {"object", r.object}};
}

json encode(const StateRecord& r) {
  return {{"type", "state"},
          {"t", r.t},
          {"scene", r.scene},
          {"object", r.object},
          {"frame", r.frame},
          {"topology_version", r.topology_version},
          {"positions", doubles(r.positions)},
          {"velocities", doubles(r.velocities)}};
}

json encode(const ForcesRecord& r) {
  json j = {{"type", "forces"},
            {"t", r.t},
            {"scene", r.scene},
            {"object", r.object},
            {"frame", r.frame},
            {"topology_version", r.topology_version},
            {"status", r.status},
            {"nodes", r.nodes},
            {"forces", doubles(r.forces)},
            {"stiffness", doubles(r.stiffness)}};
  // Only answers with df/dv blocks (protocol 3) carry them: other records stay as they were.
  if (!r.damping.empty()) j["damping"] = doubles(r.damping);
  return j;
}

json encode(const StatusRecord& r) {
  const auto& e = r.event;
  return {{"type", "status"},
          {"t", r.t},
          {"service_id", e.service_id},
          {"sequence_number", e.sequence_number},
          {"state", static_cast<int>(e.state)},
          {"kind", static_cast<int>(e.kind)},
          {"code", e.code},
          {"scene", e.scene},
          {"object", e.object},
          {"topology_version", e.topology_version},
          {"frame", e.frame},
          {"message", e.message},
          {"topology_timestamp", e.topology_timestamp}};
}

Record decode(const json& j) {
  const std::string type = j.at("type").get<std::string>();
  const double t = j.at("t").get<double>();
  if (type == "topology") {
    TopologyRecord r;
    r.t = t;
    r.scene = j.at("scene").get<std::string>();
    r.object = j.at("object").get<std::string>();
    r.version = integer<std::uint32_t>(j.at("version"), "version");
    r.mesh.node_ids = integers<std::int64_t>(j.at("node_ids"), "node_ids");
    r.mesh.rest_positions = read_doubles(j.at("rest_positions"));
    r.mesh.tets = integers<std::int32_t>(j.at("tets"), "tets");
    if (j.contains("triangles"))
      r.mesh.triangles = integers<std::int32_t>(j.at("triangles"), "triangles");
    const json& p = j.at("params");
    r.params.stiffness = p.at("stiffness").get<double>();
    r.params.damping = p.at("damping").get<double>();
    r.params.max_force = p.at("max_force").get<double>();
    r.params.is_static = p.at("is_static").get<bool>();
    r.params.depth = depth_of(p.at("depth").get<std::string>());
    r.params.response = response_of(p.at("response").get<std::string>());
    // Protocol 3's parameters; recordings made before them have none (their defaults).
    if (p.contains("friction")) r.params.friction = p.at("friction").get<double>();
    if (p.contains("friction_velocity"))
      r.params.friction_velocity = p.at("friction_velocity").get<double>();
    if (p.contains("blocks")) r.params.blocks = p.at("blocks").get<bool>();
    if (p.contains("contacts")) r.params.contacts = p.at("contacts").get<bool>();
    if (p.contains("self_contact")) r.params.self_contact = p.at("self_contact").get<bool>();
    return r;
  }
  if (type == "remove") {
    return RemoveRecord{t, j.at("scene").get<std::string>(), j.at("object").get<std::string>()};
  }
  if (type == "state") {
    StateRecord r;
    r.t = t;
    r.scene = j.at("scene").get<std::string>();
    r.object = j.at("object").get<std::string>();
    r.frame = integer<std::int64_t>(j.at("frame"), "frame");
    r.topology_version = integer<std::uint32_t>(j.at("topology_version"), "topology_version");
    r.positions = read_doubles(j.at("positions"));
    r.velocities = read_doubles(j.at("velocities"));
    return r;
  }
  if (type == "forces") {
    ForcesRecord r;
    r.t = t;
    r.scene = j.at("scene").get<std::string>();
    r.object = j.at("object").get<std::string>();
    r.frame = integer<std::int64_t>(j.at("frame"), "frame");
    r.topology_version = integer<std::uint32_t>(j.at("topology_version"), "topology_version");
    r.status = integer<std::int32_t>(j.at("status"), "status");
    r.nodes = integers<std::int32_t>(j.at("nodes"), "nodes");
    r.forces = read_doubles(j.at("forces"));
    r.stiffness = read_doubles(j.at("stiffness"));
    if (j.contains("damping")) r.damping = read_doubles(j.at("damping"));
    return r;
  }
  if (type == "status") {
    StatusRecord r;
    r.t = t;
    auto& e = r.event;
    e.service_id = j.at("service_id").get<std::string>();
    e.sequence_number = integer<std::uint64_t>(j.at("sequence_number"), "sequence_number");
    e.state = static_cast<client::StatusEvent::State>(integer<int>(j.at("state"), "state"));
    e.kind = static_cast<client::StatusEvent::Kind>(integer<int>(j.at("kind"), "kind"));
    e.code = integer<std::int32_t>(j.at("code"), "code");
    e.scene = j.at("scene").get<std::string>();
    e.object = j.at("object").get<std::string>();
    e.topology_version = integer<std::uint32_t>(j.at("topology_version"), "topology_version");
    e.frame = integer<std::int64_t>(j.at("frame"), "frame");
    e.message = j.at("message").get<std::string>();
    e.topology_timestamp = j.value("topology_timestamp", std::int64_t{0});
    return r;
  }
  throw std::invalid_argument("unknown record type '" + type + "'");
}

}  // namespace

double record_time(const Record& record) {
  return std::visit([](const auto& r) { return r.t; }, record);
}

std::string encode_record(const Record& record) {
  return std::visit([](const auto& r) { return encode(r).dump(); }, record);
}

Expected<Record> decode_record(const std::string& line, const std::string& where) {
  try {
    return decode(json::parse(line));
  } catch (const std::exception& e) {
    return Error{ErrorCode::kParse, where + ": " + e.what()};
  }
}

Status RecordingWriter::open(const std::filesystem::path& path, std::uint32_t domain) {
  path_ = path;
  out_.open(path, std::ios::binary | std::ios::trunc);
  if (!out_) return Error{ErrorCode::kIo, path.string() + ": cannot create the recording"};
  out_ << json{{"format", kFormatName}, {"version", kFormatVersion}}.dump() << '\n';
  out_ << json{{"type", "info"}, {"t", 0.0}, {"domain", domain}}.dump() << '\n';
  if (!out_) return Error{ErrorCode::kIo, path.string() + ": write error"};
  return {};
}

Status RecordingWriter::write(const Record& record) {
  out_ << encode_record(record) << '\n';
  if (!out_) return Error{ErrorCode::kIo, path_.string() + ": write error"};
  ++records_;
  return {};
}

Status RecordingWriter::flush() {
  out_.flush();
  if (!out_) return Error{ErrorCode::kIo, path_.string() + ": write error"};
  return {};
}

Status RecordingWriter::close() {
  out_.flush();
  const bool ok = static_cast<bool>(out_);
  out_.close();
  if (!ok) return Error{ErrorCode::kIo, path_.string() + ": write error"};
  return {};
}

Expected<std::vector<Record>> read_recording(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{ErrorCode::kIo, path.string() + ": cannot open the recording"};
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return Error{ErrorCode::kIo, path.string() + ": read error"};
  return read_recording_buffer(text, path.string());
}

Expected<std::vector<Record>> read_recording_buffer(std::string_view text,
                                                    const std::string& name) {
  std::size_t pos = 0;
  // The next line without its '\n'; false at the end of the text.
  const auto next_line = [&](std::string& line) {
    if (pos >= text.size()) return false;
    const std::size_t nl = text.find('\n', pos);
    const std::size_t end = nl == std::string_view::npos ? text.size() : nl;
    line.assign(text.substr(pos, end - pos));
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    return true;
  };
  std::string line;
  if (!next_line(line))
    return Error{ErrorCode::kParse, name + ":1: empty file, expected the header"};
  try {
    const json header = json::parse(line);
    if (!header.is_object() || header.value("format", std::string()) != kFormatName)
      return Error{ErrorCode::kParse, name + ":1: not a tetcollide recording (no \"format\": \"" +
                                          kFormatName + "\" header)"};
    // (find, not operator[]: on a const json a missing key is undefined behaviour.)
    const auto version = header.find("version");
    if (version == header.end())
      return Error{ErrorCode::kParse, name + ":1: the header has no \"version\""};
    if (!version->is_number_integer() || version->get<std::int64_t>() != kFormatVersion)
      return Error{ErrorCode::kUnsupported, name + ":1: recording version " + version->dump() +
                                                " is not supported (this build reads version 1)"};
  } catch (const json::exception& e) {
    return Error{ErrorCode::kParse, name + ":1: " + e.what()};
  }
  std::vector<Record> records;
  std::size_t number = 1;
  while (next_line(line)) {
    ++number;
    if (line.empty()) continue;
    const std::string where = name + ":" + std::to_string(number);
    // "info" lines describe the session (domain, ...); they carry no sample.
    if (line.find("\"type\":\"info\"") != std::string::npos) continue;
    auto r = decode_record(line, where);
    if (!r) return r.error();
    records.push_back(std::move(*r));
  }
  return records;
}

}  // namespace tc::replay
