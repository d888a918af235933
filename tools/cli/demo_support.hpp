// Plumbing of `tetcollide demo` (cmd_demo.cpp): finding scenes and programs, a private
// tetcollided child process, and the output files (the frames' VTK grids and series, the
// pictures).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "core/common/result.hpp"
#include "core/io/mesh_io.hpp"
#include "scene_run.hpp"

namespace tc::cli::demo {

/// Directory of the running executable (build/bin or <prefix>/bin).
std::filesystem::path exe_dir();

/// Folders where scene files and meshes are looked for: the current directory, the
/// source tree the program was built from, the tree above build/bin, and the installed
/// share/tetcollide folder.
std::vector<std::filesystem::path> data_roots();

/// The scene file for `scene` (a path, or a name looked up as config/scenes/NAME.yaml
/// and share/tetcollide/scenes/NAME.yaml under the data roots); empty when not found.
std::filesystem::path find_scene_file(const std::string& scene);

/// The loopback Cyclone DDS config (config/cyclonedds.xml or the installed one), or "".
std::filesystem::path find_cyclonedds_config();

/// A program started as a child (tetcollided, the recorder): sent SIGTERM when this
/// process dies, stopped by stop() or the destructor.
class ChildProcess {
 public:
  ChildProcess() = default;
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  /// Starts `argv` (argv[0] a path) with stdout and stderr appended to `log`.
  Status start(const std::vector<std::string>& argv, const std::filesystem::path& log);
  /// True while the child runs (reaps it when it exited).
  bool alive();
  /// Sends `sig`, then waits up to `timeout` (SIGKILL after). Returns the exit code, or -1.
  int stop(int sig = 15, std::chrono::milliseconds timeout = std::chrono::seconds(10));
  [[nodiscard]] pid_t pid() const { return child_.pid(); }

 private:
  process::Child child_;
};

/// A ParaView collection (.pvd) of time steps.
struct PvdEntry {
  double time = 0.0;
  std::string file;  ///< relative to the .pvd
};
Status write_pvd(const std::filesystem::path& path, const std::vector<PvdEntry>& entries);

/// Nearest-rank percentile (q in [0, 1]); 0 for an empty list.
double percentile(std::vector<double> values, double q);

/// What the pictures draw of an object: a tet object's boundary faces, a shell's
/// triangles.
std::vector<std::array<std::int32_t, 3>> boundary_of(const sim::SimObject& o);

/// Writes frame `f` of every object into one unstructured grid `out/frame_NNNN.vtu`: point
/// fields depth (m; 0 when not probed), force (N), velocity (m/s), cell field object. The
/// tets of every tet object come first, then the triangles of the shells.
Status write_frame_vtu(const std::vector<sim::SimObject>& objects,
                       const std::vector<std::vector<double>>& depth,
                       const std::filesystem::path& out, int f);

/// Draws the scene's objects (their `surface` triangles) at their current positions into
/// the PNG `path`, titled with the frame, its time and the deepest penetration.
Status render_frame(const std::vector<sim::SimObject>& objects,
                    const std::vector<std::vector<std::array<std::int32_t, 3>>>& surface,
                    const sim::SceneSpec& scene, int frame, double max_depth_mm,
                    const std::filesystem::path& path);

}  // namespace tc::cli::demo
