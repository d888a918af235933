// A simulator outside this project, built against `cmake --install build --prefix P`:
// with find_package(tetcollide) (the CMake package, its version file) and with
// pkg-config tetcollide-client, then run against the daemon installed in P, started
// from its installed configuration on a private DDS domain. And the same program built
// against the build tree itself (-Dtetcollide_DIR=<build>: the exported build-tree
// package), run against the build tree's daemon. Each run also reads a mesh file with
// tc::client::read_mesh (tetcollide/mesh.hpp).
#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <regex>

#include "package_support.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

/// Builds the configured consumer project in `build` (verbose: the output shows the
/// command lines); the tetcollide::client target must bring C++20.
RunResult build_consumer(const std::string& cmake, const fs::path& build) {
  RunResult r = run_program({cmake, "--build", build.string(), "--verbose"}, 120s);
  EXPECT_NE(r.out.find("-std=gnu++20"), std::string::npos)
      << "tetcollide::client did not bring C++20:\n"
      << r.out;
  return r;
}

/// Runs the consumer `program` against a daemon on `domain`, with a mesh to read
/// (data/meshes/box.msh, 3,276 tets), and checks that it loaded
/// libtetcollide_client.so.0 from `libdir`.
void run_consumer_with(const fs::path& program, std::uint32_t domain, const fs::path& libdir) {
  const fs::path mesh = fs::path(program_from_env("TC_SOURCE_DIR")) / "data" / "meshes" / "box.msh";
  const auto r = run_program({program.string(), std::to_string(domain), mesh.string()}, 60s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("consumer: " + mesh.string() + ": "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("consumer: frame 0, a: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("consumer: frame 0, b: "), std::string::npos) << r.out;
  // It runs with the library of `libdir` (the installed one, or the build tree's).
  const auto ldd = run_program({"/usr/bin/ldd", program.string()}, 30s);
  EXPECT_NE(ldd.out.find((libdir / "libtetcollide_client.so.0").string()), std::string::npos)
      << ldd.out;
}

class InstalledTree : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = make_temp_dir("package-consumer");
    prefix_ = dir_ / "prefix";
    libdir_ = prefix_ / program_from_env("TC_INSTALL_LIBDIR");
    const auto r = run_program({program_from_env("TC_CMAKE"), "--install",
                                program_from_env("TC_BUILD_DIR"), "--prefix", prefix_.string()},
                               120s);
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  }
  void TearDown() override {
    if (HasFailure()) std::cerr << "---- daemon log ----\n" << file_text(dir_ / "daemon.log");
    daemon_.stop(SIGKILL);
    fs::remove_all(dir_);
  }
  /// The installed daemon with the installed configuration, as the installed unit runs it
  /// (with a private domain).
  void start_installed_daemon() {
    const fs::path conf = prefix_ / "etc" / "tetcollide";
    setenv("CYCLONEDDS_URI", ("file://" + (conf / "cyclonedds.xml").string()).c_str(), 1);
    ASSERT_TRUE(
        start_daemon(daemon_,
                     {(prefix_ / "bin" / "tetcollided").string(), "--config",
                      (conf / "tetcollided.yaml").string(), "--domain", std::to_string(domain_)},
                     dir_, 20s))
        << file_text(dir_ / "daemon.log");
  }
  void run_consumer(const fs::path& program) { run_consumer_with(program, domain_, libdir_); }

  std::uint32_t domain_ = private_domain();
  fs::path dir_, prefix_, libdir_;
  ChildProcess daemon_;
};

TEST_F(InstalledTree, ConsumerBuiltWith_cmake) {
  const fs::path package = libdir_ / "cmake" / "tetcollide";
  for (const char* f :
       {"tetcollideConfig.cmake", "tetcollideConfigVersion.cmake", "tetcollideTargets.cmake"})
    EXPECT_TRUE(fs::exists(package / f)) << package / f;
  const std::string cmake = program_from_env("TC_CMAKE");

  // The version file: SameMajorVersion. Requests of this major version up to this one
  // are compatible; a newer minor or another major is not.
  int major = 0, minor = 0;
  ASSERT_EQ(std::sscanf(TC_VERSION, "%d.%d", &major, &minor), 2);
  const std::vector<std::pair<std::string, bool>> requests = {
      {std::to_string(major), true},
      {std::to_string(major) + "." + std::to_string(minor), true},
      {TC_VERSION, true},
      {std::to_string(major) + "." + std::to_string(minor + 1), false},
      {std::to_string(major + 1), false},
      {std::to_string(major + 1) + ".0", false}};
  const fs::path versions = dir_ / "versions";
  fs::create_directories(versions);
  std::ofstream lists(versions / "CMakeLists.txt");
  // A language: find_package searches lib/<triplet> only once CMake knows the triplet.
  lists << "cmake_minimum_required(VERSION 3.16)\nproject(versions LANGUAGES CXX)\n";
  for (const auto& [v, ok] : requests)
    lists << "find_package(tetcollide " << v << " CONFIG QUIET)\n"
          << "message(STATUS \"request " << v << ": ${tetcollide_FOUND}\")\n"
          << "unset(tetcollide_DIR CACHE)\n";
  lists.close();
  auto r = run_program({cmake, "-S", versions.string(), "-B", (versions / "build").string(),
                        "-DCMAKE_PREFIX_PATH=" + prefix_.string()},
                       60s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const auto& [v, ok] : requests)
    EXPECT_NE(r.out.find("request " + v + ": " + (ok ? "1" : "0")), std::string::npos)
        << "find_package(tetcollide " << v << ") should " << (ok ? "" : "not ") << "succeed\n"
        << r.out;

  // The consumer project: find_package + target_link_libraries, no C++ standard of its own.
  const fs::path build = dir_ / "consumer-build";
  r = run_program(
      {cmake, "-S", program_from_env("TC_CONSUMER_SOURCE"), "-B", build.string(), "-G", "Ninja",
       "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_PREFIX_PATH=" + prefix_.string()},
      120s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(file_text(build / "CMakeCache.txt").find("tetcollide_DIR:PATH=" + package.string()),
            std::string::npos);
  r = build_consumer(cmake, build);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("-isystem " + (prefix_ / "include").string()), std::string::npos) << r.out;

  start_installed_daemon();
  run_consumer(build / "consumer");
  EXPECT_EQ(daemon_.stop(SIGTERM), 0);
}

TEST_F(InstalledTree, ConsumerBuiltWith_pkgconfig) {
  setenv("PKG_CONFIG_PATH", (libdir_ / "pkgconfig").c_str(), 1);
  auto r = sh("pkg-config --modversion tetcollide-client");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, std::string(TC_VERSION) + "\n");
  r = sh("pkg-config --cflags --libs tetcollide-client");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "-I" + (prefix_ / "include").string() + " -L" + libdir_.string() +
                       " -ltetcollide_client \n");
  EXPECT_EQ(
      sh("pkg-config --exists 'tetcollide-client >= " + std::string(TC_VERSION) + "'").exit_code,
      0);

  const fs::path main_cpp = fs::path(program_from_env("TC_CONSUMER_SOURCE")) / "main.cpp";
  const fs::path program = dir_ / "consumer";
  r = sh("c++ -std=c++20 " + quoted(main_cpp.string()) +
         " $(pkg-config --cflags --libs tetcollide-client)"
         " -Wl,-rpath,$(pkg-config --variable=libdir tetcollide-client) -o " +
         quoted(program.string()));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;

  start_installed_daemon();
  run_consumer(program);
  EXPECT_EQ(daemon_.stop(SIGTERM), 0);
}

