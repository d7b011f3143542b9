/// @file data_bindings.cpp
/// numen.Data (core::Data of a scene), its read-only NumPy views, numen.step, and
/// numen._testing.step_loop (the same scripted loop in C++, for the tests and the benchmark).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <memory>
#include <stdexcept>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "numen/core/step.hpp"
#include "numen/platform/device_binding.hpp"

namespace py = pybind11;

namespace numen::python {
namespace {

// feedback_wrench / coupling_wrench are viewed as 6 contiguous doubles (force, then torque).
static_assert(sizeof(core::Wrench) == 6 * sizeof(double), "Wrench is not 6 packed doubles");
static_assert(sizeof(core::Vec3) == 3 * sizeof(double) && sizeof(core::Quat) == 4 * sizeof(double),
              "Vec3 / Quat are not packed doubles");

/// Bytes from `a` to `b` (two addresses inside one Data).
py::ssize_t byte_offset(const void* a, const void* b) {
  return static_cast<const char*>(b) - static_cast<const char*>(a);
}

/// A read-only NumPy array of `shape` over memory inside the Data of `self` starting at
/// `first`, with byte `strides` (an array of structs: the stride is the struct's size): no copy;
/// the array's base is `self` (the numen.Data), which therefore lives as long as the view.
/// Data's vectors are sized once by make_data() and never reallocated, so the view stays valid
/// and shows each new step. An empty view (a dimension 0) points at the Data itself.
template <typename T>
py::array view(const py::object& self, const T* first, std::vector<py::ssize_t> shape,
               std::vector<py::ssize_t> strides) {
  py::array a(py::dtype::of<T>(), std::move(shape), std::move(strides), first, self);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

DataHandle& handle(const py::object& self) { return self.cast<DataHandle&>(); }

/// numen.QuaternionOrderWarning (a UserWarning), made by bind_data(): an orientation given
/// without a name (read_quaternion()).
py::object& quaternion_order_warning() {
  static py::object* category = nullptr;  // the module's attribute; lives as long as the process
  if (category == nullptr) category = new py::object();
  return *category;
}

/// (n, 3) view of one Vec3 member of `n` consecutive structs of type Item, whose first
/// element's member starts at `first` (nullptr when n is 0; the view then points at `self`'s Data).
template <typename Item>
py::array vec3_rows(const py::object& self, std::size_t n, const double* first) {
  const double* p = n > 0 ? first : reinterpret_cast<const double*>(&handle(self).data);
  return view(self, p, {static_cast<py::ssize_t>(n), 3},
              {static_cast<py::ssize_t>(sizeof(Item)), sizeof(double)});
}

/// Getter of the (n, 3) view of the Vec3 `member` of every element of the Data vector `items`
/// (bodies, nodes).
template <typename Item>
auto rows_of(std::vector<Item> core::Data::*items, core::Vec3 Item::*member) {
  return [items, member](const py::object& self) {
    const std::vector<Item>& v = handle(self).data.*items;
    return vec3_rows<Item>(self, v.size(), v.empty() ? nullptr : (v[0].*member).data());
  };
}

/// Getter of the (num_contacts, 3) view of the Vec3 `member` of Data::contacts.
auto contact_rows(core::Vec3 core::Contact::*member) {
  return [member](const py::object& self) {
    const core::Data& d = handle(self).data;
    return vec3_rows<core::Contact>(self, static_cast<std::size_t>(d.num_contacts),
                                    (d.contacts[0].*member).data());
  };
}

/// Getter of the (num_node_contacts, 3) view of the Vec3 `member` of Data::node_contacts.
auto node_contact_rows(core::Vec3 core::NodeContact::*member) {
  return [member](const py::object& self) {
    const core::Data& d = handle(self).data;
    const auto n = static_cast<std::size_t>(d.num_node_contacts);
    return vec3_rows<core::NodeContact>(self, n,
                                        n > 0 ? (d.node_contacts[0].*member).data() : nullptr);
  };
}

/// Getter of the (num_node_contacts,) view of the scalar `member` (int, double or bool) of
/// Data::node_contacts, strided over core::NodeContact; with none it points at the Data itself.
template <typename T>
auto node_contact_column(T core::NodeContact::*member) {
  return [member](const py::object& self) {
    const core::Data& d = handle(self).data;
    const auto n = static_cast<py::ssize_t>(d.num_node_contacts);
    const T* first = n > 0 ? &(d.node_contacts[0].*member) : reinterpret_cast<const T*>(&d);
    return view(self, first, {n}, {static_cast<py::ssize_t>(sizeof(core::NodeContact))});
  };
}

/// The model a step argument names: a numen.Scene (its model) or a numen.Model.
/// TypeError naming `what` (the call and its argument) for anything else, e.g. an int.
const core::Model& model_of(const py::object& scene_or_model, const char* what) {
  if (py::isinstance<sim::Scene>(scene_or_model)) return scene_or_model.cast<const sim::Scene&>().model;
  if (py::isinstance<core::Model>(scene_or_model)) return scene_or_model.cast<const core::Model&>();
  throw py::type_error(std::string(what) +
                       " must be the numen.Scene (or its Scene.model) whose make_data() made the "
                       "Data, got " +
                       py::str(py::type::of(scene_or_model).attr("__name__")).cast<std::string>() +
                       " " + py::repr(scene_or_model).cast<std::string>());
}

/// The DataHandle of `data`; TypeError naming `what` when it is not a numen.Data.
DataHandle& data_arg(const py::object& data, const char* what) {
  if (!py::isinstance<DataHandle>(data))
    throw py::type_error(std::string(what) + " must be a numen.Data (Scene.make_data()), got " +
                         py::str(py::type::of(data).attr("__name__")).cast<std::string>());
  return data.cast<DataHandle&>();
}

/// core::step(model, data) after checking that `data` was made for `model` (a Data of another
/// model has other sizes: stepping it would read out of bounds).
void checked_step(const core::Model& model, DataHandle& h) {
  if (&model != h.model)
    throw py::value_error("numen.step: this Data was made for another model (use the Scene, "
                          "or Scene.model, whose make_data() made it)");
  core::step(model, h.data);
}

/// A (3,) or (4,) float vector argument into `out`; ValueError naming `what` otherwise.
void read_vector(const py::handle& arg, double* out, py::ssize_t n, const char* what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(arg);
  if (!a || a.ndim() != 1 || a.shape(0) != n)
    throw py::value_error(std::string(what) + ": expected " + std::to_string(n) + " numbers");
  for (py::ssize_t i = 0; i < n; ++i) out[i] = a.at(i);
}

/// Number of the arguments given (not None) among `args`.
int given(std::initializer_list<const py::handle*> args) {
  int n = 0;
  for (const py::handle* a : args) n += a->is_none() ? 0 : 1;
  return n;
}

/// Largest |‖q‖ − 1| of an orientation the setters take: a rounded unit quaternion typed by hand
/// (0.7071, 0, 0, 0.7071: 2e-5) passes; [1, 0, 0, 1], a zero quaternion or angles in degrees
/// do not.
constexpr double kUnitTolerance = 1e-3;

/// A quaternion argument of the Python API (docs/python.md "Quaternions"): exactly one of
/// `positional` (numen's Python order x, y, z, w), `xyzw` or `wxyz` (by name); `what` names the
/// argument in the messages. ValueError for a wrong length, none or several, a finite one that
/// is not unit (|‖q‖ − 1| > kUnitTolerance: normalise it; a non-finite one is taken as given:
/// the step flags an invalid target), and a positional one whose first component is above 1/√2
/// of its norm (read in the scene files' order (w, x, y, z) it would be a turn of less than 90°,
/// in (x, y, z, w) one of more than 90° about an axis near x: [1, 0, 0, 0] meant as the identity
/// turns a probe by 180°). Any other positional one is taken as (x, y, z, w) with a
/// numen.QuaternionOrderWarning (a UserWarning; Python shows it once per calling line): no
/// value tells the two orders apart. Otherwise taken as given (not normalised: a Python loop
/// stays bit-identical to the same loop in C++).
core::Quat read_quaternion(const py::handle& positional, const py::handle& xyzw,
                           const py::handle& wxyz, const std::string& what) {
  const int n = given({&positional, &xyzw, &wxyz});
  if (n != 1)
    throw py::value_error(what + ": give the orientation once, " +
                          (n == 0 ? std::string("as ") : std::string("either ")) +
                          "xyzw=(x, y, z, w) or wxyz=(w, x, y, z) (docs/python.md \"Quaternions\")");
  double c[4];
  core::Quat q;
  std::string form;
  if (!wxyz.is_none()) {
    read_vector(wxyz, c, 4, (what + " wxyz").c_str());
    q = core::Quat(c[0], c[1], c[2], c[3]);  // Eigen's constructor takes w, x, y, z
    form = "wxyz=";
  } else {
    read_vector(xyzw.is_none() ? positional : xyzw, q.coeffs().data(), 4, (what + " xyzw").c_str());
    form = xyzw.is_none() ? "" : "xyzw=";
  }
  const double norm = q.coeffs().norm();
  char text[480];
  if (std::isfinite(norm) && std::abs(norm - 1.0) > kUnitTolerance) {
    const double* v = form == "wxyz=" ? c : q.coeffs().data();
    std::snprintf(text, sizeof text,
                  "%s %s(%g, %g, %g, %g) is not a unit quaternion (norm %g): a rotation is one of "
                  "norm 1 (within %g); divide it by its norm (docs/python.md \"Quaternions\")",
                  what.c_str(), form.c_str(), v[0], v[1], v[2], v[3], norm, kUnitTolerance);
    throw py::value_error(text);
  }
  if (!form.empty()) return q;
  const auto turn_deg = [norm](double w) {
    return 2.0 * std::acos(std::min(1.0, std::abs(w) / norm)) * 180.0 / 3.14159265358979323846;
  };
  if (std::abs(q.x()) > norm / std::sqrt(2.0)) {
    std::snprintf(text, sizeof text,
                  "%s (%g, %g, %g, %g) given without a name is ambiguous: read as (x, y, z, w), "
                  "numen's Python order, it turns by %.1f°; read as (w, x, y, z), the scene files' "
                  "order, by %.1f°. Pass it by name: xyzw=... or wxyz=... (docs/python.md "
                  "\"Quaternions\")",
                  what.c_str(), q.x(), q.y(), q.z(), q.w(), turn_deg(q.w()), turn_deg(q.x()));
    throw py::value_error(text);
  }
  std::snprintf(text, sizeof text,
                "%s (%g, %g, %g, %g) given without a name is read as (x, y, z, w), numen's Python "
                "order (a turn of %.1f°; as (w, x, y, z), the scene files' order, it would turn by "
                "%.1f°): pass it by name, xyzw=... or wxyz=... (docs/python.md \"Quaternions\")",
                what.c_str(), q.x(), q.y(), q.z(), q.w(), turn_deg(q.w()), turn_deg(q.x()));
  if (PyErr_WarnEx(quaternion_order_warning().ptr(), text, 1) != 0) throw py::error_already_set();
  return q;
}

/// A body argument: its index or its name (Model.body_names); ValueError otherwise.
int body_arg(const core::Model& model, const py::handle& body) {
  if (py::isinstance<py::str>(body)) {
    const std::string name = body.cast<std::string>();
    for (int b = 0; b < model.num_bodies(); ++b)
      if (model.bodies[static_cast<std::size_t>(b)].name == name) return b;
    throw py::value_error("no body named '" + name + "' (Model.body_names)");
  }
  const int b = body.cast<int>();
  if (b < 0 || b >= model.num_bodies())
    throw py::value_error("body " + std::to_string(b) + " out of range [0, " +
                          std::to_string(model.num_bodies()) + ")");
  return b;
}

/// Data.held_body = body: -1 (none), a body index or a body name; ValueError naming `what`
/// otherwise (core::set_held_body() turns an out-of-range index into none: the instrument would
/// be dropped without a word).
void set_held(DataHandle& h, const py::handle& body, const char* what) {
  if (py::isinstance<py::str>(body)) {
    core::set_held_body(*h.model, h.data, body_arg(*h.model, body));
    return;
  }
  // Any integer (int, numpy.int64, ...: __index__), not a float or a bool.
  PyObject* index = py::isinstance<py::bool_>(body) ? nullptr : PyNumber_Index(body.ptr());
  if (index == nullptr) {
    PyErr_Clear();
    throw py::type_error(std::string(what) +
                         " must be a body index, a body name or -1 (none), got " +
                         py::str(py::type::of(body).attr("__name__")).cast<std::string>());
  }
  const auto v = py::reinterpret_steal<py::int_>(index);
  if (!(v.equal(py::int_(-1)) || (v >= py::int_(0) && v < py::int_(h.model->num_bodies()))))
    throw py::value_error(std::string(what) + " must be -1 (none) or a body index in [0, " +
                          std::to_string(h.model->num_bodies()) + ") (Model.body_names), got " +
                          py::str(body).cast<std::string>());
  core::set_held_body(*h.model, h.data, v.cast<int>());
}

/// A prescribed joint argument: its index or its name (Model.joint_names); ValueError for
/// another joint or none.
int prescribed_joint_arg(const core::Model& model, const py::handle& joint) {
  int j = -1;
  if (py::isinstance<py::str>(joint)) {
    const std::string name = joint.cast<std::string>();
    for (int k = 0; k < model.num_joints() && j < 0; ++k)
      if (model.joints[static_cast<std::size_t>(k)].name == name) j = k;
    if (j < 0) throw py::value_error("no joint named '" + name + "' (Model.joint_names)");
  } else {
    j = joint.cast<int>();
    if (j < 0 || j >= model.num_joints())
      throw py::value_error("joint " + std::to_string(j) + " out of range [0, " +
                            std::to_string(model.num_joints()) + ")");
  }
  const core::JointModel& jm = model.joints[static_cast<std::size_t>(j)];
  if (!jm.prescribed)
    throw py::value_error("joint '" + jm.name + "' is not prescribed (scene key `prescribed`): "
                          "the solve sets its coordinate");
  return j;
}

/// The target pose and twist of the set_*target methods (position (3,), the orientation by
/// read_quaternion(), optional velocities (3,), zero by default).
void read_target(const py::handle& position, const py::handle& orientation,
                 const py::handle& xyzw, const py::handle& wxyz,
                 const py::handle& linear_velocity, const py::handle& angular_velocity,
                 core::Pose& pose, core::Twist& twist) {
  read_vector(position, pose.position.data(), 3, "position");
  pose.orientation = read_quaternion(orientation, xyzw, wxyz, "orientation");
  twist = core::Twist{};
  if (!linear_velocity.is_none()) read_vector(linear_velocity, twist.linear.data(), 3, "linear_velocity");
  if (!angular_velocity.is_none())
    read_vector(angular_velocity, twist.angular.data(), 3, "angular_velocity");
}

/// The DataHandle's sim::InstrumentTargets, made on first use.
const sim::InstrumentTargets& instrument_of(DataHandle& h) {
  if (!h.instrument) h.instrument = std::make_unique<sim::InstrumentTargets>(*h.scene);
  return *h.instrument;
}

/// An instrument sample from Python arguments: the tool frame's world position (3,) m and its
/// orientation by name, xyzw= or wxyz= (read_quaternion()); jaw 0.
sim::TrajectorySample tool_sample(const py::handle& position, const py::handle& xyzw,
                                  const py::handle& wxyz) {
  sim::TrajectorySample s;
  read_vector(position, s.pose.position.data(), 3, "position");
  s.pose.orientation = read_quaternion(py::none(), xyzw, wxyz, "orientation");
  return s;
}

/// What `pose_of` (sim::InstrumentTargets::held_body_target or tool_in_held_body) gives for the
/// sample `s` on `h`'s data, as (position (3,), orientation (4,) x y z w) copies. ValueError
/// naming `what` when it gives none (no body held, or no link of the device drives it).
py::tuple held_body_pose(DataHandle& h, const sim::TrajectorySample& s,
                         bool (sim::InstrumentTargets::*pose_of)(const sim::TrajectorySample&,
                                                                 const core::Data&, core::Pose&)
                             const noexcept,
                         const char* what) {
  core::Pose pose;
  if (!(instrument_of(h).*pose_of)(s, h.data, pose))
    throw py::value_error(std::string(what) +
                          ": no body is held (held_body -1) or no link of the device drives it");
  return py::make_tuple(py::array_t<double>(3, pose.position.data()),
                        py::array_t<double>(4, pose.orientation.coeffs().data()));
}

/// The scripted loop of the tests and of the benchmark (docs/python.md), in C++: `steps` times,
/// every target from the scene trajectory's sample at data.time through the device
/// (sim::InstrumentTargets::set_at: the held body's centre-of-mass frame, not the tip; Python's
/// Data.set_targets_at()), then core::step. Returns
/// copies of the end state, the wall time of the loop and the summed time of the step calls
/// (each bracketed by steady_clock, like the step_time benchmark's manual timing).
py::dict step_loop(const sim::Scene& scene, std::int64_t steps) {
  core::Data data = core::make_data(scene.model);
  const sim::InstrumentTargets targets(scene);
  using Clock = std::chrono::steady_clock;
  Clock::duration in_step{};
  const Clock::time_point t0 = Clock::now();
  for (std::int64_t k = 0; k < steps; ++k) {
    targets.set_at(scene.trajectory, data.time, data);
    const Clock::time_point s0 = Clock::now();
    core::step(scene.model, data);
    in_step += Clock::now() - s0;
  }
  const Clock::time_point t1 = Clock::now();
  const auto n = static_cast<py::ssize_t>(data.bodies.size());
  py::array_t<double> pos({n, py::ssize_t{3}}), quat({n, py::ssize_t{4}}),
      lin({n, py::ssize_t{3}}), ang({n, py::ssize_t{3}});
  for (py::ssize_t i = 0; i < n; ++i) {
    const core::BodyState& b = data.bodies[static_cast<std::size_t>(i)];
    for (int c = 0; c < 3; ++c) {
      pos.mutable_at(i, c) = b.position[c];
      lin.mutable_at(i, c) = b.linear_velocity[c];
      ang.mutable_at(i, c) = b.angular_velocity[c];
    }
    for (int c = 0; c < 4; ++c) quat.mutable_at(i, c) = b.orientation.coeffs()[c];
  }
  const auto nn = static_cast<py::ssize_t>(data.nodes.size());
  py::array_t<double> nodes({nn, py::ssize_t{3}});
  for (py::ssize_t i = 0; i < nn; ++i)
    for (int c = 0; c < 3; ++c) nodes.mutable_at(i, c) = data.nodes[static_cast<std::size_t>(i)].position[c];
  py::array_t<double> feedback(6);
  for (int c = 0; c < 3; ++c) {
    feedback.mutable_at(c) = data.feedback_wrench.force[c];
    feedback.mutable_at(c + 3) = data.feedback_wrench.torque[c];
  }
  py::dict out;
  out["time"] = data.time;
  out["step_count"] = data.step_count;
  out["body_positions"] = pos;
  out["body_orientations"] = quat;
  out["body_linear_velocities"] = lin;
  out["body_angular_velocities"] = ang;
  out["node_positions"] = nodes;
  out["feedback_wrench"] = feedback;
  out["num_contacts"] = data.num_contacts;
  out["wall_s"] = std::chrono::duration<double>(t1 - t0).count();
  out["step_s"] = std::chrono::duration<double>(in_step).count();
  return out;
}

}  // namespace

void bind_data(py::module_& m) {
  py::class_<DataHandle>(
      m, "Data",
      "All mutable state of a scene (core::Data), made by Scene.make_data(). Inputs are set "
      "with set_target() / held_body; step() advances model.dt. The array properties are "
      "read-only NumPy views of this Data's memory (no copy; the Data is their base and lives "
      "as long as they do): a view taken once shows the values of every later step. Contact "
      "views cover the contacts of the last step at the time they are taken. SI units, world "
      "frame; quaternions (x, y, z, w), body to world; rows in body index order "
      "(Model.body_names).")
      .def("step", [](py::object self, const py::object& scene_or_model) {
             checked_step(model_of(scene_or_model, "Data.step(scene_or_model): scene_or_model"),
                          handle(self));
           },
           py::arg("scene_or_model"),
           "Advances the state by model.dt (core::step: contacts, forces, implicit solve, "
           "feedback, non-finite checks). The Scene or Model must be the one whose make_data() "
           "made this Data (ValueError for another's, TypeError for anything else). Never fails "
           "otherwise: problems are status bits.")
      .def("reset", [](DataHandle& h) { core::reset_data(*h.model, h.data); },
           "Back to the initial state (core::reset_data): bodies at their initial pose and "
           "twist, inputs, outputs and counters cleared, device on the initial held body.")
      .def(
          "set_target",
          [](DataHandle& h, const py::handle& position, const py::handle& orientation,
             const py::handle& linear_velocity, const py::handle& angular_velocity,
             const py::handle& xyzw, const py::handle& wxyz) {
            if (h.data.held_body < 0)
              throw py::value_error("set_target: no body is held (held_body is -1): the "
                                    "target would drive nothing; set data.held_body first");
            core::Pose pose;
            core::Twist twist;
            read_target(position, orientation, xyzw, wxyz, linear_velocity, angular_velocity,
                        pose, twist);
            h.data.target = pose;
            h.data.target_twist = twist;
          },
          py::arg("position"), py::arg("orientation") = py::none(),
          py::arg("linear_velocity") = py::none(), py::arg("angular_velocity") = py::none(),
          py::kw_only(), py::arg("xyzw") = py::none(), py::arg("wxyz") = py::none(),
          "Sets the device target of the held body's centre-of-mass frame (Data::target, "
          "target_twist; world) — not the instrument's tool frame that Scene.target_at gives "
          "(set_targets_at / set_tool_sample turn that into this target): position (3,) m, the "
          "orientation once, as a unit quaternion: `orientation` (x, y, z, w), or by name "
          "xyzw=(x, y, z, w) or wxyz=(w, x, y, z) (the scene files' order); a positional one "
          "whose x is above 1/√2 of its norm is refused as ambiguous, any other positional one "
          "warns (numen.QuaternionOrderWarning; docs/python.md \"Quaternions\"); linear "
          "velocity (3,) m/s and angular velocity (3,) rad/s (default zero). Values are taken "
          "as given: a non-finite target makes the next step skip the coupling, hold the "
          "feedback, set STATUS_INVALID_TARGET and count invalid_target_steps. ValueError for "
          "a wrong length, an orientation given twice, none, ambiguous or finite but not unit "
          "(|norm - 1| > 1e-3), or no held body (held_body -1).")
      .def(
          "set_body_target",
          [](DataHandle& h, const py::handle& body, const py::handle& position,
             const py::handle& linear_velocity, const py::handle& angular_velocity,
             const py::handle& xyzw, const py::handle& wxyz) {
            const int b = body_arg(*h.model, body);
            core::Pose pose;
            core::Twist twist;
            read_target(position, py::none(), xyzw, wxyz, linear_velocity, angular_velocity,
                        pose, twist);
            platform::set_body_target(h.data, b, pose, twist);
          },
          py::arg("body"), py::arg("position"), py::arg("linear_velocity") = py::none(),
          py::arg("angular_velocity") = py::none(), py::kw_only(), py::arg("xyzw") = py::none(),
          py::arg("wxyz") = py::none(),
          "Sets body `body`'s own coupling target (paper Eq. 6; index or name of "
          "Model.body_names): its centre-of-mass frame's pose, position (3,) m and orientation "
          "by name, xyzw=(x, y, z, w) or wxyz=(w, x, y, z), and twist (m/s, rad/s; default "
          "zero), world. The held body's is Data::target (as set_target); any other's is its "
          "enabled Data::body_targets entry: its spring acts and its Eq. 8 wrench joins the "
          "feedback (carried to the held body's target point) until clear_body_target.")
      .def(
          "clear_body_target",
          [](DataHandle& h, const py::handle& body) {
            const int b = body_arg(*h.model, body);
            h.data.body_targets[static_cast<std::size_t>(b)] = core::BodyTarget{};
          },
          py::arg("body"),
          "Disables body `body`'s own target (Data::body_targets): left to the simulation (the "
          "held body's Data::target is not affected).")
      .def_property_readonly(
          "body_targets_enabled",
          [](const DataHandle& h) {
            std::vector<bool> on;
            for (const core::BodyTarget& t : h.data.body_targets) on.push_back(t.enabled);
            return on;
          },
          "Per body (list of bool, a copy): its own target is enabled (Data::body_targets).")
      .def(
          "set_joint_prescribed",
          [](DataHandle& h, const py::handle& joint, double value, double rate) {
            const int j = prescribed_joint_arg(*h.model, joint);
            h.data.joint_prescribed[static_cast<std::size_t>(j)] = core::JointPrescription{value, rate};
          },
          py::arg("joint"), py::arg("value"), py::arg("rate") = 0.0,
          "Imposes prescribed joint `joint`'s coordinate (index or name of Model.joint_names; "
          "the scene's `prescribed` joints, e.g. the default scene's jaw hinges): value (rad "
          "for a revolute, m for a prismatic) and rate (per s); the step aims at value + dt · "
          "rate (Data::joint_prescribed). ValueError for a joint that is not prescribed.")
      .def(
          "grasp",
          [](const DataHandle& h, int index) {
            if (index < 0 || index >= h.model->num_grasps())
              throw py::index_error("no grasper " + std::to_string(index) + " (Model.grasp_names has " +
                                    std::to_string(h.model->num_grasps()) + ")");
            const core::GraspState& g = h.data.grasps[static_cast<std::size_t>(index)];
            py::list nodes;
            for (int k = 0; k < g.num_nodes; ++k) nodes.append(g.nodes[static_cast<std::size_t>(k)].node);
            py::dict out;
            out["holding"] = g.holding();
            out["body"] = g.body;
            out["net"] = g.net;
            out["nodes"] = nodes;
            out["points"] = g.num_points;
            py::list thread_nodes;
            for (int k = 0; k < g.num_thread_nodes; ++k) thread_nodes.append(g.thread_nodes[static_cast<std::size_t>(k)].node);
            out["thread"] = g.thread;
            out["thread_nodes"] = thread_nodes;
            out["opening"] = g.opening;
            out["event"] = core::to_string(g.event);
            out["started"] = g.started;
            out["grip_force"] = g.grip_force;
            out["armed"] = g.armed;
            out["grasps"] = g.grasps;
            out["releases"] = g.releases;
            out["slips"] = g.slips;
            return out;
          },
          py::arg("index"),
          "Grasper `index`'s state after the last step (core::GraspState, docs/grasping.md), a "
          "dict (a copy): holding (bool); body (the held body, -1) or net (the net whose tissue "
          "is held, -1) and nodes (its held global node indices); points (the grip's springs on "
          "a held body); thread (the held thread, -1) and thread_nodes (its held node indices in "
          "the thread); opening (rad, the jaws' |q1 - q2|); event ('none', 'grasp', 'release', "
          "'slip': this step's); started (s, the current grasp's start); grip_force (N, the "
          "springs' net pull at the last step's start); armed; grasps, releases, slips (counts "
          "since reset). IndexError for an index outside Model.grasp_names.")
      .def_property_readonly(
          "joint_prescribed",
          [](const DataHandle& h) {
            py::array_t<double> rows({static_cast<py::ssize_t>(h.data.joint_prescribed.size()),
                                      py::ssize_t{2}});
            for (std::size_t j = 0; j < h.data.joint_prescribed.size(); ++j) {
              rows.mutable_at(static_cast<py::ssize_t>(j), 0) = h.data.joint_prescribed[j].value;
              rows.mutable_at(static_cast<py::ssize_t>(j), 1) = h.data.joint_prescribed[j].rate;
            }
            return rows;
          },
          "(J, 2) copy: per joint, the imposed (value, rate) of Data::joint_prescribed (read "
          "for prescribed joints only).")
      .def(
          "set_targets_at",
          [](DataHandle& h, std::optional<double> t) {
            if (const sim::InputError* e = missing_part(*h.scene, "trajectory")) throw *e;
            instrument_of(h).set_at(h.scene->trajectory,
                                    t ? finite_time(*t, "Data.set_targets_at: t") : h.data.time,
                                    h.data);
          },
          py::arg("t") = py::none(),
          "Sets every target the scene's device drives from its trajectory at time t (s; "
          "None: data.time), as `numen run`'s control loop does from the encoders "
          "(sim::InstrumentTargets): the trajectory's sample (the instrument's tool frame, "
          "Scene.target_at: the tip and the jaw) goes through the device's kinematics (the "
          "trocar, tool_offset) to the links, each linked body's target is its link's pose · "
          "link_offset (the held body's Data::target, the others' body targets) and each "
          "prescribed joint gets its axis (the jaw); the rates are the difference to the "
          "sample a trajectory period later. Raises InputError for a scene without "
          "[trajectory], ValueError for a t that is not finite.")
      .def(
          "set_tool_sample",
          [](DataHandle& h, const py::handle& position, const py::handle& xyzw,
             const py::handle& wxyz, double jaw) {
            sim::TrajectorySample s = tool_sample(position, xyzw, wxyz);
            s.jaw = jaw;
            instrument_of(h).set(s, h.data);
          },
          py::arg("position"), py::kw_only(), py::arg("xyzw") = py::none(),
          py::arg("wxyz") = py::none(), py::arg("jaw") = 0.0,
          "Sets every target the scene's device drives from one instrument sample, as "
          "set_targets_at does from the trajectory's: the world pose of the instrument's tool "
          "frame (trocar instrument: the tip, z along the shaft; pose tracker: the tracked "
          "frame), position (3,) m and orientation by name, xyzw=(x, y, z, w) or "
          "wxyz=(w, x, y, z), and the jaw opening (rad). The targets are at rest (zero "
          "rates). A scene without [device] has the identity pose tracker: the sample is the "
          "held body's centre-of-mass target.")
      .def(
          "tool_to_body",
          [](DataHandle& h, const py::handle& position, const py::handle& xyzw,
             const py::handle& wxyz) {
            return held_body_pose(h, tool_sample(position, xyzw, wxyz),
                                  &sim::InstrumentTargets::held_body_target, "tool_to_body");
          },
          py::arg("position"), py::kw_only(), py::arg("xyzw") = py::none(),
          py::arg("wxyz") = py::none(),
          "The held body's centre-of-mass pose for an instrument tool-frame pose (the frame of "
          "Scene.target_at: a trocar instrument's tip), world: (position (3,) m, orientation "
          "(4,) x y z w), copies — the pose to give set_target when you have the tip "
          "(sim::InstrumentTargets::held_body_target: through the device's kinematics, "
          "tool_offset and the body's link_offset, as set_tool_sample sets it). The tool pose: "
          "position (3,) m, orientation by name, xyzw= or wxyz=. Sets nothing. ValueError "
          "without a held body.")
      .def(
          "tool_in_held_body",
          [](DataHandle& h, const py::handle& position, const py::handle& xyzw,
             const py::handle& wxyz) {
            return held_body_pose(h, tool_sample(position, xyzw, wxyz),
                                  &sim::InstrumentTargets::tool_in_held_body, "tool_in_held_body");
          },
          py::arg("position"), py::kw_only(), py::arg("xyzw") = py::none(),
          py::arg("wxyz") = py::none(),
          "The instrument's tool frame (its tip) in the held body's centre-of-mass frame when "
          "the tool is at the given world pose: (position (3,) m, orientation (4,) x y z w), "
          "body frame, copies (sim::InstrumentTargets::tool_in_held_body). The tip's offset "
          "from the centre of mass: (0, 0, 0.04) on the lattice scene's tube, zero on "
          "probe.toml. ValueError without a held body.")
      .def_property(
          "held_body", [](const DataHandle& h) { return h.data.held_body; },
          [](DataHandle& h, const py::handle& body) { set_held(h, body, "held_body"); },
          "Body the device drives (-1: none); set it to a body index or name (Model.body_names) "
          "or -1 to let go (core::set_held_body: tool switching). ValueError for an index out "
          "of range or an unknown name (core::set_held_body alone would let go of the body).")
      .def_property(
          "attached_body", [](const DataHandle& h) { return h.data.held_body; },
          [](DataHandle& h, const py::handle& body) { set_held(h, body, "attached_body"); },
          "Alias of held_body, kept for existing scripts.")
      .def_property_readonly("time", [](const DataHandle& h) { return h.data.time; },
                             "Simulated time (s).")
      .def_property_readonly("step_count", [](const DataHandle& h) { return h.data.step_count; })
      .def_property_readonly("status", [](const DataHandle& h) { return h.data.status; },
                             "StepStatus bits of the last step (numen.STATUS_*; 0: ok).")
      .def_property_readonly("nonfinite_steps",
                             [](const DataHandle& h) { return h.data.nonfinite_steps; },
                             "Steps whose result was rejected as non-finite (rolled back).")
      .def_property_readonly(
          "invalid_target_steps", [](const DataHandle& h) { return h.data.invalid_target_steps; },
          "Steps since reset whose device target was not finite (STATUS_INVALID_TARGET): "
          "coupling skipped, feedback held at its last value (docs/safety.md).")
      .def_property_readonly("num_contacts", [](const DataHandle& h) { return h.data.num_contacts; },
                             "Contacts C of the last step.")
      .def_property_readonly("max_penetration",
                             [](const DataHandle& h) { return h.data.max_penetration; },
                             "Deepest contact of the last step (m).")
      .def_property_readonly("solver_iterations",
                             [](const DataHandle& h) { return h.data.solver_iterations; },
                             "Iterations of the implicit solve in the last step.")
      .def_property_readonly(
          "target_position",
          [](py::object self) {
            const core::Data& d = handle(self).data;
            return view(self, d.target.position.data(), {3}, {sizeof(double)});
          },
          "View (3,) of the device target position (m, world).")
      .def_property_readonly(
          "target_orientation",
          [](py::object self) {
            const core::Data& d = handle(self).data;
            return view(self, d.target.orientation.coeffs().data(), {4}, {sizeof(double)});
          },
          "View (4,) of the device target orientation (x, y, z, w).")
      .def_property_readonly(
          "body_positions", rows_of(&core::Data::bodies, &core::BodyState::position),
          "View (B, 3) of the bodies' COM positions (m, world); strided over core::BodyState.")
      .def_property_readonly(
          "body_orientations",
          [](py::object self) {
            const core::Data& d = handle(self).data;
            const double* p = d.bodies.empty() ? reinterpret_cast<const double*>(&d)
                                               : d.bodies[0].orientation.coeffs().data();
            return view(self, p, {static_cast<py::ssize_t>(d.bodies.size()), 4},
                        {sizeof(core::BodyState), sizeof(double)});
          },
          "View (B, 4) of the bodies' orientations, unit quaternions (x, y, z, w), body to world.")
      .def_property_readonly(
          "body_linear_velocities", rows_of(&core::Data::bodies, &core::BodyState::linear_velocity),
          "View (B, 3) of the COM linear velocities (m/s, world).")
      .def_property_readonly(
          "body_angular_velocities", rows_of(&core::Data::bodies, &core::BodyState::angular_velocity),
          "View (B, 3) of the angular velocities (rad/s, world frame).")
      .def_property_readonly(
          "node_positions", rows_of(&core::Data::nodes, &core::NodeState::position),
          "View (N, 3) of the net nodes' positions (m, world); (0, 3) without nets (or in a "
          "build without deformable nets).")
      .def_property_readonly(
          "node_velocities", rows_of(&core::Data::nodes, &core::NodeState::velocity),
          "View (N, 3) of the net nodes' velocities (m/s, world).")
      .def_property_readonly(
          "feedback_wrench",
          [](py::object self) {
            const core::Data& d = handle(self).data;
            return view(self, d.feedback_wrench.force.data(), {6}, {sizeof(double)});
          },
          "View (6,) of the device feedback: force (N) then torque (N·m), world, about the "
          "held body's target point; saturated (paper Eq. 8-9).")
      .def_property_readonly(
          "coupling_wrench",
          [](py::object self) {
            const core::Data& d = handle(self).data;
            return view(self, d.coupling_wrench.force.data(), {6}, {sizeof(double)});
          },
          "View (6,) of the coupling (Eq. 2) on the held body: force (N), torque (N·m) at "
          "its COM, world.")
      .def_property_readonly(
          "contact_points", contact_rows(&core::Contact::position),
          "View (C, 3) of the last step's contact points (m, world), C = num_contacts when "
          "taken; strided over core::Contact.")
      .def_property_readonly(
          "contact_normals", contact_rows(&core::Contact::normal),
          "View (C, 3) of the contact normals (unit, from body_b/obstacle towards body_a).")
      .def_property_readonly(
          "contact_forces", contact_rows(&core::Contact::force),
          "View (C, 3) of the penalty forces on body_a (N, world); -force on body_b.")
      .def_property_readonly(
          "contact_depths",
          [](py::object self) {
            const core::Data& d = handle(self).data;
            return view(self, &d.contacts[0].depth, {static_cast<py::ssize_t>(d.num_contacts)},
                        {static_cast<py::ssize_t>(sizeof(core::Contact))});
          },
          "View (C,) of the penetration depths (m, > 0).")
      .def_property_readonly(
          "contact_bodies",
          [](py::object self) {
            const core::Data& d = handle(self).data;
            return view(self, &d.contacts[0].body_a, {static_cast<py::ssize_t>(d.num_contacts), 2},
                        {static_cast<py::ssize_t>(sizeof(core::Contact)),
                         byte_offset(&d.contacts[0].body_a, &d.contacts[0].body_b)});
          },
          "View (C, 2) int of (body_a, body_b) per contact: body_a receives +force; body_b the "
          "other body (-force), or -1 when body_a touches a static obstacle (then "
          "contact_obstacles names it).")
      .def_property_readonly(
          "contact_obstacles",
          [](py::object self) {
            const core::Data& d = handle(self).data;
            return view(self, &d.contacts[0].obstacle, {static_cast<py::ssize_t>(d.num_contacts)},
                        {static_cast<py::ssize_t>(sizeof(core::Contact))});
          },
          "View (C,) int per contact: the static obstacle's index (row of "
          "Model.obstacle_names) where body_b is -1, else -1 (core::Contact::obstacle).")
      // The nets' node contacts (core::NodeContact, net_state.hpp): a node sphere's contact, or
      // one node's share of a surface triangle's contact (docs/organs.md "Surface contacts").
      .def_property_readonly(
          "num_node_contacts", [](const DataHandle& h) { return h.data.num_node_contacts; },
          "Node contacts K of the last step (0 without nets).")
      .def_property_readonly(
          "node_contact_nodes", node_contact_column(&core::NodeContact::node),
          "View (K,) int of the node receiving +force (global node index); strided over "
          "core::NodeContact, K = num_node_contacts when taken.")
      .def_property_readonly(
          "node_contact_bodies", node_contact_column(&core::NodeContact::body_b),
          "View (K,) int of the body receiving -force, -1 for a static obstacle.")
      .def_property_readonly(
          "node_contact_obstacles", node_contact_column(&core::NodeContact::obstacle),
          "View (K,) int of the obstacle index where the body is -1, else -1.")
      .def_property_readonly(
          "node_contact_points", node_contact_rows(&core::NodeContact::position),
          "View (K, 3) of the contact points (m, world): the middle of the overlap.")
      .def_property_readonly(
          "node_contact_normals", node_contact_rows(&core::NodeContact::normal),
          "View (K, 3) of the unit normals, from the body/obstacle towards the node.")
      .def_property_readonly(
          "node_contact_forces", node_contact_rows(&core::NodeContact::force),
          "View (K, 3) of the penalty force on the node (N, world; a triangle contact: this "
          "node's share); -force on the body.")
      .def_property_readonly(
          "node_contact_depths", node_contact_column(&core::NodeContact::depth),
          "View (K,) of the penetration depths (m, > 0).")
      .def_property_readonly(
          "node_contact_active", node_contact_column(&core::NodeContact::active),
          "View (K,) bool: the contact law acts (f_n > 0, or engaged by a look-ahead).")
      .def_property_readonly(
          "node_contact_faces", node_contact_column(&core::NodeContact::face),
          "View (K,) int: a surface triangle's contact, its triangle (row of Model.net_faces); "
          "-1 for a node sphere's contact.")
      .def_property_readonly(
          "node_contact_face_weights", node_contact_rows(&core::NodeContact::face_weights),
          "View (K, 3) of the barycentric weights of the closest point on the triangle, one per "
          "node of Model.net_faces[face] in its order (each >= 0, sum 1); 0 where face is -1.")
      .def_property_readonly(
          "node_contact_shares", node_contact_column(&core::NodeContact::share),
          "View (K,) of this node's weight among face_weights (1 for a node sphere's contact).");

  m.def("step", [](const py::object& model, py::object data) {
          checked_step(model_of(model, "numen.step(model, data): model"),
                       data_arg(data, "numen.step(model, data): data"));
        },
        py::arg("model"), py::arg("data"),
        "numen.step(model, data): data.step(model) (core::step), model a Model or a Scene.");

  py::class_<sim::FeedbackRamp>(
      m, "FeedbackRamp",
      "The device's soft start for a loop that steps the scene itself and renders "
      "Data.feedback_wrench (sim::FeedbackRamp; docs/python.md \"Soft start\"): `numen run`'s "
      "device ramps its torques in over [device] soft_start (0.1 s by default), core::step does "
      "not. After each step, apply(data) gives the wrench to render: (1 - r) w_from + r "
      "feedback_wrench, r = min(1, k dt / soft_start), k the steps since the ramp began; w_from "
      "zero at start-up, the held wrench after an invalid-target dropout.")
      .def(py::init([](const sim::Scene& scene, std::optional<double> soft_start) {
             if (!soft_start) return sim::FeedbackRamp(scene);
             if (!std::isfinite(*soft_start) || *soft_start < 0.0)
               throw py::value_error("FeedbackRamp: soft_start must be a finite number of "
                                     "seconds >= 0, got " + sim::format_input_number(*soft_start));
             return sim::FeedbackRamp(*soft_start, scene.model.dt);
           }),
           py::arg("scene"), py::arg("soft_start") = py::none(),
           "The ramp of `scene` (its dt), over soft_start s (None: the scene's [device] "
           "soft_start, 0.1 s unless it says; 0: off).")
      .def(
          "apply",
          [](sim::FeedbackRamp& r, const py::object& data) {
            const core::Wrench w = r.apply(data_arg(data, "FeedbackRamp.apply(data): data").data);
            py::array_t<double> out(6);
            for (int c = 0; c < 3; ++c) {
              out.mutable_at(c) = w.force[c];
              out.mutable_at(c + 3) = w.torque[c];
            }
            return out;
          },
          py::arg("data"),
          "Call once after each step: the wrench to render (6,) copy, force (N) then torque "
          "(N·m), world, as Data.feedback_wrench.")
      .def("restart", &sim::FeedbackRamp::restart,
           "Starts the ramp again from zero (a re-arm, or after Data.reset()).")
      .def_property_readonly("ramp", &sim::FeedbackRamp::ramp,
                             "The factor r of the last apply() (1: ramp over or off).");

  quaternion_order_warning() = py::reinterpret_steal<py::object>(PyErr_NewExceptionWithDoc(
      "numen.QuaternionOrderWarning",
      "An orientation was given to a numen.Data setter without a name: it is read as (x, y, z, "
      "w), numen's Python order, and may have been meant as (w, x, y, z), the scene files' "
      "order. Pass it as xyzw=... or wxyz=... (docs/python.md \"Quaternions\"); "
      "warnings.simplefilter('error', numen.QuaternionOrderWarning) makes it an error.",
      PyExc_UserWarning, nullptr));
  if (!quaternion_order_warning()) throw py::error_already_set();
  m.attr("QuaternionOrderWarning") = quaternion_order_warning();
  m.attr("STATUS_CONTACT_OVERFLOW") = static_cast<std::uint32_t>(core::kContactOverflow);
  m.attr("STATUS_NON_FINITE") = static_cast<std::uint32_t>(core::kNonFinite);
  m.attr("STATUS_SOLVER_NOT_CONVERGED") = static_cast<std::uint32_t>(core::kSolverNotConverged);
  m.attr("STATUS_INVALID_TARGET") = static_cast<std::uint32_t>(core::kInvalidTarget);

  py::module_ testing = m.def_submodule(
      "_testing", "Helpers of the tests and the benchmark (not API).");
  testing.def("step_loop", &step_loop, py::arg("scene"), py::arg("steps"),
              "The scripted loop in C++: `steps` times, the targets from the scene's trajectory "
              "at data.time as Data.set_targets_at() sets them, then core::step, on a new Data. Returns a dict of copies of the end "
              "state (same keys as the Data views), wall_s, the loop's wall time (s), and step_s, the "
              "sum of the steady-clock time of each core::step call (s).");
}

}  // namespace numen::python
