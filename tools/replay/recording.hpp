// Recordings of a service session: the versioned JSON-lines file format of
// `tetcollide record` / `tetcollide replay` (docs/RECORDING.md), read and written here.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "core/common/result.hpp"
#include "tetcollide/client.hpp"

namespace tc::replay {

inline constexpr const char* kFormatName = "tetcollide-recording";
inline constexpr int kFormatVersion = 1;

/// Every record carries `t`: seconds since the recording started, as received.
struct TopologyRecord {
  double t = 0.0;
  std::string scene;
  std::string object;
  std::uint32_t version = 0;
  client::Mesh mesh;
  client::ObjectParams params;
};

/// A topology instance disposed or left without writers (the object left the scene).
struct RemoveRecord {
  double t = 0.0;
  std::string scene;
  std::string object;
};

struct StateRecord {
  double t = 0.0;
  std::string scene;
  std::string object;
  std::int64_t frame = 0;
  std::uint32_t topology_version = 0;
  std::vector<double> positions;
  std::vector<double> velocities;
};

struct ForcesRecord {
  double t = 0.0;
  std::string scene;
  std::string object;
  std::int64_t frame = 0;
  std::uint32_t topology_version = 0;
  std::int32_t status = 0;
  std::vector<std::int32_t> nodes;
  std::vector<double> forces;
  std::vector<double> stiffness;
  std::vector<double> damping;  ///< df/dv blocks (protocol 3); absent in older recordings
};

struct StatusRecord {
  double t = 0.0;
  client::StatusEvent event;
};

using Record = std::variant<TopologyRecord, RemoveRecord, StateRecord, ForcesRecord, StatusRecord>;

/// Time stamp of any record.
double record_time(const Record& record);

/// Appends records to a recording file; the header line is written on open.
class RecordingWriter {
 public:
  /// Creates (truncates) the file and writes the header. kIo on failure.
  Status open(const std::filesystem::path& path, std::uint32_t domain);
  /// Writes one record as one line; kIo when the stream fails.
  Status write(const Record& record);
  /// Pushes buffered records to the file (the recorder does after every batch).
  Status flush();
  Status close();
  [[nodiscard]] std::size_t records() const { return records_; }

 private:
  std::ofstream out_;
  std::filesystem::path path_;
  std::size_t records_ = 0;
};

/// Reads a whole recording. kParse names the line at fault; kUnsupported for another
/// format or version.
Expected<std::vector<Record>> read_recording(const std::filesystem::path& path);
/// Same, from the file's content in memory; `name` prefixes the error messages
/// ("name:line: ...").
Expected<std::vector<Record>> read_recording_buffer(std::string_view text, const std::string& name);

/// Encodes / decodes one record line (exposed for tests).
std::string encode_record(const Record& record);
Expected<Record> decode_record(const std::string& line, const std::string& where);

}  // namespace tc::replay
