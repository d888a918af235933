#include "scene_run.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace tc::sim {

double energy_rise(const RunBooks& books) {
  if (!std::isfinite(books.energy_max)) return std::numeric_limits<double>::infinity();
  return (books.energy_max - books.energy_initial) /
         std::max(std::abs(books.energy_initial), 1e-12);
}

namespace {

/// The contact force linearised in the velocity as well, for backward Euler: with the
/// df/dv blocks D, f(v) ~ fc + D (v - vn) and v = (x - xn) / h, so the step sees the
/// force fc - D vn and the stiffness K + D / h (docs/DEMO.md, "Integration").
void fold_damping(const Eigen::Matrix3Xd& damping, const Eigen::Matrix3Xd& vn, double h,
                  Eigen::Matrix3Xd& forces, Eigen::Matrix3Xd& blocks) {
  if (damping.cols() == 0 || blocks.cols() != damping.cols()) return;
  for (Index i = 0; i < vn.cols(); ++i) {
    const Eigen::Matrix3d d = damping.block<3, 3>(0, 3 * i);
    if (d.isZero()) continue;
    forces.col(i) -= d * vn.col(i);
    blocks.block<3, 3>(0, 3 * i) += d / h;
  }
}

/// Mass-weighted mean of the columns of x.
Eigen::Vector3d weighted_mean(const Eigen::VectorXd& mass, const Eigen::Matrix3Xd& x) {
  return x * mass / mass.sum();
}

}  // namespace

std::vector<std::string> run_failures(const RunBooks& books, double max_rise,
                                      double max_self_penetration) {
  std::vector<std::string> failures;
  if (books.rejected > 0)
    failures.push_back("the service rejected " + std::to_string(books.rejected) +
                       " states (first: " + books.first_rejection + ")");
  if (books.first_non_finite_frame >= 0)
    failures.push_back("the state became NaN or infinite at frame " +
                       std::to_string(books.first_non_finite_frame));
  if (books.inverted_tets > 0)
    failures.push_back(std::to_string(books.inverted_tets) + " tets inverted (first at frame " +
                       std::to_string(books.first_inverted_frame) + ")");
  if (const double rise = energy_rise(books); !(rise <= max_rise)) {
    char msg[200];
    std::snprintf(msg, sizeof msg,
                  "the mechanical energy rose %.1f %% above its initial value (%.4g J -> max "
                  "%.4g J): the integration is unstable",
                  100.0 * rise, books.energy_initial, books.energy_max);
    failures.emplace_back(msg);
  }
  if (max_self_penetration > 0.0 && books.max_self_penetration > max_self_penetration) {
    char msg[200];
    std::snprintf(msg, sizeof msg,
                  "an object went %.3f mm into itself at frame %lld (the scene allows %.3f mm)",
                  1e3 * books.max_self_penetration,
                  static_cast<long long>(books.max_self_penetration_frame),
                  1e3 * max_self_penetration);
    failures.emplace_back(msg);
  }
  return failures;
}

Expected<SceneRun> SceneRun::create(const SceneSpec& scene) {
  SceneRun run;
  run.scene_ = scene;
  const bool implicit = scene.integrator == "implicit";
  for (const auto& o : scene.objects) {
    SimObject e;
    e.spec = o;
    if (o.shell) {
      auto surface = load_object_surface(o);
      if (!surface) return Error{surface.error().code, o.name + ": " + surface.error().message};
      auto shell = ShellBody::create(std::move(*surface), *o.shell);
      if (!shell) return Error{shell.error().code, o.name + ": " + shell.error().message};
      Eigen::Matrix3Xd v(3, shell->node_count());
      v.colwise() = o.velocity;
      shell->set_velocities(v);
      e.shell = std::move(*shell);
      e.contact = Eigen::Matrix3Xd::Zero(3, e.positions().cols());
      run.objects_.push_back(std::move(e));
      continue;
    }
    auto mesh = load_object_mesh(o);
    if (!mesh) return Error{mesh.error().code, o.name + ": " + mesh.error().message};
    if (o.is_static) {
      e.fixed = std::move(*mesh);
      e.zero_velocity = Eigen::Matrix3Xd::Zero(3, e.fixed.positions.cols());
    } else {
      auto body = Body::create(std::move(*mesh), o.material);
      if (!body) return Error{body.error().code, o.name + ": " + body.error().message};
      Eigen::Matrix3Xd v(3, body->node_count());
      v.colwise() = o.velocity;
      body->set_velocities(v);
      if (o.fix_border > 0.0) body->fix_nodes(body->border_nodes(o.fix_border, o.fix_border));
      e.body = std::move(*body);
      e.inverted_seen.assign(e.body->rest_mesh().tets.size(), false);
      if (implicit)
        e.stepper.emplace(ImplicitOptions{
            .max_newton = scene.newton_iterations,
            .solver = scene.linear_solver == "ldlt" ? LinearSolver::kLdlt : LinearSolver::kCg});
    }
    e.contact = Eigen::Matrix3Xd::Zero(3, e.positions().cols());
    run.objects_.push_back(std::move(e));
  }
  for (std::size_t i = 0; i < run.objects_.size(); ++i)
    run.probe_.set_object(i, run.objects_[i].mesh().tets,
                          static_cast<Index>(run.objects_[i].positions().cols()));
  for (const auto& o : run.objects_) {
    if (o.body) run.books_.com_start[o.spec.name] = weighted_mean(o.body->masses(), o.positions());
    if (o.shell)
      run.books_.com_start[o.spec.name] = weighted_mean(o.shell->masses(), o.positions());
  }
  run.books_.energy_initial = run.mechanical_energy();
  run.books_.energy_max = run.books_.energy_initial;
  run.books_.energy_final = run.books_.energy_initial;
  return run;
}

