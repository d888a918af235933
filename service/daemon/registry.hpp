// The objects of one scene as the daemon's reader thread knows them: which topology
// version each object has, how many nodes it has (to validate states before anything is
// built) and whether the pipeline has confirmed it. DDS-free and single-threaded.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh/tet_mesh.hpp"

namespace tc::daemon {

struct VersionInfo {
  std::uint32_t version = 0;
  Index nodes = 0;
  bool is_static = false;
  /// Hash of the sample's content (ids, rest positions, tets, parameters): tells a re-sent
  /// version from a different topology under the same version number.
  std::uint64_t content_hash = 0;
};

class SceneRegistry {
 public:
  /// How a state's (object, topology version) relates to what is registered.
  enum class Match {
    kCurrent,  ///< the newest submitted version: the state can be used
    kStale,    ///< a version this registry has seen, but not the newest
    kUnknown,  ///< no such object, or a version not seen yet (its topology may follow)
  };

  /// Records a validated topology handed to the pipeline. Returns false (and changes
  /// nothing) when this exact version is already the newest: a re-delivered sample.
  bool submit(const std::string& object, const VersionInfo& info);

  /// The pipeline's verdict on a submitted version. On failure the object falls back to
  /// its last confirmed version (the pipeline keeps that one), or is forgotten.
  void confirm(const std::string& object, std::uint32_t version, bool ok);

  /// Forgets an object (its topology was disposed or lost its writers).
  void remove(const std::string& object);

  /// The newest submitted version of an object, or null.
  [[nodiscard]] const VersionInfo* current(std::string_view object) const;

  [[nodiscard]] Match match(std::string_view object, std::uint32_t version) const;

  /// Non-static objects, sorted by name: the ones a frame waits for.
  [[nodiscard]] std::vector<std::string> expected() const;

  [[nodiscard]] std::size_t size() const { return objects_.size(); }
  [[nodiscard]] bool empty() const { return objects_.empty(); }

 private:
  struct Entry {
    VersionInfo current;
    bool has_confirmed = false;
    VersionInfo confirmed;
    std::vector<VersionInfo> in_flight;  ///< submitted, verdict not in yet
    std::vector<std::uint32_t> seen;     ///< every version ever current (for kStale)
  };
  std::map<std::string, Entry, std::less<>> objects_;
};

}  // namespace tc::daemon
