// Parts shared by the service benchmarks (service_latency, service_load): percentiles,
// mesh conversion to the client library's flat arrays, a daemon started by the benchmark
// with its /proc figures (RSS, CPU time, open file descriptors, threads), and reading its
// Prometheus endpoint (metrics.listen) over HTTP.
#pragma once

#include <arpa/inet.h>
#include <dirent.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "tetcollide/client.hpp"

namespace tc::bench {

/// Nearest-rank percentile q in [0, 1]; 0 for an empty list.
inline double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, k == 0 ? 0 : k - 1)];
}

/// `m` moved by `offset`, as the client library's flat arrays.
inline client::Mesh to_client(const TetMesh& m, const Eigen::Vector3d& offset) {
  client::Mesh out;
  out.node_ids = m.node_ids;
  out.rest_positions.resize(static_cast<std::size_t>(3 * m.num_nodes()));
  for (Index i = 0; i < m.num_nodes(); ++i)
    for (int c = 0; c < 3; ++c)
      out.rest_positions[static_cast<std::size_t>(3 * i + c)] = m.positions(c, i) + offset[c];
  for (const auto& t : m.tets) out.tets.insert(out.tets.end(), t.begin(), t.end());
  return out;
}

/// Figures of a running process read from /proc/<pid>.
struct ProcFigures {
  double rss_mb = 0.0;
  double cpu_s = 0.0;  ///< user + system time so far
  int fds = 0;         ///< entries of /proc/<pid>/fd
  int threads = 0;     ///< entries of /proc/<pid>/task
};

inline int count_entries(const std::string& dir) {
  DIR* d = opendir(dir.c_str());
  if (d == nullptr) return -1;
  int n = 0;
  while (const dirent* e = readdir(d))
    if (e->d_name[0] != '.') ++n;
  closedir(d);
  return n;
}

inline ProcFigures proc_figures(pid_t pid) {
  ProcFigures f;
  const std::string base = "/proc/" + std::to_string(pid);
  {
    std::ifstream in(base + "/status");
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("VmRSS:", 0) == 0) f.rss_mb = std::stod(line.substr(6)) / 1024.0;
  }
  {
    // /proc/<pid>/stat: fields 14 and 15 (utime, stime) in clock ticks, after "(comm)".
    std::ifstream in(base + "/stat");
    std::string all;
    std::getline(in, all);
    const auto close = all.rfind(')');
    if (close != std::string::npos) {
      std::istringstream rest(all.substr(close + 2));
      std::string field;
      double utime = 0.0;
      double stime = 0.0;
      for (int i = 3; i <= 15 && rest >> field; ++i) {
        if (i == 14) utime = std::stod(field);
        if (i == 15) stime = std::stod(field);
      }
      f.cpu_s = (utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
    }
  }
  f.fds = count_entries(base + "/fd");
  f.threads = count_entries(base + "/task");
  return f;
}

/// A free TCP port on 127.0.0.1 (bound once and released: free unless taken between this
/// call and the daemon's start, which in the tool's private network namespace nothing does).
inline int free_loopback_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  int port = 0;
  if (bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0)
    port = ntohs(addr.sin_port);
  close(fd);
  return port;
}

/// A daemon started by the benchmark (stdout to /dev/null), SIGTERMed at the end.
struct Daemon {
  tc::process::Child child;
  pid_t pid = -1;
  ~Daemon() {
    child.signal(SIGTERM);
    child.wait();
  }
  bool start(const std::string& path, std::uint32_t domain, const std::string& config) {
    const Status st =
        child.start({.argv = {path, "--config", config, "--domain", std::to_string(domain)},
                     .out = "/dev/null"});
    pid = child.pid();
    return st.ok();
  }
  [[nodiscard]] double rss_mb() const { return proc_figures(pid).rss_mb; }
  /// CPU time (user + system, every thread) the daemon has used so far, seconds.
  [[nodiscard]] double cpu_s() const { return proc_figures(pid).cpu_s; }
  [[nodiscard]] ProcFigures figures() const { return proc_figures(pid); }
};

}  // namespace tc::bench