double SceneRun::mechanical_energy() const {
  double e = books_.torn_energy;
  for (const auto& o : objects_) {
    if (o.body) e += o.body->energy(scene_.gravity).total();
    if (o.shell) e += o.shell->energy(scene_.gravity).total();
  }
  return e;
}

Status SceneRun::exchange(ContactService& service, std::int64_t frame, Probe probe) {
  std::vector<StateView> states;
  for (const auto& o : objects_)
    if (o.moving()) states.push_back({&o.spec.name, &o.positions(), &o.velocities()});
  auto answers = service.exchange(frame, states);
  if (!answers) return answers.error();
  const bool implicit = scene_.integrator == "implicit";
  std::size_t contacts = 0;
  for (auto& o : objects_) {
    const Index n = static_cast<Index>(o.positions().cols());
    o.contact = Eigen::Matrix3Xd::Zero(3, n);
    o.blocks.resize(3, 0);
    o.damping.resize(3, 0);
    const auto it = answers->find(o.spec.name);
    if (it == answers->end()) continue;
    const ContactAnswer& a = it->second;
    if (a.status != 0) {
      ++books_.rejected;
      if (books_.first_rejection.empty())
        books_.first_rejection =
            o.spec.name + " at frame " + std::to_string(frame) + ": " + a.status_name;
      continue;
    }
    const bool blocks = a.stiffness.size() == 9 * a.nodes.size();
    if ((o.shell || (implicit && o.body)) && !a.nodes.empty() && !blocks)
      return Error{ErrorCode::kInvalidArgument,
                   "the service sent contact forces without stiffness blocks (object '" +
                       o.spec.name + "', frame " + std::to_string(frame) +
                       "); the implicit integrator needs them: the demo asks for them per "
                       "object (protocol 3); a service before that needs "
                       "'pipeline: {compute_stiffness: true}' in its --config file, or use "
                       "--spawn-daemon"};
    const bool damping = blocks && a.damping.size() == a.stiffness.size();
    if (blocks && o.moving()) o.blocks = Eigen::Matrix3Xd::Zero(3, 3 * n);
    if (damping && o.moving()) o.damping = Eigen::Matrix3Xd::Zero(3, 3 * n);
    for (std::size_t k = 0; k < a.nodes.size(); ++k) {
      const Index i = a.nodes[k];
      if (i < 0 || i >= n) continue;
      o.contact.col(i) = Eigen::Vector3d(a.forces[3 * k], a.forces[3 * k + 1], a.forces[3 * k + 2]);
      if (blocks && o.moving())
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) o.blocks(r, 3 * i + c) = a.stiffness[9 * k + 3 * r + c];
      if (damping && o.moving())
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) o.damping(r, 3 * i + c) = a.damping[9 * k + 3 * r + c];
    }
    contacts += a.nodes.size();
    double& peak = books_.peak_contact_force[o.spec.name];
    peak = std::max(peak, o.contact.rowwise().sum().norm());
  }
  books_.contacts = contacts;
  depth_.clear();
  if (probe == Probe::kYes || (probe == Probe::kIfContact && contacts > 0)) {
    std::vector<const Eigen::Matrix3Xd*> xs;
    for (const auto& o : objects_) xs.push_back(&o.positions());
    depth_ = probe_.measure(xs);
    double deepest = 0.0;
    for (const auto& d : depth_)
      for (const double v : d) deepest = std::max(deepest, v);
    books_.last_penetration = deepest;
    books_.last_probe_frame = frame;
    if (deepest > books_.max_penetration) {
      books_.max_penetration = deepest;
      books_.max_penetration_frame = frame;
    }
    double self = 0.0;
    for (std::size_t i = 0; i < objects_.size(); ++i) {
      const SimObject& o = objects_[i];
      if (o.body && (o.spec.contact.self_contact || scene_.self_penetration_probe))
        self = std::max(self, probe_.self_depth(i, o.positions()));
    }
    books_.last_self_penetration = self;
    if (self > books_.max_self_penetration) {
      books_.max_self_penetration = self;
      books_.max_self_penetration_frame = frame;
    }
  }
  return {};
}

