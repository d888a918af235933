// forces_reference: runs lock-step frames through libtetcollide_client (C++) from files
// the Python tests write, and writes the service's answers as raw bytes, so that
// test_forces_equal_the_cpp_client can compare the Python module's answers to the C++
// client's bit for bit (same daemon, another scene: the service's forces depend on the
// states only, docs/PROTOCOL.md "Frames").
//
//   forces_reference --domain D --scene S --dir DIR
//
// DIR/objects.txt: one line per object, "name n m static" (static 0 or 1); DIR/<name>.nodes.f64
// (n x 3 float64 rest positions, metres), DIR/<name>.tets.i32 (m x 4 int32);
// DIR/frames.txt: the number of frames F; DIR/state_<f>_<name>.f64 (n x 3 float64) for
// every frame f < F and every object. Writes DIR/cpp_<f>_<name>.{nodes.i32,forces.f64,
// stiffness.f64} (k, k x 3, k x 3 x 3 values, native byte order) and DIR/cpp_summary.txt,
// one line per answer: "f name answered_frame status topology_version k"; prints the
// median and largest round trip (publish + wait_forces) of the frames. Exit 0 when
// every frame was answered, 1 otherwise (the reason on stderr), 2 on bad usage.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "tetcollide/client.hpp"

namespace {

template <typename T>
std::vector<T> read_raw(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::stringstream s;
  s << in.rdbuf();
  const std::string bytes = s.str();
  if (bytes.size() % sizeof(T) != 0) throw std::runtime_error(path + ": size not a multiple");
  std::vector<T> out(bytes.size() / sizeof(T));
  std::memcpy(out.data(), bytes.data(), bytes.size());
  return out;
}

template <typename T>
void write_raw(const std::string& path, const std::vector<T>& values) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(values.data()),
            static_cast<std::streamsize>(values.size() * sizeof(T)));
  if (!out) throw std::runtime_error("cannot write " + path);
}

struct Object {
  std::string name;
  bool is_static = false;
};

int run(std::uint32_t domain, const std::string& scene, const std::string& dir) {
  using namespace std::chrono_literals;
  std::vector<Object> objects;
  auto client = tc::client::Client::connect(domain, scene);
  if (!client->wait_for_service(20s)) {
    std::cerr << "forces_reference: no service on domain " << domain << "\n";
    return 1;
  }
  std::ifstream list(dir + "/objects.txt");
  std::string name;
  std::size_t n = 0;
  std::size_t m = 0;
  int is_static = 0;
  while (list >> name >> n >> m >> is_static) {
    tc::client::Mesh mesh;
    mesh.rest_positions = read_raw<double>(dir + "/" + name + ".nodes.f64");
    mesh.tets = read_raw<std::int32_t>(dir + "/" + name + ".tets.i32");
    if (mesh.rest_positions.size() != 3 * n || mesh.tets.size() != 4 * m)
      throw std::runtime_error(name + ": sizes do not match objects.txt");
    tc::client::ObjectParams params;
    params.is_static = is_static != 0;
    client->register_object(name, mesh, params);
    objects.push_back({name, is_static != 0});
  }
  for (const auto& o : objects) {
    const auto r = client->wait_registered(o.name, 20s);
    if (!r.ok) {
      std::cerr << "forces_reference: " << o.name << " not registered: " << r.message << "\n";
      return 1;
    }
  }
  std::ifstream frames_file(dir + "/frames.txt");
  std::int64_t frames = 0;
  frames_file >> frames;
  // Every state is read before the first frame: the round trips printed at the end are
  // publish + wait only (docs/PYTHON.md compares them with the module's).
  std::vector<std::vector<std::vector<double>>> positions(static_cast<std::size_t>(frames));
  for (std::int64_t f = 0; f < frames; ++f)
    for (const auto& o : objects)
      positions[static_cast<std::size_t>(f)].push_back(
          read_raw<double>(dir + "/state_" + std::to_string(f) + "_" + o.name + ".f64"));
  std::ofstream summary(dir + "/cpp_summary.txt");
  std::vector<double> round_trips_ms;
  for (std::int64_t f = 0; f < frames; ++f) {
    std::vector<tc::client::ObjectState> states;
    for (std::size_t i = 0; i < objects.size(); ++i)
      states.push_back({objects[i].name, positions[static_cast<std::size_t>(f)][i]});
    const auto start = std::chrono::steady_clock::now();
    client->publish_states(f, states);
    const auto answer = client->wait_forces(f, 30s);
    round_trips_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
    if (!answer) {
      std::cerr << "forces_reference: no answer to frame " << f << "\n";
      return 1;
    }
    for (const auto& a : answer->objects) {
      const std::string stem = dir + "/cpp_" + std::to_string(f) + "_" + a.object;
      write_raw(stem + ".nodes.i32", a.nodes);
      write_raw(stem + ".forces.f64", a.forces);
      write_raw(stem + ".stiffness.f64", a.stiffness);
      summary << f << ' ' << a.object << ' ' << answer->frame << ' ' << a.status << ' '
              << a.topology_version << ' ' << a.nodes.size() << '\n';
    }
  }
  if (!round_trips_ms.empty()) {
    std::sort(round_trips_ms.begin(), round_trips_ms.end());
    std::printf("round trip p50 %.3f ms, max %.3f ms over %zu frames\n",
                round_trips_ms[round_trips_ms.size() / 2], round_trips_ms.back(),
                round_trips_ms.size());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::uint32_t domain = 0;
  std::string scene;
  std::string dir;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "--domain")
      domain = static_cast<std::uint32_t>(std::stoul(argv[i + 1]));
    else if (key == "--scene")
      scene = argv[i + 1];
    else if (key == "--dir")
      dir = argv[i + 1];
    else
      scene.clear();
  }
  if (scene.empty() || dir.empty() || argc != 7) {
    std::cerr << "usage: forces_reference --domain D --scene S --dir DIR\n";
    return 2;
  }
  try {
    return run(domain, scene, dir);
  } catch (const std::exception& e) {
    std::cerr << "forces_reference: " << e.what() << "\n";
    return 1;
  }
}
