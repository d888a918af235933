// The Debian packages of `make package` (built by the fixture package.debs into
// TC_DEB_DIR). DebPackages: what dpkg-deb shows: names, versions, where each file is,
// Depends against what the ELF files need, conffiles, maintainer scripts, shlibs.
// DebInstall (root only): dpkg -i, the installed daemon from its installed configuration
// (as an unprivileged user, like the unit's DynamicUser) reports READY=1 to a fake
// systemd, a recording replays bit for bit against it, programs build against /usr, and
// dpkg --purge leaves nothing of the packages behind.
#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "notify_socket.hpp"
#include "package_support.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

const std::vector<std::string> kPackages = {"tetcollided", "libtetcollide-client",
                                            "libtetcollide-client-dev", "tetcollide-tools"};

const std::map<std::string, Deb>& debs() {
  static const std::map<std::string, Deb> all = [] {
    std::map<std::string, Deb> out;
    const fs::path dir = program_from_env("TC_DEB_DIR");
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".deb") {
        Deb d = read_deb(e.path());
        out[d.fields["Package"]] = d;
      }
    return out;
  }();
  return all;
}

const Deb& deb(const std::string& name) {
  static const Deb none;
  const auto it = debs().find(name);
  if (it == debs().end()) {
    ADD_FAILURE() << "no package " << name << " in " << program_from_env("TC_DEB_DIR");
    return none;
  }
  return it->second;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(line);
  return out;
}

/// "/usr/lib/x86_64-linux-gnu": the library directory in the packages.
std::string libdir() {
  return "/usr/" + program_from_env("TC_INSTALL_LIBDIR");
}

