// Headless pictures (tools/viz): one 1024x768 frame of the torus over the box (the
// demo's scene), with and without wireframe, and the PNG encoding of that frame.
#include <benchmark/benchmark.h>

#include "core/io/mesh_io.hpp"
#include "core/mesh/topology.hpp"
#include "render.hpp"
#include "test_meshes.hpp"

namespace {

struct Scene {
  std::vector<Eigen::Matrix3Xd> positions;
  std::vector<tc::viz::Surface> surfaces;
  tc::viz::Camera camera;
};

Scene& torus_over_box() {
  static Scene scene = [] {
    Scene s;
    const auto torus = tc::read_mesh(tc::test::mesh_path("torus.msh"));
    const auto box = tc::read_mesh(tc::test::mesh_path("box.msh"));
    if (!torus || !box) std::abort();
    s.positions = {torus->positions.colwise() + Eigen::Vector3d(0, 0, 0.3), box->positions};
    const tc::TetMesh* meshes[2] = {&*torus, &*box};
    s.surfaces.resize(2);
    for (int i = 0; i < 2; ++i) {
      s.surfaces[i].positions = &s.positions[i];
      s.surfaces[i].triangles =
          tc::build_topology(meshes[i]->tets, meshes[i]->num_nodes()).boundary_faces;
    }
    s.surfaces[0].base_color = {0.93f, 0.55f, 0.30f};
    s.surfaces[1].base_color = {0.55f, 0.68f, 0.85f};
    s.camera = tc::viz::fit_camera(s.surfaces, {-0.6, 1.0, -0.55}, 1024, 768);
    return s;
  }();
  return scene;
}

void BM_RenderTorusOverBox(benchmark::State& state) {
  Scene& s = torus_over_box();
  for (auto& surface : s.surfaces) surface.wireframe = state.range(0) != 0;
  for (auto _ : state) benchmark::DoNotOptimize(tc::viz::render(s.surfaces, s.camera).rgb.data());
}
BENCHMARK(BM_RenderTorusOverBox)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// Baseline in the same run: the same frame with nothing to draw (background fill and
// the 2x2 downsampling only).
void BM_RenderEmpty(benchmark::State& state) {
  const Scene& s = torus_over_box();
  for (auto _ : state) benchmark::DoNotOptimize(tc::viz::render({}, s.camera).rgb.data());
}
BENCHMARK(BM_RenderEmpty)->Unit(benchmark::kMillisecond);

void BM_EncodePng(benchmark::State& state) {
  Scene& s = torus_over_box();
  const tc::viz::Image img = tc::viz::render(s.surfaces, s.camera);
  for (auto _ : state) benchmark::DoNotOptimize(tc::viz::encode_png(img).size());
}
BENCHMARK(BM_EncodePng)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
