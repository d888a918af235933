// The Python module `tetcollide` (docs/PYTHON.md): libtetcollide_client and the mesh
// readers for simulators written in Python and NumPy.
//
// Arrays in: positions and velocities are borrowed (a C-contiguous float64 array is
// read in place; anything else is converted once); the topology is copied once into the
// registration, because Client::register_object() takes vectors. Arrays out: the
// vectors of the client's answers (and of the mesh reader) are moved into NumPy arrays
// that own them through a capsule, never copied.
//
// The GIL is released while the client waits on DDS or writes samples. Errors: bad
// arguments raise TypeError (wrong kind of object or dtype) or ValueError (shape, range,
// unknown name) naming the argument; DDS failures raise tetcollide.ClientError; the
// service's verdicts are values, as in the C++ client (Registration, ObjectForces.status),
// which check() / raise_for_status() turn into tetcollide.RejectedError.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/io/mesh_io.hpp"
#include "core/io/surface_io.hpp"
#include "tetcollide/client.hpp"
#include "tetcollide/integration.hpp"

namespace py = pybind11;
using tc::client::Client;

namespace {

// --- arrays -------------------------------------------------------------------------

/// A NumPy array of `shape` over `data`, which `owner` holds; the array owns `owner`
/// through a capsule (nothing is copied).
template <typename Owner, typename T>
py::array adopt(std::unique_ptr<Owner> owner, const T* data, std::vector<py::ssize_t> shape) {
  py::capsule capsule(owner.get(), [](void* p) { delete static_cast<Owner*>(p); });
  owner.release();  // the capsule deletes it from here on
  return py::array_t<T>(std::move(shape), data, capsule);
}

/// A NumPy array of `shape` that owns `values` (moved, not copied).
template <typename T>
py::array owning_array(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto owner = std::make_unique<std::vector<T>>(std::move(values));
  const T* data = owner->data();
  return adopt(std::move(owner), data, std::move(shape));
}

std::string shape_text(const py::array& a) {
  std::ostringstream s;
  s << '(';
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s << (i ? ", " : "") << a.shape(i);
  s << (a.ndim() == 1 ? ",)" : ")");
  return s.str();
}

[[noreturn]] void raise_type(const std::string& text) {
  throw py::type_error(text);
}
[[noreturn]] void raise_value(const std::string& text) {
  throw py::value_error(text);
}

/// `obj` as a NumPy array of numbers (no copy when it is one); TypeError naming `name`
/// and `expected` otherwise. `integers`: only integer dtypes are accepted.
py::array numeric_array(const py::handle& obj, const std::string& name, const std::string& expected,
                        bool integers) {
  const auto type_name = [&] { return std::string(py::str(py::type::of(obj).attr("__name__"))); };
  py::array a = py::array::ensure(obj);
  if (!a) raise_type(name + ": expected " + expected + ", got " + type_name());
  // dtype.kind read as the attribute: GCC's -Wnull-dereference flags the inlined
  // descriptor access of pybind11's dtype::kind() (a false positive at -O3).
  const auto kind_text = a.dtype().attr("kind").cast<std::string>();
  const char kind = kind_text.empty() ? '?' : kind_text.front();
  const bool ok =
      integers ? (kind == 'i' || kind == 'u') : (kind == 'f' || kind == 'i' || kind == 'u');
  if (!ok && kind == 'O' && !py::isinstance<py::array>(obj))  // None, a str, a ragged list
    raise_type(name + ": expected " + expected + ", got " + type_name());
  if (!ok)
    raise_type(name + ": expected " + expected + ", got dtype " + std::string(py::str(a.dtype())));
  return a;
}

/// Checks that `a` is rows x cols (rows < 0: any); ValueError naming `name` otherwise.
void check_shape(const py::array& a, const std::string& name, py::ssize_t rows, py::ssize_t cols,
                 const std::string& expected) {
  if (a.ndim() != 2 || a.shape(1) != cols || (rows >= 0 && a.shape(0) != rows))
    raise_value(name + ": expected shape " + expected + ", got " + shape_text(a));
}

using F64 = py::array_t<double, py::array::c_style | py::array::forcecast>;
using I64 = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

/// An n x 3 float64 C-contiguous view of `obj`: the array itself when it already is one
/// (borrowed), else one converted copy.
F64 positions_array(const py::handle& obj, const std::string& name, py::ssize_t rows) {
  const std::string expected = rows >= 0 ? "(" + std::to_string(rows) + ", 3)" : "(n, 3)";
  py::array a = numeric_array(obj, name, "a float64 array of shape " + expected, false);
  check_shape(a, name, rows, 3, expected);
  return F64::ensure(a);
}

/// A float as Python writes it ("-1.0", "nan"), for messages (GIL held).
std::string float_text(double value) {
  return py::repr(py::float_(value));
}

std::chrono::milliseconds timeout_ms(double seconds, const char* name = "timeout") {
  if (!std::isfinite(seconds) || seconds < 0.0 || seconds > 1e9)
    raise_value(std::string(name) + ": expected seconds in [0, 1e9], got " + float_text(seconds));
  return std::chrono::milliseconds(static_cast<std::int64_t>(std::llround(seconds * 1000.0)));
}

// --- exceptions ---------------------------------------------------------------------

py::object g_rejected_error;  // tetcollide.RejectedError, set at import

[[noreturn]] void raise_rejected(const std::string& object, std::int32_t code,
                                 const std::string& message) {
  std::string text =
      "tetcollide: the service rejected '" + object + "': " + tc::client::status_name(code);
  if (!message.empty()) text += ": " + message;
  py::object e = g_rejected_error(text);
  e.attr("object") = object;
  e.attr("code") = code;
  e.attr("code_name") = tc::client::status_name(code);
  PyErr_SetObject(g_rejected_error.ptr(), e.ptr());
  throw py::error_already_set();
}

// --- answers ------------------------------------------------------------------------

/// The contacts behind an answer's forces (ObjectParams.contacts) as NumPy columns, one
/// row per contact point (docs/PROTOCOL.md "Contacts").
struct PyContacts {
  py::array node;         ///< int32 (k,): the intruding node (the edge's first for a piece)
  py::array nodes;        ///< int32 (k, 2): the intruding object's nodes (second -1: a point)
  py::array weights;      ///< float64 (k, 2): the point is w0 x[n0] + w1 x[n1]
  py::array other;        ///< str (k,): the other object
  py::array intrudes;     ///< bool (k,): this object's point is inside the other
  py::array tet;          ///< int32 (k,): the penetrated object's tet
  py::array barycentric;  ///< float64 (k, 4): the point in that tet
  py::array depth;        ///< float64 (k,): metres
  py::array normal;       ///< float64 (k, 3): unit push-out direction of the intruder

