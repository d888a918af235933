#include "registry.hpp"

#include <algorithm>

namespace tc::daemon {
namespace {
/// Versions remembered per object to tell a stale state from an unknown one.
constexpr std::size_t kMaxSeenVersions = 64;
}  // namespace

bool SceneRegistry::submit(const std::string& object, const VersionInfo& info) {
  auto [it, inserted] = objects_.try_emplace(object);
  Entry& e = it->second;
  if (!inserted && e.current.version == info.version) return false;
  e.current = info;
  e.in_flight.push_back(info);
  if (std::find(e.seen.begin(), e.seen.end(), info.version) == e.seen.end()) {
    if (e.seen.size() == kMaxSeenVersions) e.seen.erase(e.seen.begin());
    e.seen.push_back(info.version);
  }
  return true;
}

void SceneRegistry::confirm(const std::string& object, std::uint32_t version, bool ok) {
  const auto it = objects_.find(object);
  if (it == objects_.end()) return;
  Entry& e = it->second;
  const auto flight = std::find_if(e.in_flight.begin(), e.in_flight.end(),
                                   [&](const VersionInfo& v) { return v.version == version; });
  if (flight == e.in_flight.end()) return;
  const VersionInfo info = *flight;
  e.in_flight.erase(flight);
  if (ok) {
    e.has_confirmed = true;
    e.confirmed = info;
    return;
  }
  if (e.current.version != version) return;  // a newer version is on its way
  if (!e.in_flight.empty()) {
    e.current = e.in_flight.back();
  } else if (e.has_confirmed) {
    e.current = e.confirmed;
  } else {
    objects_.erase(it);
  }
}

void SceneRegistry::remove(const std::string& object) {
  const auto it = objects_.find(object);
  if (it != objects_.end()) objects_.erase(it);
}

const VersionInfo* SceneRegistry::current(std::string_view object) const {
  const auto it = objects_.find(object);
  return it == objects_.end() ? nullptr : &it->second.current;
}

SceneRegistry::Match SceneRegistry::match(std::string_view object, std::uint32_t version) const {
  const auto it = objects_.find(object);
  if (it == objects_.end()) return Match::kUnknown;
  const Entry& e = it->second;
  if (e.current.version == version) return Match::kCurrent;
  if (std::find(e.seen.begin(), e.seen.end(), version) != e.seen.end()) return Match::kStale;
  return Match::kUnknown;
}

std::vector<std::string> SceneRegistry::expected() const {
  std::vector<std::string> out;
  for (const auto& [name, e] : objects_)
    if (!e.current.is_static) out.push_back(name);
  return out;
}

}  // namespace tc::daemon