/// The package's files unpacked into a fresh directory.
fs::path unpack(const Deb& d) {
  const fs::path dir = make_temp_dir("deb-data");
  const auto r = sh("dpkg-deb -x " + quoted(d.file.string()) + " " + quoted(dir.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return dir;
}

bool is_elf(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  char magic[4] = {};
  in.read(magic, 4);
  return in && magic[0] == 0x7f && magic[1] == 'E' && magic[2] == 'L' && magic[3] == 'F';
}

/// NEEDED entries of an ELF file (readelf -d).
std::vector<std::string> needed(const fs::path& file) {
  const auto r = sh("readelf -d " + quoted(file.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> out;
  for (const auto& line : lines_of(r.out)) {
    const auto at = line.find("(NEEDED)");
    const auto open = line.find('[');
    const auto close = line.find(']');
    if (at != std::string::npos && open != std::string::npos && close > open)
      out.push_back(line.substr(open + 1, close - open - 1));
  }
  return out;
}

/// The installed Debian packages that ship a file named `soname` (dpkg -S), and the
/// virtual packages they provide (a shlibs file may name one: libspdlog1.10 provides
/// libspdlog1.10-fmt9).
std::set<std::string> owners(const std::string& soname) {
  const auto r = sh("dpkg -S " + quoted("*/" + soname));
  std::set<std::string> out;
  for (const auto& line : lines_of(r.out)) {
    if (line.rfind("diversion ", 0) == 0) continue;
    const auto colon = line.find(": ");
    if (colon == std::string::npos) continue;
    std::istringstream names(line.substr(0, colon));
    for (std::string name; std::getline(names, name, ',');) {
      name.erase(0, name.find_first_not_of(' '));
      out.insert(name.substr(0, name.find(':')));  // "libc6:amd64" -> "libc6"
    }
  }
  std::set<std::string> provided;
  for (const auto& p : out) {
    const auto q = sh("dpkg-query -W -f='${Provides}' " + quoted(p));
    const auto names = depends_names(q.out);
    provided.insert(names.begin(), names.end());
  }
  out.insert(provided.begin(), provided.end());
  return out;
}

bool allowed(const std::string& path, const std::vector<std::string>& rules) {
  return std::any_of(rules.begin(), rules.end(), [&](const std::string& rule) {
    return path == rule || (rule.back() == '/' && path.rfind(rule, 0) == 0);
  });
}

TEST(DebPackages, NamesVersionsAndControlFields) {
  std::set<std::string> names;
  for (const auto& [name, d] : debs()) names.insert(name);
  EXPECT_EQ(names, std::set<std::string>(kPackages.begin(), kPackages.end()));
  const std::string arch = trimmed(sh("dpkg --print-architecture").out);
  std::set<std::string> synopses;
  for (const auto& name : kPackages) {
    const Deb& d = deb(name);
    auto fields = d.fields;
    EXPECT_EQ(fields["Version"], TC_VERSION) << name;
    EXPECT_EQ(fields["Architecture"], arch) << name;
    EXPECT_EQ(d.file.filename(), name + "_" + TC_VERSION + "_" + arch + ".deb");
    EXPECT_FALSE(fields["Maintainer"].empty()) << name;
    EXPECT_FALSE(fields["Section"].empty()) << name;
    const std::string synopsis = fields["Description"].substr(0, fields["Description"].find('\n'));
    EXPECT_GT(synopsis.size(), 10u) << name;
    synopses.insert(synopsis);
  }
  EXPECT_EQ(synopses.size(), kPackages.size()) << "each package has its own synopsis";
}

TEST(DebPackages, EachFileIsWhereDebianWantsItAndInOnePackage) {
  const std::string lib = libdir();
  const std::string so = lib + "/libtetcollide_client.so";
  struct Rule {
    std::vector<std::string> required;
    std::vector<std::string> allowed;
  };
  const std::map<std::string, Rule> rules = {
      {"tetcollided",
       {{"/usr/bin/tetcollided", "/etc/tetcollide/tetcollided.yaml",
         "/etc/tetcollide/cyclonedds.xml", "/etc/tetcollide/cyclonedds-network.xml",
         "/usr/lib/systemd/system/tetcollided.service", "/usr/share/doc/tetcollided/PROTOCOL.md",
         "/usr/share/doc/tetcollided/DEPLOYMENT.md", "/usr/share/doc/tetcollided/tetcollide.idl"},
        {"/usr/bin/tetcollided", "/etc/tetcollide/", "/usr/lib/systemd/system/tetcollided.service",
         "/usr/share/doc/tetcollided/"}}},
      {"libtetcollide-client",
       {{so + ".0", so + "." + TC_VERSION}, {so + ".0", so + "." + TC_VERSION}}},
      {"libtetcollide-client-dev",
       {{"/usr/include/tetcollide/client.hpp", "/usr/include/tetcollide/mesh.hpp",
         "/usr/include/tetcollide/integration.hpp", so,
         lib + "/cmake/tetcollide/tetcollideConfig.cmake",
         lib + "/cmake/tetcollide/tetcollideConfigVersion.cmake",
         lib + "/cmake/tetcollide/tetcollideTargets.cmake",
         lib + "/pkgconfig/tetcollide-client.pc"},
        {"/usr/include/tetcollide/", so, lib + "/cmake/tetcollide/",
         lib + "/pkgconfig/tetcollide-client.pc"}}},
      {"tetcollide-tools",
       {{"/usr/bin/tetcollide", "/usr/share/tetcollide/scenes/torus_on_box.yaml",
         "/usr/share/tetcollide/data/meshes/torus.msh"},
        {"/usr/bin/tetcollide", "/usr/share/tetcollide/"}}}};
  std::map<std::string, std::string> owner;
  for (const auto& [name, rule] : rules) {
    const Deb& d = deb(name);
    for (const auto& f : rule.required) EXPECT_TRUE(d.paths.count(f)) << name << " lacks " << f;
    for (const auto& p : d.paths) {
      if (d.dirs.count(p)) continue;
      EXPECT_TRUE(allowed(p, rule.allowed)) << name << " should not hold " << p;
      const auto [it, fresh] = owner.emplace(p, name);
      EXPECT_TRUE(fresh) << p << " is in " << it->second << " and " << name;
    }
  }
}

TEST(DebPackages, TheUnitThePcFileAndTheConfigurationNameTheInstalledSystem) {
  const fs::path daemon = unpack(deb("tetcollided"));
  const std::string unit = file_text(daemon / "usr/lib/systemd/system/tetcollided.service");
  for (const char* line :
       {"Type=notify", "NotifyAccess=main", "WatchdogSec=30s", "DynamicUser=yes",
        "ExecStart=/usr/bin/tetcollided --config /etc/tetcollide/tetcollided.yaml",
        "Environment=CYCLONEDDS_URI=file:///etc/tetcollide/cyclonedds.xml",
        "Documentation=file:///usr/share/doc/tetcollided/PROTOCOL.md"})
    EXPECT_NE(unit.find(std::string("\n") + line + "\n"), std::string::npos)
        << "the unit lacks " << line << ":\n"
        << unit;
  EXPECT_EQ(unit.find('@'), std::string::npos) << "unconfigured placeholder:\n" << unit;
  const fs::path source = program_from_env("TC_SOURCE_DIR");
  for (const char* f : {"tetcollided.yaml", "cyclonedds.xml", "cyclonedds-network.xml"})
    EXPECT_EQ(file_text(daemon / "etc/tetcollide" / f), file_text(source / "config" / f)) << f;

  const fs::path dev = unpack(deb("libtetcollide-client-dev"));
  const std::string pc = file_text(dev / libdir().substr(1) / "pkgconfig/tetcollide-client.pc");
  for (const std::string& line : std::vector<std::string>{
           "prefix=/usr", "libdir=${prefix}" + libdir().substr(4), "includedir=${prefix}/include",
           std::string("Version: ") + TC_VERSION, "Libs: -L${libdir} -ltetcollide_client"})
    EXPECT_NE(pc.find(line + "\n"), std::string::npos) << "the .pc lacks " << line << ":\n" << pc;

  // No text file of any package names the build machine's directories.
  const std::string build_dir = program_from_env("TC_BUILD_DIR");
  for (const auto& [name, d] : debs()) {
    const fs::path root = name == "tetcollided"                ? daemon
                          : name == "libtetcollide-client-dev" ? dev
                                                               : unpack(d);
    for (const auto& e : fs::recursive_directory_iterator(root)) {
      if (!e.is_regular_file() || is_elf(e.path())) continue;
      const std::string text = file_text(e.path());
      EXPECT_EQ(text.find("_CPack_Packages"), std::string::npos) << e.path();
      EXPECT_EQ(text.find(build_dir), std::string::npos) << e.path();
    }
    if (root != daemon && root != dev) fs::remove_all(root);
  }
  fs::remove_all(daemon);
  fs::remove_all(dev);
}

TEST(DebPackages, DependsCoverEveryLibraryTheProgramsNeed) {
  const std::string own = std::string("libtetcollide-client (= ") + TC_VERSION + ")";
  for (const auto& name : kPackages) {
    const Deb& d = deb(name);
    auto fields = d.fields;
    const std::string depends = fields["Depends"];
    const auto names = depends_names(depends);
    const fs::path root = unpack(d);
    int elf_files = 0;
    for (const auto& e : fs::recursive_directory_iterator(root)) {
      if (!e.is_regular_file() || e.is_symlink() || !is_elf(e.path())) continue;
      ++elf_files;
      for (const auto& soname : needed(e.path())) {
        if (soname.rfind("libtetcollide_client.so", 0) == 0) {
          EXPECT_NE(depends.find(own), std::string::npos) << name << ": Depends: " << depends;
          continue;
        }
        const auto from = owners(soname);
        EXPECT_FALSE(from.empty()) << soname << " is in no installed package";
        EXPECT_TRUE(std::any_of(from.begin(), from.end(),
                                [&](const std::string& p) { return names.count(p) > 0; }))
            << name << ": " << e.path().filename() << " needs " << soname << " (package "
            << *from.begin() << "), Depends: " << depends;
      }
    }
    fs::remove_all(root);
    if (elf_files > 0) {
      // dpkg-shlibdeps' versioned dependencies, not a hand-written list.
      EXPECT_NE(depends.find("libc6 (>= "), std::string::npos) << name << ": " << depends;
    } else {
      EXPECT_EQ(depends, own) << name;
    }
  }
  auto daemon = deb("tetcollided").fields;
  EXPECT_TRUE(depends_names(daemon["Depends"]).count("libsystemd0")) << daemon["Depends"];
  EXPECT_FALSE(depends_names(daemon["Depends"]).count("libtetcollide-client"));
  auto tools = deb("tetcollide-tools").fields;
  EXPECT_EQ(tools["Suggests"], "tetcollided");
}

TEST(DebPackages, TheConfigurationFilesAreConffiles) {
  const Deb& daemon = deb("tetcollided");
  ASSERT_TRUE(daemon.control.count("conffiles"));
  const auto conffiles = lines_of(daemon.control.at("conffiles"));
  EXPECT_EQ(
      std::set<std::string>(conffiles.begin(), conffiles.end()),
      (std::set<std::string>{"/etc/tetcollide/tetcollided.yaml", "/etc/tetcollide/cyclonedds.xml",
                             "/etc/tetcollide/cyclonedds-network.xml"}));
  for (const auto& f : conffiles) EXPECT_TRUE(daemon.paths.count(f)) << f << " is not shipped";
  for (const auto& [name, d] : debs()) {
    if (name != "tetcollided") {
      EXPECT_FALSE(d.control.count("conffiles")) << name;
    }
    for (const auto& p : d.paths) {
      if (p.rfind("/etc/", 0) == 0 && !d.dirs.count(p)) {
        EXPECT_NE(std::find(conffiles.begin(), conffiles.end(), p), conffiles.end())
            << name << ": " << p << " is under /etc but not a conffile";
      }
    }
  }
}

TEST(DebPackages, MaintainerScriptsAndShlibs) {
  const Deb& daemon = deb("tetcollided");
  const fs::path dir = make_temp_dir("deb-scripts");
  for (const char* script : {"postinst", "prerm", "postrm"}) {
    ASSERT_TRUE(daemon.control.count(script)) << script;
    EXPECT_TRUE(daemon.executable_control.count(script)) << script << " is not executable";
    std::ofstream(dir / script) << daemon.control.at(script);
    const auto r = sh("sh -n " + quoted((dir / script).string()));
    EXPECT_EQ(r.exit_code, 0) << script << ": " << r.err;
  }
  fs::remove_all(dir);
  EXPECT_NE(daemon.control.at("postinst").find("deb-systemd-helper enable tetcollided.service"),
            std::string::npos);
  EXPECT_NE(daemon.control.at("postrm").find("deb-systemd-helper purge tetcollided.service"),
            std::string::npos);

  const Deb& lib = deb("libtetcollide-client");
  ASSERT_TRUE(lib.control.count("shlibs"));
  EXPECT_EQ(trimmed(lib.control.at("shlibs")),
            std::string("libtetcollide_client 0 libtetcollide-client (>= ") + TC_VERSION + ")");
  ASSERT_TRUE(lib.control.count("postinst"));
  EXPECT_NE(lib.control.at("postinst").find("ldconfig"), std::string::npos);
}

/// Purges the packages when it goes out of scope (every path out of the test).
class PurgeAtExit {
 public:
  ~PurgeAtExit() {
    if (!armed) return;
    std::string all;
    for (const auto& p : kPackages) all += " " + p;
    const auto r = sh("dpkg --purge" + all, 300s);
    if (r.exit_code != 0) std::cerr << "dpkg --purge failed:\n" << r.out << r.err;
  }
  bool armed = true;
};

std::string package_status(const std::string& name) {
  return trimmed(sh("dpkg-query -W -f='${db:Status-Abbrev}' " + name + " 2>/dev/null").out);
}

TEST(DebInstall, InstallRunReplayAndPurgeLeaveNothingBehind) {
  if (geteuid() != 0)
    GTEST_SKIP() << "needs root: installs the packages with dpkg -i and purges them "
                    "(run the tests as root, as CI does)";
  for (const auto& p : kPackages) {
    const std::string status = package_status(p);
    if (!status.empty() && status != "un")
      GTEST_SKIP() << p << " is on this machine already (dpkg status '" << status
                   << "'): this test would replace and purge it";
  }
  if (fs::exists("/etc/tetcollide"))
    GTEST_SKIP() << "/etc/tetcollide exists already: this test would purge it";

  std::set<std::string> paths, dirs;
  std::string files;
  for (const auto& p : kPackages) {
    const Deb& d = deb(p);
    paths.insert(d.paths.begin(), d.paths.end());
    dirs.insert(d.dirs.begin(), d.dirs.end());
    files += ' ';
    files += quoted(d.file.string());
  }
  std::set<std::string> dirs_before;
  for (const auto& dir : dirs)
    if (fs::exists(dir)) dirs_before.insert(dir);
  const fs::path dir = make_temp_dir("deb-install");

  PurgeAtExit purge;  // declared before the daemon: the daemon is stopped first
  auto r = sh("dpkg -i" + files, 300s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const auto& p : kPackages) EXPECT_EQ(package_status(p), "ii") << p;
  r = sh("dpkg -V tetcollided libtetcollide-client libtetcollide-client-dev tetcollide-tools");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "") << "installed files differ from the packages'";
  // postinst enabled the unit (deb-systemd-helper works without a running systemd).
  EXPECT_TRUE(fs::is_symlink("/etc/systemd/system/multi-user.target.wants/tetcollided.service"));
  EXPECT_NE(sh("ldconfig -p").out.find("libtetcollide_client.so.0 "), std::string::npos);
  if (fs::exists("/usr/bin/systemd-analyze")) {
    r = sh("systemd-analyze verify /usr/lib/systemd/system/tetcollided.service");
    EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  }
  r = sh("/usr/bin/tetcollided --version");
  EXPECT_EQ(r.out, std::string("tetcollided ") + TC_VERSION + "\n");

  // The installed daemon from its installed configuration, as the unit starts it, as an
  // unprivileged user (the unit's DynamicUser), on a private domain, with systemd's
  // notification socket faked. systemd is not PID 1 here: no systemctl.
  const std::uint32_t domain = private_domain();
  setenv("CYCLONEDDS_URI", "file:///etc/tetcollide/cyclonedds.xml", 1);
  test::FakeNotifySocket notify;
  setenv("NOTIFY_SOCKET", notify.address().c_str(), 1);
  ChildProcess daemon;
  ASSERT_TRUE(daemon.start({"/usr/bin/setpriv", "--reuid=nobody", "--regid=nogroup",
                            "--clear-groups", "--no-new-privs", "/usr/bin/tetcollided", "--config",
                            "/etc/tetcollide/tetcollided.yaml", "--domain", std::to_string(domain)},
                           dir / "daemon.out", dir / "daemon.log"));
  unsetenv("NOTIFY_SOCKET");
  const auto ready = notify.wait_for("READY=1", 20s);
  ASSERT_TRUE(ready) << file_text(dir / "daemon.log");
  EXPECT_NE(file_text(dir / "daemon.log").find("tetcollided ready"), std::string::npos);
  EXPECT_NE(file_text(dir / "daemon.log").find("config /etc/tetcollide/tetcollided.yaml"),
            std::string::npos);

  // A committed recording replays bit for bit through the installed CLI.
  const fs::path recording = fs::path(program_from_env("TC_RECORDINGS")) / "two_boxes.jsonl";
  r = run_program({"/usr/bin/tetcollide", "replay", recording.string(), "--domain",
                   std::to_string(domain), "--rate", "0", "--check", "--json"},
                  120s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err << file_text(dir / "daemon.log");
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["frames"].get<int>(), 40);
  EXPECT_EQ(report["mismatched_frames"].get<int>(), 0);
  EXPECT_EQ(report["max_force_deviation"].get<double>(), 0.0);

  // Programs build against /usr with no path given: the CMake package and the .pc file
  // are where find_package and pkg-config look.
  const std::string cmake = program_from_env("TC_CMAKE");
  const fs::path build = dir / "consumer-build";
  unsetenv("PKG_CONFIG_PATH");
  unsetenv("CMAKE_PREFIX_PATH");
  r = run_program({cmake, "-S", program_from_env("TC_CONSUMER_SOURCE"), "-B", build.string(), "-G",
                   "Ninja", "-DCMAKE_BUILD_TYPE=Release"},
                  120s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(file_text(build / "CMakeCache.txt")
                .find("tetcollide_DIR:PATH=" + libdir() + "/cmake/tetcollide"),
            std::string::npos);
  r = run_program({cmake, "--build", build.string()}, 120s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  r = sh("pkg-config --cflags --libs tetcollide-client");
  EXPECT_EQ(trimmed(r.out), "-ltetcollide_client") << r.err;
  const fs::path main_cpp = fs::path(program_from_env("TC_CONSUMER_SOURCE")) / "main.cpp";
  r = sh("c++ -std=c++20 " + quoted(main_cpp.string()) +
         " $(pkg-config --cflags --libs tetcollide-client) -o " +
         quoted((dir / "consumer-pc").string()));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const fs::path& program : {build / "consumer", dir / "consumer-pc"}) {
    r = run_program({program.string(), std::to_string(domain)}, 60s);
    EXPECT_EQ(r.exit_code, 0) << program << ": " << r.out << r.err;
  }

  // SIGTERM: STOPPING=1, a clean exit.
  EXPECT_EQ(daemon.stop(SIGTERM), 0) << file_text(dir / "daemon.log");
  EXPECT_TRUE(notify.wait_for("STOPPING=1", 5s));

  // Purge, then nothing of the packages is left.
  purge.armed = false;
  r = sh("dpkg --purge tetcollide-tools libtetcollide-client-dev tetcollided libtetcollide-client",
         300s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const auto& p : kPackages) {
    const std::string status = package_status(p);
    EXPECT_TRUE(status.empty() || status == "un") << p << ": dpkg status " << status;
    EXPECT_TRUE(sh("ls /var/lib/dpkg/info/" + p + ".* 2>/dev/null").out.empty()) << p;
  }
  for (const auto& p : paths) {
    if (dirs.count(p)) {
      if (!dirs_before.count(p)) {
        EXPECT_FALSE(fs::exists(p)) << "left behind: " << p;
      }
    } else {
      EXPECT_FALSE(fs::exists(fs::symlink_status(p))) << "left behind: " << p;
    }
  }
  EXPECT_FALSE(fs::exists("/etc/tetcollide"));
  for (const char* p : {"/etc/systemd/system/multi-user.target.wants/tetcollided.service",
                        "/etc/systemd/system/tetcollided.service",
                        "/var/lib/systemd/deb-systemd-helper-enabled/tetcollided.service.dsh-also",
                        "/var/lib/systemd/deb-systemd-helper-enabled/multi-user.target.wants/"
                        "tetcollided.service",
                        "/var/lib/systemd/deb-systemd-helper-masked/tetcollided.service"})
    EXPECT_FALSE(fs::exists(fs::symlink_status(p))) << "left behind: " << p;
  EXPECT_EQ(sh("ldconfig -p").out.find("libtetcollide_client"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace tc::itest