  explicit PyContacts(const std::vector<tc::client::Contact>& c) {
    const auto k = static_cast<py::ssize_t>(c.size());
    std::vector<std::int32_t> n0(c.size()), ns(2 * c.size()), t(c.size());
    std::vector<double> w(2 * c.size()), b(4 * c.size()), d(c.size()), nr(3 * c.size());
    py::array_t<bool> in(k);
    py::list names;
    auto in_w = in.mutable_unchecked<1>();
    for (std::size_t r = 0; r < c.size(); ++r) {
      n0[r] = c[r].nodes[0];
      for (std::size_t j = 0; j < 2; ++j) {
        ns[2 * r + j] = c[r].nodes[j];
        w[2 * r + j] = c[r].weights[j];
      }
      t[r] = c[r].tet;
      for (std::size_t j = 0; j < 4; ++j) b[4 * r + j] = c[r].barycentric[j];
      d[r] = c[r].depth;
      for (std::size_t j = 0; j < 3; ++j) nr[3 * r + j] = c[r].normal[j];
      in_w(static_cast<py::ssize_t>(r)) = c[r].intrudes;
      names.append(c[r].other);
    }
    node = owning_array(std::move(n0), {k});
    nodes = owning_array(std::move(ns), {k, 2});
    weights = owning_array(std::move(w), {k, 2});
    tet = owning_array(std::move(t), {k});
    barycentric = owning_array(std::move(b), {k, 4});
    depth = owning_array(std::move(d), {k});
    normal = owning_array(std::move(nr), {k, 3});
    intrudes = std::move(in);
    other = py::module_::import("numpy").attr("array")(names, py::arg("dtype") = "str");
  }
};

/// ObjectForces with NumPy arrays that own the client's vectors.
struct PyObjectForces {
  std::string object;
  std::int64_t frame = 0;
  std::uint32_t topology_version = 0;
  std::int32_t status = 0;
  py::array nodes;
  py::array forces;
  py::object stiffness;
  py::object damping;
  std::shared_ptr<PyContacts> contacts;
  std::int64_t state_frame = -1;
  std::uint64_t answer_id = 0;
  std::vector<std::string> left_out;

  explicit PyObjectForces(tc::client::ObjectForces&& f)
      : object(std::move(f.object)),
        frame(f.frame),
        topology_version(f.topology_version),
        status(f.status),
        state_frame(f.state_frame),
        answer_id(f.answer_id),
        left_out(std::move(f.left_out)) {
    contacts = std::make_shared<PyContacts>(f.contacts);
    const auto k = static_cast<py::ssize_t>(f.nodes.size());
    // A malformed answer (lengths that do not match) would be the service's bug; the
    // C++ client passes it on as it came, so do we, as flat arrays.
    const bool whole = f.forces.size() == 3 * f.nodes.size();
    forces = whole ? owning_array(std::move(f.forces), {k, 3})
                   : owning_array(std::move(f.forces), {static_cast<py::ssize_t>(f.forces.size())});
    nodes = owning_array(std::move(f.nodes), {k});
    // None: no blocks asked (register(blocks=False), pipeline.compute_stiffness off) or,
    // for damping, a service before protocol 3; an answer without contact has (0, 3, 3)
    // blocks either way.
    const auto blocks = [k](std::vector<double>&& b) -> py::object {
      if (b.empty() && k > 0) return py::none();
      if (b.size() == 9 * static_cast<std::size_t>(k)) return owning_array(std::move(b), {k, 3, 3});
      const auto size = static_cast<py::ssize_t>(b.size());
      return owning_array(std::move(b), {size});
    };
    stiffness = blocks(std::move(f.stiffness));
    damping = blocks(std::move(f.damping));
  }
};

struct PyFrameForces {
  std::int64_t frame = 0;
  std::vector<std::shared_ptr<PyObjectForces>> objects;  // sorted by name

  [[nodiscard]] bool ok() const {
    for (const auto& o : objects)
      if (o->status != 0) return false;
    return true;
  }
  [[nodiscard]] std::shared_ptr<PyObjectForces> get(const std::string& name) const {
    for (const auto& o : objects)
      if (o->object == name) return o;
    throw py::key_error("no answer for object '" + name + "' in frame " + std::to_string(frame));
  }
};

// --- client -------------------------------------------------------------------------

tc::client::DepthMethod parse_depth(const std::string& s) {
  if (const auto m = tc::client::parse_depth_method(s)) return *m;
  raise_value("depth: expected 'cpfm', 'cffm' or 'exact', got '" + s + "'");
}

tc::client::ResponseKind parse_response(const std::string& s) {
  if (const auto k = tc::client::parse_response_kind(s)) return *k;
  raise_value("response: expected 'point', 'segment' or 'auto', got '" + s + "'");
}

/// The Python Client. The C++ client is shared with every call in progress, so close()
/// from one thread never frees it under a wait of another (the last call frees it).
class PyClient {
 public:
  PyClient(const std::string& scene, std::uint32_t domain, const std::string& partition,
           const py::object& config, double resend_after) {
    tc::client::Options o;
    if (scene.empty()) raise_value("scene: expected a non-empty name");
    o.scene = scene;
    o.domain = domain;
    if (domain > 232)
      raise_value("domain: expected a DDS domain id in [0, 232], got " + std::to_string(domain));
    o.partition = partition;
    o.cyclonedds_config = config_text(config);
    o.resend_after = timeout_ms(resend_after, "resend_after");
    py::gil_scoped_release release;
    client_ = std::shared_ptr<Client>(Client::connect(o).release());
  }

  std::shared_ptr<Client> get() const {
    if (!client_) throw tc::client::ClientError("tetcollide: the client is closed");
    return client_;
  }