Expected<std::vector<std::size_t>> SceneRun::advance(ContactService& service, std::int64_t frame) {
  for (auto& o : objects_) {
    Eigen::Matrix3Xd forces = o.contact, blocks = o.blocks;
    fold_damping(o.damping, o.velocities(), scene_.dt, forces, blocks);
    if (o.shell) {
      const auto report =
          o.shell->step(scene_.dt, scene_.gravity, forces, blocks, scene_.newton_iterations);
      books_.newton_iterations += static_cast<std::size_t>(report.newton_iterations);
      if (report.linear_solver_failed || report.line_search_failed) ++books_.step_failures;
      if (!o.shell->positions().allFinite() || !o.shell->velocities().allFinite()) {
        if (books_.first_non_finite_frame < 0) books_.first_non_finite_frame = frame;
      }
      continue;
    }
    if (!o.body) continue;
    if (o.stepper) {
      const auto report = o.stepper->step(*o.body, scene_.dt, scene_.gravity, forces, blocks);
      books_.newton_iterations += static_cast<std::size_t>(report.newton_iterations);
      if (report.linear_solver_failed || report.line_search_failed) ++books_.step_failures;
    } else {
      o.body->step(scene_.dt, scene_.substeps, scene_.gravity, o.contact);
    }
    if (!o.body->positions().allFinite() || !o.body->velocities().allFinite()) {
      if (books_.first_non_finite_frame < 0) books_.first_non_finite_frame = frame;
    }
    // Inverted tets, each counted once (until a tear renumbers them).
    const auto& tets = o.body->rest_mesh().tets;
    const auto& x = o.body->positions();
    for (std::size_t t = 0; t < tets.size(); ++t) {
      Eigen::Matrix3d d;
      for (int k = 0; k < 3; ++k)
        d.col(k) = x.col(tets[t][static_cast<std::size_t>(k + 1)]) - x.col(tets[t][0]);
      if (!(d.determinant() > 0.0) && !o.inverted_seen[t]) {
        o.inverted_seen[t] = true;
        ++books_.inverted_tets;
        if (books_.first_inverted_frame < 0) books_.first_inverted_frame = frame;
      }
    }
  }
  // Tearing: a new topology version; the states go on with it.
  std::vector<std::size_t> cut;
  for (std::size_t i = 0; i < objects_.size(); ++i) {
    auto& o = objects_[i];
    if (!o.body || o.spec.tear_strain <= 0.0) continue;
    const double before = o.body->energy(scene_.gravity).total();
    const std::size_t removed = o.body->tear(o.spec.tear_strain);
    if (removed == 0) continue;
    books_.torn_energy += before - o.body->energy(scene_.gravity).total();
    ++books_.tears;
    books_.torn_tets += removed;
    if (books_.first_tear < 0) books_.first_tear = frame;
    o.inverted_seen.assign(o.body->rest_mesh().tets.size(), false);
    probe_.set_object(i, o.body->rest_mesh().tets, o.body->node_count());
    o.contact = Eigen::Matrix3Xd::Zero(3, o.body->node_count());
    o.blocks.resize(3, 0);
    o.damping.resize(3, 0);
    if (auto st = service.reregister(o.spec.name, o.body->rest_mesh()); !st) return st.error();
    cut.push_back(i);
  }
  const double e = mechanical_energy();
  books_.energy_max =
      std::isfinite(e) ? std::max(books_.energy_max, e) : std::numeric_limits<double>::infinity();
  books_.energy_final = e;
  books_.dissipated = 0.0;
  books_.kinetic_final = 0.0;
  for (const auto& o : objects_) {
    const Eigen::VectorXd* mass = o.body    ? &o.body->masses()
                                  : o.shell ? &o.shell->masses()
                                            : nullptr;
    if (mass != nullptr) {
      books_.com[o.spec.name].push_back(weighted_mean(*mass, o.positions()));
      books_.com_velocity[o.spec.name] = weighted_mean(*mass, o.velocities());
    }
    if (o.body) {
      books_.dissipated += o.body->dissipated();
      books_.kinetic_final += o.body->energy(scene_.gravity).kinetic;
    }
    if (o.shell) {
      books_.dissipated += o.shell->dissipated();
      books_.kinetic_final += o.shell->energy(scene_.gravity).kinetic;
    }
  }
  books_.kinetic_max = std::max(books_.kinetic_max, books_.kinetic_final);
  ++books_.frames;
  return cut;
}

}  // namespace tc::sim
