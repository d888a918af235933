#include "demo_support.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

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

std::string line_chart_svg(const std::string& title, const std::string& x_label,
                           const std::string& y_label, const std::vector<double>& x,
                           const std::vector<Series>& series) {
  constexpr double kW = 960, kH = 540, kL = 70, kR = 190, kT = 40, kB = 60;
  double xmax = 1.0;
  double xmin = 0.0;
  if (!x.empty()) {
    xmin = *std::min_element(x.begin(), x.end());
    xmax = std::max(xmin + 1.0, *std::max_element(x.begin(), x.end()));
  }
  double ymax = 0.0;
  for (const auto& s : series)
    for (const double v : s.y)
      if (std::isfinite(v)) ymax = std::max(ymax, v);
  // A "nice" top: 1, 2 or 5 times a power of ten.
  double step = std::pow(10.0, std::floor(std::log10(std::max(ymax, 1e-9) / 5.0)));
  for (const double m : {1.0, 2.0, 5.0, 10.0})
    if (ymax / (m * step) <= 6.0) {
      step *= m;
      break;
    }
  const double ytop = std::max(step, std::ceil(ymax / step) * step);
  const auto px = [&](double v) { return kL + (v - xmin) / (xmax - xmin) * (kW - kL - kR); };
  const auto py = [&](double v) { return kH - kB - v / ytop * (kH - kT - kB); };
  std::ostringstream s;
  s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << kW << "\" height=\"" << kH
    << "\" font-family=\"sans-serif\" font-size=\"13\">\n<rect width=\"100%\" height=\"100%\" "
       "fill=\"white\"/>\n";
  s << "<text x=\"" << kW / 2 << "\" y=\"24\" text-anchor=\"middle\" font-size=\"16\">" << title
    << "</text>\n";
  for (double v = 0.0; v <= ytop * 1.0001; v += step) {
    s << "<line x1=\"" << kL << "\" x2=\"" << kW - kR << "\" y1=\"" << py(v) << "\" y2=\"" << py(v)
      << "\" stroke=\"#ddd\"/>\n<text x=\"" << kL - 6 << "\" y=\"" << py(v) + 4
      << "\" text-anchor=\"end\">" << v << "</text>\n";
  }
  const double xstep = std::pow(10.0, std::floor(std::log10((xmax - xmin) / 2.0)));
  for (double v = std::ceil(xmin / xstep) * xstep; v <= xmax; v += xstep)
    s << "<text x=\"" << px(v) << "\" y=\"" << kH - kB + 18 << "\" text-anchor=\"middle\">" << v
      << "</text>\n";
  s << "<rect x=\"" << kL << "\" y=\"" << kT << "\" width=\"" << kW - kL - kR << "\" height=\""
    << kH - kT - kB << "\" fill=\"none\" stroke=\"#444\"/>\n";
  s << "<text x=\"" << (kL + kW - kR) / 2 << "\" y=\"" << kH - 18 << "\" text-anchor=\"middle\">"
    << x_label << "</text>\n";
  s << "<text transform=\"translate(18," << (kT + kH - kB) / 2
    << ") rotate(-90)\" text-anchor=\"middle\">" << y_label << "</text>\n";
  for (std::size_t i = 0; i < series.size(); ++i) {
    const auto& ser = series[i];
    s << "<polyline fill=\"none\" stroke=\"" << ser.color << "\" stroke-width=\"1.2\" points=\"";
    for (std::size_t k = 0; k < ser.y.size() && k < x.size(); ++k)
      if (std::isfinite(ser.y[k])) s << px(x[k]) << "," << py(std::min(ser.y[k], ytop)) << " ";
    s << "\"/>\n";
    const double ly = kT + 10 + 20.0 * static_cast<double>(i);
    s << "<line x1=\"" << kW - kR + 12 << "\" x2=\"" << kW - kR + 36 << "\" y1=\"" << ly
      << "\" y2=\"" << ly << "\" stroke=\"" << ser.color << "\" stroke-width=\"3\"/>\n<text x=\""
      << kW - kR + 42 << "\" y=\"" << ly + 4 << "\">" << ser.name << "</text>\n";
  }
  s << "</svg>\n";
  return s.str();
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank == 0 ? 0 : rank - 1)];
}

}  // namespace tc::cli::demo