  void close() {
    std::shared_ptr<Client> c = std::move(client_);
    objects_.clear();
    py::gil_scoped_release release;
    c.reset();  // deletes the DDS participant unless a call in another thread holds it
  }
  [[nodiscard]] bool closed() const { return !client_; }

  bool wait_for_service(double timeout) {
    auto c = get();
    const auto t = timeout_ms(timeout);
    py::gil_scoped_release release;
    return c->wait_for_service(t);
  }

  bool wait_for_readers(std::size_t count, double timeout) {
    auto c = get();
    const auto t = timeout_ms(timeout);
    py::gil_scoped_release release;
    return c->wait_for_readers(count, t);
  }

  std::uint32_t register_object(const std::string& object, const py::object& nodes_obj,
                                const py::object& tets_obj, double stiffness, double damping,
                                double max_force, bool is_static, const std::string& depth,
                                const std::string& response, const py::object& node_ids_obj,
                                std::uint32_t version, double friction, double friction_velocity,
                                bool blocks, bool contacts, bool self_contact) {
    tc::client::ObjectParams params =
        make_params(stiffness, damping, max_force, is_static, depth, response, friction,
                    friction_velocity, blocks, contacts);
    params.self_contact = self_contact;
    return register_cells(object, nodes_obj, tets_obj, "tets", 4, params, node_ids_obj, version);
  }

  std::uint32_t register_surface(const std::string& object, const py::object& nodes_obj,
                                 const py::object& triangles_obj, double stiffness, double damping,
                                 double max_force, bool is_static, const std::string& response,
                                 const py::object& node_ids_obj, std::uint32_t version,
                                 double friction, double friction_velocity, bool blocks,
                                 bool contacts) {
    // A surface has no depth map: the depth method is never used ("cpfm" is sent).
    return register_cells(object, nodes_obj, triangles_obj, "triangles", 3,
                          make_params(stiffness, damping, max_force, is_static, "cpfm", response,
                                      friction, friction_velocity, blocks, contacts),
                          node_ids_obj, version);
  }

  /// Checked parameters of register() and register_surface() (ValueError on a bad one).
  static tc::client::ObjectParams make_params(double stiffness, double damping, double max_force,
                                              bool is_static, const std::string& depth,
                                              const std::string& response, double friction,
                                              double friction_velocity, bool blocks,
                                              bool contacts) {
    for (const auto& [value, param] :
         {std::pair{stiffness, "stiffness"}, std::pair{damping, "damping"},
          std::pair{max_force, "max_force"}, std::pair{friction, "friction"},
          std::pair{friction_velocity, "friction_velocity"}})
      if (!std::isfinite(value) || value < 0.0)
        raise_value(std::string(param) + ": expected a finite value >= 0, got " +
                    float_text(value));
    tc::client::ObjectParams params;
    params.stiffness = stiffness;
    params.damping = damping;
    params.max_force = max_force;
    params.is_static = is_static;
    params.depth = parse_depth(depth);
    params.response = parse_response(response);
    params.friction = friction;
    params.friction_velocity = friction_velocity;
    params.blocks = blocks;
    params.contacts = contacts;
    return params;
  }

