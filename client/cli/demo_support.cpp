#include "demo_support.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#ifndef TC_SOURCE_DIR
#define TC_SOURCE_DIR ""
#endif

namespace tc::cli::demo {

std::filesystem::path exe_dir() {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::current_path() : self.parent_path();
}

std::vector<std::filesystem::path> data_roots() {
  std::vector<std::filesystem::path> roots{std::filesystem::current_path()};
  if (std::string(TC_SOURCE_DIR).size() > 0) roots.emplace_back(TC_SOURCE_DIR);
  const auto bin = exe_dir();
  roots.push_back(bin / ".." / "..");                    // <repo>/build/bin
  roots.push_back(bin / ".." / "share" / "tetcollide");  // <prefix>/bin
  return roots;
}

std::filesystem::path find_scene_file(const std::string& scene) {
  const std::filesystem::path p(scene);
  if (p.has_extension() || scene.find('/') != std::string::npos)
    return std::filesystem::exists(p) ? p : std::filesystem::path();
  for (const auto& root : data_roots())
    for (const auto& sub : {root / "config" / "scenes", root / "scenes"}) {
      const auto f = sub / (scene + ".yaml");
      if (std::filesystem::exists(f)) return f;
    }
  return {};
}

std::filesystem::path find_cyclonedds_config() {
  for (const auto& root : data_roots())
    for (const auto& f : {root / "config" / "cyclonedds.xml",
                          root / ".." / ".." / "etc" / "tetcollide" / "cyclonedds.xml"})
      if (std::filesystem::exists(f)) return std::filesystem::weakly_canonical(f);
  if (std::filesystem::exists("/etc/tetcollide/cyclonedds.xml"))
    return "/etc/tetcollide/cyclonedds.xml";
  return {};
}

ChildProcess::~ChildProcess() {
  stop();
}

Status ChildProcess::start(const std::vector<std::string>& argv, const std::filesystem::path& log) {
  if (argv.empty() || !std::filesystem::exists(argv[0]))
    return Error{ErrorCode::kIo, "program not found: " + (argv.empty() ? std::string() : argv[0])};
  // The demo's own signal dispositions must not leak into the daemon, and Ctrl-C in the
  // terminal reaches the demo only; the demo stops the daemon.
  return child_.start({.argv = argv,
                       .out = log,
                       .err = log,
                       .parent_death_signal = SIGTERM,
                       .reset_signals = true,
                       .own_process_group = true});
}

bool ChildProcess::alive() {
  return !child_.exited();
}

int ChildProcess::stop(int sig, std::chrono::milliseconds timeout) {
  const std::optional<int> status = child_.stop(sig, timeout);
  return status ? process::exit_code(*status) : -1;
}

Status write_pvd(const std::filesystem::path& path, const std::vector<PvdEntry>& entries) {
  std::ofstream out(path);
  out << "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "  <Collection>\n";
  char line[512];
  for (const auto& e : entries) {
    std::snprintf(line, sizeof line,
                  "    <DataSet timestep=\"%.6f\" group=\"\" part=\"0\" file=\"%s\"/>\n", e.time,
                  e.file.c_str());
    out << line;
  }
  out << "  </Collection>\n</VTKFile>\n";
  out.close();
  if (!out) return Error{ErrorCode::kIo, "cannot write " + path.string()};
  return {};
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank == 0 ? 0 : rank - 1)];
}

}  // namespace tc::cli::demo