// The build tree as a CMake package: `cmake -Dtetcollide_DIR=<build>` finds the exported
// build-tree package (client/lib/CMakeLists.txt), whose tetcollide::client is this tree's
// library with the source tree's include directory; no install.
TEST(BuildTree, ConsumerBuiltWith_cmake) {
  const fs::path build_tree = program_from_env("TC_BUILD_DIR");
  const fs::path source = program_from_env("TC_SOURCE_DIR");
  for (const char* f :
       {"tetcollideConfig.cmake", "tetcollideConfigVersion.cmake", "tetcollideTargets.cmake"})
    EXPECT_TRUE(fs::exists(build_tree / f)) << build_tree / f;
  const fs::path dir = make_temp_dir("package-build-tree");
  const std::string cmake = program_from_env("TC_CMAKE");
  const fs::path build = dir / "consumer-build";
  auto r = run_program(
      {cmake, "-S", program_from_env("TC_CONSUMER_SOURCE"), "-B", build.string(), "-G", "Ninja",
       "-DCMAKE_BUILD_TYPE=Release", "-Dtetcollide_DIR=" + build_tree.string()},
      120s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  // A -D without a type stays UNINITIALIZED; the link line below shows the package found
  // is the build tree's.
  EXPECT_NE(file_text(build / "CMakeCache.txt")
                .find("tetcollide_DIR:UNINITIALIZED=" + build_tree.string() + "\n"),
            std::string::npos);
  r = build_consumer(cmake, build);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("-isystem " + (source / "client" / "lib" / "include").string()),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find((build_tree / "lib" / "libtetcollide_client.so").string()),
            std::string::npos)
      << r.out;

  // The build tree's daemon with the source tree's configuration, on a private domain.
  const std::uint32_t domain = private_domain();
  setenv("CYCLONEDDS_URI", ("file://" + (source / "config" / "cyclonedds.xml").string()).c_str(),
         1);
  ChildProcess daemon;
  ASSERT_TRUE(start_daemon(
      daemon,
      {(build_tree / "bin" / "tetcollided").string(), "--config",
       (source / "config" / "tetcollided.yaml").string(), "--domain", std::to_string(domain)},
      dir, 20s))
      << file_text(dir / "daemon.log");
  run_consumer_with(build / "consumer", domain, build_tree / "lib");
  EXPECT_EQ(daemon.stop(SIGTERM), 0);
  if (HasFailure()) std::cerr << "---- daemon log ----\n" << file_text(dir / "daemon.log");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace tc::itest