  /// A tet object (`name` "tets", k = 4 nodes per cell) or a surface object
  /// ("triangles", k = 3): nodes (n, 3), cells (m, k) node indices in [0, n).
  std::uint32_t register_cells(const std::string& object, const py::object& nodes_obj,
                               const py::object& cells_obj, const std::string& cells_name, int k,
                               const tc::client::ObjectParams& params,
                               const py::object& node_ids_obj, std::uint32_t version) {
    auto c = get();
    if (object.empty()) raise_value("object: expected a non-empty name");
    tc::client::Mesh mesh;
    const F64 nodes = positions_array(nodes_obj, "nodes", -1);
    const py::ssize_t n = nodes.shape(0);
    if (n < k)  // a cell has k distinct nodes
      raise_value("nodes: expected shape (n, 3) with n >= " + std::to_string(k) + ", got " +
                  shape_text(nodes));
    mesh.rest_positions.assign(nodes.data(), nodes.data() + 3 * n);

    const std::string shape = "(m, " + std::to_string(k) + ")";
    const std::string& name = cells_name;
    const py::array cells_any =
        numeric_array(cells_obj, name, "an integer array of shape " + shape, true);
    check_shape(cells_any, name, -1, k, shape);
    if (cells_any.shape(0) == 0)
      raise_value(name + ": expected shape " + shape + " with m >= 1, got (0, " +
                  std::to_string(k) + ")");
    const I64 cells = I64::ensure(cells_any);
    if (!cells) raise_type(name + ": values do not fit int64");
    const py::ssize_t m = cells.shape(0);
    std::vector<std::int32_t>& out = k == 4 ? mesh.tets : mesh.triangles;
    out.resize(static_cast<std::size_t>(k * m));
    const std::int64_t* t = cells.data();
    for (py::ssize_t i = 0; i < k * m; ++i) {
      if (t[i] < 0 || t[i] >= n)
        raise_value(name + "[" + std::to_string(i / k) + ", " + std::to_string(i % k) +
                    "] = " + std::to_string(t[i]) +
                    " is out of range: expected a node index in [0, " + std::to_string(n) + ")");
      out[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(t[i]);
    }
    if (!node_ids_obj.is_none()) {
      const py::array ids_any =
          numeric_array(node_ids_obj, "node_ids", "an integer array of shape (n,)", true);
      if (ids_any.ndim() != 1 || ids_any.shape(0) != n)
        raise_value("node_ids: expected shape (" + std::to_string(n) + ",), got " +
                    shape_text(ids_any));
      const I64 ids = I64::ensure(ids_any);
      mesh.node_ids.assign(ids.data(), ids.data() + n);
    }
    std::uint32_t sent = 0;
    {
      py::gil_scoped_release release;
      sent = c->register_object(object, mesh, params, version);
    }
    objects_[object] = {n, params.is_static};
    return sent;
  }

  tc::client::Registration wait_registered(const std::string& object, double timeout) {
    auto c = get();
    const auto t = timeout_ms(timeout);
    py::gil_scoped_release release;
    return c->wait_registered(object, t);
  }

  void remove_object(const std::string& object) {
    auto c = get();
    if (objects_.erase(object) == 0)
      raise_value("object: '" + object + "' is not registered with this client");
    py::gil_scoped_release release;
    c->remove_object(object);
  }

  std::uint32_t version(const std::string& object) const { return get()->version(object); }

  void publish(std::int64_t frame, const py::object& positions_obj,
               const py::object& velocities_obj) {
    auto c = get();
    if (frame < 0) raise_value("frame: expected a frame number >= 0, got " + std::to_string(frame));
    if (!py::isinstance<py::dict>(positions_obj))
      raise_type("positions: expected a dict {object: (n, 3) float64 array}");
    const auto positions = positions_obj.cast<py::dict>();
    py::dict velocities;
    if (!velocities_obj.is_none()) {
      if (!py::isinstance<py::dict>(velocities_obj))
        raise_type("velocities: expected a dict {object: (n, 3) float64 array} or None");
      velocities = velocities_obj.cast<py::dict>();
      for (const auto& [key, value] : velocities)
        if (!positions.contains(key))
          raise_value("velocities: object '" + std::string(py::str(key)) +
                      "' has velocities but no positions in this frame");
    }
    if (positions.empty()) raise_value("positions: expected at least one object");
    // The arrays stay referenced here while the GIL is released: the spans point into them.
    std::vector<F64> keep;
    std::vector<std::string> names;
    keep.reserve(2 * positions.size());
    names.reserve(positions.size());
    std::vector<tc::client::ObjectState> states;
    for (const auto& [key, value] : positions) {
      if (!py::isinstance<py::str>(key)) raise_type("positions: expected str object names as keys");
      const auto name = key.cast<std::string>();
      const auto it = objects_.find(name);
      if (it == objects_.end())
        raise_value("positions: object '" + name + "' is not registered with this client");
      const py::ssize_t n = it->second.nodes;
      keep.push_back(positions_array(value, "positions['" + name + "']", n));
      names.push_back(name);
      if (velocities.contains(key))
        keep.push_back(positions_array(velocities[key], "velocities['" + name + "']", n));
    }
    std::size_t k = 0;
    for (std::size_t i = 0; i < names.size(); ++i) {
      tc::client::ObjectState s;
      s.object = names[i];
      const F64& p = keep[k++];
      s.positions = {p.data(), static_cast<std::size_t>(p.size())};
      if (velocities.contains(py::str(names[i]))) {
        const F64& v = keep[k++];
        s.velocities = {v.data(), static_cast<std::size_t>(v.size())};
      }
      states.push_back(std::move(s));
    }
    // Static objects' states are written first. The service dispatches a frame as soon as
    // every non-static object's state is in; a static object's state arriving after that
    // is answered by a second computation once frames.assembly_wait_ms has passed, and
    // wait_forces waits for it (measured: ball then box 51 ms a frame, box then ball
    // 0.3 ms, with assembly_wait_ms 50; the C++ client, which writes in the caller's
    // order, does the same).
    std::stable_partition(states.begin(), states.end(), [&](const tc::client::ObjectState& s) {
      return objects_.at(s.object).is_static;
    });
    py::gil_scoped_release release;
    c->publish_states(frame, states);
  }

  std::optional<PyFrameForces> wait_forces(std::int64_t frame, double timeout) {
    auto c = get();
    const auto t = timeout_ms(timeout);
    std::optional<tc::client::FrameForces> got;
    {
      py::gil_scoped_release release;
      got = c->wait_forces(frame, t);
    }
    if (!got) return std::nullopt;
    PyFrameForces out;
    out.frame = got->frame;
    for (auto& o : got->objects)
      out.objects.push_back(std::make_shared<PyObjectForces>(std::move(o)));
    return out;
  }

  std::vector<tc::client::StatusEvent> status_events() {
    auto c = get();
    py::gil_scoped_release release;
    return c->take_status_events();
  }

  std::vector<tc::client::FrameStatsEvent> frame_stats() {
    auto c = get();
    py::gil_scoped_release release;
    return c->take_frame_stats();
  }

  void poll(double timeout) {
    auto c = get();
    const auto t = timeout_ms(timeout);
    py::gil_scoped_release release;
    c->poll(t);
  }

 private:
  /// The Cyclone config: XML (starts with '<'), a URI (file://...), or a path to a file.
  static std::string config_text(const py::object& config) {
    if (config.is_none()) return {};
    const py::object os = py::module_::import("os");
    if (!py::isinstance<py::str>(config) && !py::isinstance(config, os.attr("PathLike")))
      raise_type("config: expected a path, a file:// URI or Cyclone DDS XML (str), or None");
    const auto text = os.attr("fspath")(config).cast<std::string>();
    if (text.empty() || text.front() == '<' || text.find("://") != std::string::npos) return text;
    if (!os.attr("path").attr("isfile")(text).cast<bool>())
      raise_value("config: no such file: '" + text + "'");
    return "file://" + os.attr("path").attr("abspath")(text).cast<std::string>();
  }

  std::shared_ptr<Client> client_;
  struct Registered {
    py::ssize_t nodes = 0;  ///< n of the version last registered
    bool is_static = false;
  };
  std::map<std::string, Registered> objects_;  // objects registered by this client
};

/// Raises OSError (kIo) or ValueError for a reader's error.
[[noreturn]] void raise_read_error(const tc::Error& e) {
  if (e.code == tc::ErrorCode::kIo) {
    PyErr_SetObject(PyExc_OSError, py::str(e.message).ptr());
    throw py::error_already_set();
  }
  raise_value(e.message);
}

py::tuple read_mesh(const py::object& path_obj) {
  const auto path = py::module_::import("os").attr("fspath")(path_obj).cast<std::string>();
  tc::Expected<tc::TetMesh> mesh = [&] {
    py::gil_scoped_release release;
    return tc::read_mesh(path);
  }();
  if (!mesh) raise_read_error(mesh.error());
  tc::TetMesh& m = *mesh;
  const auto n = static_cast<py::ssize_t>(m.positions.cols());
  const auto k = static_cast<py::ssize_t>(m.tets.size());
  // Positions are 3 x n column-major: the bytes of an n x 3 C array; tets are m x 4.
  auto positions = std::make_unique<tc::Positions>(std::move(m.positions));
  const double* p = positions->data();
  py::array nodes = adopt(std::move(positions), p, {n, 3});
  static_assert(sizeof(tc::Tet) == 4 * sizeof(std::int32_t));
  auto tet_list = std::make_unique<std::vector<tc::Tet>>(std::move(m.tets));
  const std::int32_t* t = tet_list->empty() ? nullptr : tet_list->front().data();
  py::array tets = adopt(std::move(tet_list), t, {k, 4});
  return py::make_tuple(nodes, tets);
}

/// A client::Mesh from nodes (n, 3) and cells (m, 4) tets or (m, 3) triangles, for the
/// integration helpers (ValueError on bad shapes or indices).
tc::client::Mesh mesh_of(const py::object& nodes_obj, const py::object& cells_obj) {
  tc::client::Mesh mesh;
  const F64 nodes = positions_array(nodes_obj, "nodes", -1);
  const py::ssize_t n = nodes.shape(0);
  mesh.rest_positions.assign(nodes.data(), nodes.data() + 3 * n);
  const py::array any =
      numeric_array(cells_obj, "cells", "an integer array of shape (m, 4) or (m, 3)", true);
  if (any.ndim() != 2 || (any.shape(1) != 4 && any.shape(1) != 3))
    raise_value("cells: expected shape (m, 4) (tets) or (m, 3) (triangles), got " +
                shape_text(any));
  const I64 cells = I64::ensure(any);
  if (!cells) raise_type("cells: values do not fit int64");
  std::vector<std::int32_t>& out = any.shape(1) == 4 ? mesh.tets : mesh.triangles;
  const py::ssize_t size = cells.size();
  out.resize(static_cast<std::size_t>(size));
  for (py::ssize_t i = 0; i < size; ++i) {
    const std::int64_t v = cells.data()[i];
    if (v < 0 || v >= n)
      raise_value("cells[" + std::to_string(i / any.shape(1)) + ", " +
                  std::to_string(i % any.shape(1)) + "] = " + std::to_string(v) +
                  " is out of range: expected a node index in [0, " + std::to_string(n) + ")");
    out[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(v);
  }
  return mesh;
}

py::array node_weights_py(const py::object& nodes, const py::object& cells) {
  std::vector<double> w = tc::client::node_weights(mesh_of(nodes, cells));
  const auto n = static_cast<py::ssize_t>(w.size());
  return owning_array(std::move(w), {n});
}

double max_explicit_stiffness_py(const py::object& nodes, const py::object& cells,
                                 const py::object& masses_obj, double dt, double damping) {
  const tc::client::Mesh mesh = mesh_of(nodes, cells);
  const py::array any = numeric_array(masses_obj, "masses", "a float64 array of shape (n,)", false);
  const auto masses = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(any);
  if (!masses || masses.ndim() != 1)
    raise_value("masses: expected shape (n,), got " + shape_text(any));
  try {
    return tc::client::max_explicit_stiffness(
        mesh, std::span<const double>(masses.data(), static_cast<std::size_t>(masses.size())), dt,
        damping);
  } catch (const std::invalid_argument& e) {
    raise_value(e.what());
  }
}

py::tuple read_surface(const py::object& path_obj) {
  const auto path = py::module_::import("os").attr("fspath")(path_obj).cast<std::string>();
  tc::Expected<tc::SurfaceMesh> mesh = [&] {
    py::gil_scoped_release release;
    return tc::read_surface(path);
  }();
  if (!mesh) raise_read_error(mesh.error());
  tc::SurfaceMesh& m = *mesh;
  const auto n = static_cast<py::ssize_t>(m.positions.cols());
  const auto k = static_cast<py::ssize_t>(m.triangles.size());
  auto positions = std::make_unique<tc::Positions>(std::move(m.positions));
  const double* p = positions->data();
  py::array nodes = adopt(std::move(positions), p, {n, 3});
  static_assert(sizeof(tc::Triangle) == 3 * sizeof(std::int32_t));
  auto list = std::make_unique<std::vector<tc::Triangle>>(std::move(m.triangles));
  const std::int32_t* t = list->empty() ? nullptr : list->front().data();
  py::array triangles = adopt(std::move(list), t, {k, 3});
  return py::make_tuple(nodes, triangles);
}

}  // namespace

PYBIND11_MODULE(tetcollide, m) {
  m.doc() =
      "tetcollide: contact forces between deformable tetrahedral meshes from the tetcollided\n"
      "service, for simulators written in Python and NumPy (docs/PYTHON.md).\n\n"
      "    nodes, tets = tetcollide.read_mesh('ball.msh')\n"
      "    with tetcollide.Client('my_scene', domain=7) as c:\n"
      "        c.wait_for_service(5.0)\n"
      "        c.register('ball', nodes, tets, stiffness=1e5)\n"
      "        c.wait_registered('ball', 5.0).check()\n"
      "        c.publish(0, {'ball': nodes})\n"
      "        answer = c.wait_forces(0, 1.0)   # None on timeout\n"
      "        f = answer['ball']               # .nodes (k,), .forces (k, 3) N\n";
  m.attr("__version__") = TC_VERSION;

  py::register_exception<tc::client::ClientError>(m, "ClientError", PyExc_RuntimeError);
  g_rejected_error = py::exception<void>(m, "RejectedError", PyExc_RuntimeError);
  m.attr("RejectedError").attr("__doc__") =
      "The service rejected an object's topology or state. Attributes: object (str), code\n"
      "(int, a Status value) and code_name (str, e.g. 'invalid_mesh').";
  // The object outlives the interpreter's modules otherwise: drop it at exit.
  py::module_::import("atexit").attr("register")(
      py::cpp_function([] { g_rejected_error = py::object(); }));

  // An IntEnum (equal to the ints of ObjectForces.status and Registration.code); a
  // pybind11 enum of an enum class never compares equal to an int.
  {
    py::dict codes;
    for (std::int32_t code = 0;
         code <= static_cast<std::int32_t>(tc::client::StatusCode::kInternal); ++code) {
      std::string name = tc::client::status_name(code);
      for (auto& ch : name) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
      codes[py::str(name)] = code;
    }
    m.attr("Status") = py::module_::import("enum").attr("IntEnum")(
        "Status", codes, py::arg("module") = "tetcollide");
    m.attr("Status").attr("__doc__") = "Status codes of the protocol (docs/PROTOCOL.md, Errors).";
  }
  m.def("status_name", &tc::client::status_name, py::arg("code"),
        "Lower-case name of a status code ('ok', 'invalid_mesh', ...).");

  m.def("read_mesh", &read_mesh, py::arg("path"),
        R"(Reads a tetrahedral mesh: Gmsh .msh (2.2, 4.1 ASCII or binary) or TetGen .node/.ele.

Returns (nodes, tets): nodes float64 (n, 3) in metres, tets int32 (m, 4) 0-based node
indices; both arrays own the reader's buffers (no copy). Raises OSError when the file
cannot be read and ValueError naming the file and line (or byte) when it is malformed.)");

  m.def("read_surface", &read_surface, py::arg("path"),
        R"(Reads a triangle surface: STL (ASCII or binary), Wavefront OBJ, or a Gmsh .msh
with triangles and no tets (docs/SURFACES.md, "Files").

Returns (nodes, triangles): nodes float64 (n, 3) in metres (the file's numbers), triangles
int32 (k, 3) 0-based node indices, for Client.register_surface. Raises OSError when the
file cannot be read and ValueError naming the file and line (or byte) when it is
malformed.)");

  m.def("node_weights", &node_weights_py, py::arg("nodes"), py::arg("cells"),
        R"(The point response's weight of every node, metres (docs/INTEGRATORS.md): half the
summed length of its edges. nodes (n, 3), cells (m, 4) tets or (m, 3) triangles; returns
float64 (n,). A node d metres deep feels stiffness * weight * d newtons.)");
  m.def("max_explicit_stiffness", &max_explicit_stiffness_py, py::arg("nodes"), py::arg("cells"),
        py::arg("masses"), py::arg("dt"), py::arg("damping") = 0.0,
        R"(The largest penalty stiffness (N/m^2) a symplectic Euler step of dt seconds stays
stable with, for every node (masses (n,) kg) against a heavy or static object, with
contact damping `damping` (N s/m^2): min over nodes of (4 m - 2 c w dt) / (w dt^2)
(docs/INTEGRATORS.md). Choose a stiffness below it (half). 0 when the damping alone is
unstable. ValueError on bad shapes, masses or dt.)");

  py::class_<tc::client::Registration>(
      m, "Registration", "The service's verdict on a topology (Client.wait_registered).")
      .def_readonly("done", &tc::client::Registration::done, "False: no verdict before the timeout")
      .def_readonly("ok", &tc::client::Registration::ok, "True: the service built the object")
      .def_readonly("code", &tc::client::Registration::code, "Status of a rejection (int)")
      .def_readonly("message", &tc::client::Registration::message, "the service's message")
      .def(
          "check",
          [](const tc::client::Registration& r, const std::string& object) {
            if (!r.done) {
              PyErr_SetString(
                  PyExc_TimeoutError,
                  ("tetcollide: no verdict on '" + object + "' before the timeout").c_str());
              throw py::error_already_set();
            }
            if (!r.ok) raise_rejected(object, r.code, r.message);
          },
          py::arg("object") = "",
          "Raises TimeoutError without a verdict and RejectedError when the service refused the "
          "topology; returns None when it built the object.")
      .def("__repr__", [](const tc::client::Registration& r) {
        return "Registration(done=" + std::string(r.done ? "True" : "False") +
               ", ok=" + (r.ok ? "True" : "False") + ", code=" + std::to_string(r.code) + " (" +
               tc::client::status_name(r.code) +
               "), message=" + std::string(py::repr(py::str(r.message))) + ")";
      });

  py::class_<PyContacts, std::shared_ptr<PyContacts>>(
      m, "Contacts",
      "The contacts behind an answer's forces, one row per contact point (docs/PROTOCOL.md "
      "'Contacts'): the point nodes/weights of the intruding object inside tet `tet` of the "
      "penetrated one at `barycentric`, `depth` deep, pushed out along `normal`.")
      .def_readonly("node", &PyContacts::node,
                    "int32 (k,): the intruding node (a piece of an edge: its first node)")
      .def_readonly("nodes", &PyContacts::nodes,
                    "int32 (k, 2): the intruding object's nodes; the second is -1 for a point")
      .def_readonly("weights", &PyContacts::weights,
                    "float64 (k, 2): the point is w0 x[n0] + w1 x[n1]")
      .def_readonly("other", &PyContacts::other, "str (k,): the other object")
      .def_readonly("intrudes", &PyContacts::intrudes,
                    "bool (k,): True = this object's point is inside the other")
      .def_readonly("tet", &PyContacts::tet, "int32 (k,): the penetrated object's tet")
      .def_readonly("barycentric", &PyContacts::barycentric,
                    "float64 (k, 4): the point's barycentric coordinates in that tet")
      .def_readonly("depth", &PyContacts::depth, "float64 (k,): penetration depth, m")
      .def_readonly("normal", &PyContacts::normal,
                    "float64 (k, 3): unit push-out direction of the intruding point")
      .def("__len__", [](const PyContacts& c) { return c.depth.shape(0); });

  py::class_<PyObjectForces, std::shared_ptr<PyObjectForces>>(
      m, "ObjectForces", "The service's answer for one object and frame (arrays own their data).")
      .def_readonly("object", &PyObjectForces::object)
      .def_readonly("frame", &PyObjectForces::frame)
      .def_readonly("topology_version", &PyObjectForces::topology_version)
      .def_readonly("status", &PyObjectForces::status,
                    "Status (int); not 0: this object's state was rejected")
      .def_property_readonly(
          "status_name", [](const PyObjectForces& f) { return tc::client::status_name(f.status); })
      .def_readonly("nodes", &PyObjectForces::nodes, "int32 (k,): sorted node indices")
      .def_readonly("forces", &PyObjectForces::forces, "float64 (k, 3): forces on those nodes, N")
      .def_readonly("stiffness", &PyObjectForces::stiffness,
                    "float64 (k, 3, 3): row-major df/dx blocks, N/m; None when none were asked "
                    "(register(blocks=False), pipeline.compute_stiffness off) and k > 0")
      .def_readonly("contacts", &PyObjectForces::contacts,
                    "Contacts: the contacts behind the forces (register(contacts=True)); 0 rows "
                    "otherwise")
      .def_readonly("damping", &PyObjectForces::damping,
                    "float64 (k, 3, 3): row-major df/dv blocks (contact damping and friction), "
                    "N s/m; present with stiffness (protocol 3), else None when k > 0")
      .def_readonly("state_frame", &PyObjectForces::state_frame,
                    "frame of this object's state the forces come from (-1: rest positions)")
      .def_readonly("answer_id", &PyObjectForces::answer_id)
      .def_readonly("left_out", &PyObjectForces::left_out,
                    "objects of the scene the computation had no current state of")
      .def("__repr__", [](const PyObjectForces& f) {
        return "ObjectForces(object='" + f.object + "', frame=" + std::to_string(f.frame) +
               ", version=" + std::to_string(f.topology_version) + ", status='" +
               tc::client::status_name(f.status) + "', nodes=" + std::to_string(f.nodes.shape(0)) +
               ")";
      });

  py::class_<PyFrameForces>(m, "FrameForces",
                            "Every answer of one frame for this client's objects, by object name.")
      .def_readonly(
          "frame", &PyFrameForces::frame,
          "the frame answered (newer than the one waited for when the service skipped it)")
      .def_property_readonly("ok", &PyFrameForces::ok, "True when every object's status is OK")
      .def_property_readonly(
          "objects",
          [](const PyFrameForces& f) {
            py::dict d;
            for (const auto& o : f.objects) d[py::str(o->object)] = o;
            return d;
          },
          "dict {object name: ObjectForces}, sorted by name")
      .def("__getitem__", &PyFrameForces::get, py::arg("object"))
      .def("__contains__",
           [](const PyFrameForces& f, const std::string& name) {
             for (const auto& o : f.objects)
               if (o->object == name) return true;
             return false;
           })
      .def("__len__", [](const PyFrameForces& f) { return f.objects.size(); })
      .def("__iter__",
           [](const PyFrameForces& f) {
             py::list names;
             for (const auto& o : f.objects) names.append(o->object);
             return py::iter(names);
           })
      .def(
          "raise_for_status",
          [](const PyFrameForces& f) {
            for (const auto& o : f.objects)
              if (o->status != 0)
                raise_rejected(o->object, o->status, "state of frame " + std::to_string(o->frame));
          },
          "Raises RejectedError for the first object whose state the service rejected.")
      .def("__repr__", [](const PyFrameForces& f) {
        std::string names;
        for (const auto& o : f.objects) names += (names.empty() ? "'" : ", '") + o->object + "'";
        return "FrameForces(frame=" + std::to_string(f.frame) + ", objects=[" + names +
               "], ok=" + (f.ok() ? "True" : "False") + ")";
      });

  using tc::client::StatusEvent;
  py::class_<StatusEvent> status(m, "StatusEvent", "A ServiceStatus sample (docs/PROTOCOL.md).");
  py::enum_<StatusEvent::State>(status, "State")
      .value("STARTING", StatusEvent::State::kStarting)
      .value("READY", StatusEvent::State::kReady)
      .value("STOPPING", StatusEvent::State::kStopping);
  py::enum_<StatusEvent::Kind>(status, "Kind")
      .value("HEARTBEAT", StatusEvent::Kind::kHeartbeat)
      .value("STATE_CHANGE", StatusEvent::Kind::kStateChange)
      .value("REGISTERED", StatusEvent::Kind::kRegistered)
      .value("REMOVED", StatusEvent::Kind::kRemoved)
      .value("ERROR", StatusEvent::Kind::kError);
  status.def_readonly("service_id", &StatusEvent::service_id)
      .def_readonly("sequence_number", &StatusEvent::sequence_number)
      .def_readonly("state", &StatusEvent::state)
      .def_readonly("kind", &StatusEvent::kind)
      .def_readonly("code", &StatusEvent::code)
      .def_readonly("scene", &StatusEvent::scene)
      .def_readonly("object", &StatusEvent::object)
      .def_readonly("topology_version", &StatusEvent::topology_version)
      .def_readonly("frame", &StatusEvent::frame)
      .def_readonly("message", &StatusEvent::message)
      .def_readonly("topology_timestamp", &StatusEvent::topology_timestamp)
      .def("__repr__", [](const StatusEvent& e) {
        return "StatusEvent(service_id='" + e.service_id +
               "', state=" + std::to_string(static_cast<int>(e.state)) +
               ", kind=" + std::to_string(static_cast<int>(e.kind)) + ", code='" +
               tc::client::status_name(e.code) + "', scene='" + e.scene + "', object='" + e.object +
               "', version=" + std::to_string(e.topology_version) +
               ", frame=" + std::to_string(e.frame) +
               ", message=" + std::string(py::repr(py::str(e.message))) + ")";
      });

  using tc::client::FrameStatsEvent;
  py::class_<FrameStatsEvent>(m, "FrameStats",
                              "A FrameStats sample of the client's scene: timings in ms, counts.")
      .def_readonly("scene", &FrameStatsEvent::scene)
      .def_readonly("frame", &FrameStatsEvent::frame)
      .def_readonly("assembly_ms", &FrameStatsEvent::assembly_ms)
      .def_readonly("queue_ms", &FrameStatsEvent::queue_ms)
      .def_readonly("broad_ms", &FrameStatsEvent::broad_ms)
      .def_readonly("narrow_ms", &FrameStatsEvent::narrow_ms)
      .def_readonly("depth_ms", &FrameStatsEvent::depth_ms)
      .def_readonly("response_ms", &FrameStatsEvent::response_ms)
      .def_readonly("compute_ms", &FrameStatsEvent::compute_ms)
      .def_readonly("publish_ms", &FrameStatsEvent::publish_ms)
      .def_readonly("objects", &FrameStatsEvent::objects)
      .def_readonly("states", &FrameStatsEvent::states)
      .def_readonly("rejected", &FrameStatsEvent::rejected)
      .def_readonly("candidate_pairs", &FrameStatsEvent::candidate_pairs)
      .def_readonly("overlapping_pairs", &FrameStatsEvent::overlapping_pairs)
      .def_readonly("settled_nodes", &FrameStatsEvent::settled_nodes)
      .def_readonly("contacts", &FrameStatsEvent::contacts)
      .def_readonly("max_depth", &FrameStatsEvent::max_depth, "metres")
      .def_readonly("dropped_frames", &FrameStatsEvent::dropped_frames);

  py::class_<PyClient>(m, "Client", R"(A connection to tetcollided for the objects of one scene.

Client(scene, *, domain=0, partition='', config=None, resend_after=0.0)
  scene         every object of this client lives in this scene (non-empty)
  domain        DDS domain id, 0..232 (the service's dds.domain / --domain)
  partition     DDS partition, '' = default (must match the service's dds.partition)
  config        Cyclone DDS configuration for this domain: a path, a file:// URI or
                XML; None = the CYCLONEDDS_URI environment variable
  resend_after  seconds: wait_forces re-publishes the frame's states when no answer came
                for this long (a restarted service, a lost sample); 0 = never

A context manager: `with Client(...) as c:` closes it (the service then drops its
objects). One thread per Client; every wait releases the GIL.)")
      .def(py::init<const std::string&, std::uint32_t, const std::string&, const py::object&,
                    double>(),
           py::arg("scene"), py::kw_only(), py::arg("domain") = 0, py::arg("partition") = "",
           py::arg("config") = py::none(), py::arg("resend_after") = 0.0)
      .def(
          "__enter__", [](PyClient& c) -> PyClient& { return c; },
          py::return_value_policy::reference)
      .def("__exit__", [](PyClient& c, const py::args&) { c.close(); })
      .def("close", &PyClient::close,
           "Deletes the DDS participant: the service removes this client's objects. Idempotent.")
      .def_property_readonly("closed", &PyClient::closed)
      .def("wait_for_service", &PyClient::wait_for_service, py::arg("timeout") = 5.0,
           "Waits (seconds) for a service announcing READY. False on timeout.")
      .def("wait_for_readers", &PyClient::wait_for_readers, py::arg("count") = 1,
           py::arg("timeout") = 5.0,
           "Waits (seconds) until `count` services/recorders read this client's states.")
      .def("register", &PyClient::register_object, py::arg("object"), py::arg("nodes"),
           py::arg("tets"), py::kw_only(), py::arg("stiffness") = 1e4, py::arg("damping") = 0.0,
           py::arg("max_force") = 0.0, py::arg("static") = false, py::arg("depth") = "cpfm",
           py::arg("response") = "auto", py::arg("node_ids") = py::none(), py::arg("version") = 0,
           py::arg("friction") = 0.0, py::arg("friction_velocity") = 0.0, py::arg("blocks") = false,
           py::arg("contacts") = false, py::arg("self_contact") = false,
           R"(Publishes (or, after a cut, replaces) an object's topology; returns the version sent.

  nodes      (n, 3) float64 rest positions, metres
  tets       (m, 4) integer 0-based node indices, positively oriented
  stiffness  penalty stiffness, N/m^2;  damping: N s/m^2 (per metre of edge, as stiffness)
  max_force  cap on one node's force, N (0 = none);  static: never moves
  depth      'cpfm' | 'cffm' | 'exact';  response: 'point' | 'segment' | 'auto'
  node_ids   (n,) integer ids reported back only, or None
  version    0 = the previous version + 1 (1 the first time)
  friction   Coulomb coefficient mu >= 0 (a pair uses sqrt(mu_a mu_b); 0 = none)
  friction_velocity  m/s below which friction sticks viscously (0 = service default 1e-3)
  blocks     answers carry df/dx (stiffness) and df/dv (damping) blocks (protocol 3)
  contacts   answers carry the contacts behind the forces, ObjectForces.contacts (protocol 3)
  self_contact  contact of the object with itself: a fold, torn fragments (protocol 3)

The topology is copied once into the sample (the C++ API takes vectors). The service's
verdict comes later: wait_registered(). Raises TypeError / ValueError on bad arguments.)")
      .def("register_surface", &PyClient::register_surface, py::arg("object"), py::arg("nodes"),
           py::arg("triangles"), py::kw_only(), py::arg("stiffness") = 1e4,
           py::arg("damping") = 0.0, py::arg("max_force") = 0.0, py::arg("static") = false,
           py::arg("response") = "auto", py::arg("node_ids") = py::none(), py::arg("version") = 0,
           py::arg("friction") = 0.0, py::arg("friction_velocity") = 0.0, py::arg("blocks") = false,
           py::arg("contacts") = false,
           R"(Publishes (or replaces) a surface object's topology (docs/SURFACES.md, protocol 2).

  nodes      (n, 3) float64 rest positions, metres
  triangles  (m, 3) integer 0-based node indices (closed or open, any orientation)
  other arguments as for register() (a surface has no depth map: no `depth`)

A surface meets tet objects only: its vertices and edges inside their tets are pushed
out, the tets' nodes take the reactions. Answers and states as for register().)")
      .def("wait_registered", &PyClient::wait_registered, py::arg("object"),
           py::arg("timeout") = 5.0,
           "Waits (seconds) for the service's verdict on the object's current version.")
      .def("unregister", &PyClient::remove_object, py::arg("object"),
           "Removes an object from the scene (disposes its topology).")
      .def("version", &PyClient::version, py::arg("object"),
           "The topology version last sent for an object (0 when unknown).")
      .def("publish", &PyClient::publish, py::arg("frame"), py::arg("positions"),
           py::arg("velocities") = py::none(),
           R"(Publishes the states of one frame.

  frame       frame number >= 0 (the answer carries it)
  positions   {object: (n, 3) float64 positions, metres}, n = the registered node count
  velocities  {object: (n, 3) float64, m/s} for some of those objects, or None

A C-contiguous float64 array is read in place (borrowed while the sample is written);
any other numeric array is converted once.)")
      .def("wait_forces", &PyClient::wait_forces, py::arg("frame"), py::arg("timeout") = 1.0,
           R"(Waits (seconds, GIL released) for the answer to `frame`.

Returns a FrameForces (one ObjectForces per object published in that frame; a newer frame
when the service skipped this one: check .frame), or None on timeout. A state the service
rejected is an answer with a non-zero status (FrameForces.ok, raise_for_status()).)")
      .def("status_events", &PyClient::status_events,
           "ServiceStatus samples received since the last call (all services and scenes).")
      .def("frame_stats", &PyClient::frame_stats,
           "FrameStats samples of this client's scene received since the last call.")
      .def("poll", &PyClient::poll, py::arg("timeout") = 0.0,
           "Reads what DDS has delivered, waiting at most `timeout` seconds for the first sample.");
}
