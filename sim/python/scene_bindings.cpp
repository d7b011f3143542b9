/// @file scene_bindings.cpp
/// numen.InputError, numen.load_scene, numen.default_scene_path, numen.Scene, numen.Model.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <exception>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "numen/sim/scene/scene_info.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/input/shipped_files.hpp"

namespace py = pybind11;

namespace numen::python {
namespace {

/// A NumPy copy of a 3-vector or of a quaternion as (x, y, z, w) (Eigen's coefficient order).
py::array_t<double> to_array(const core::Vec3& v) { return py::array_t<double>(3, v.data()); }
py::array_t<double> to_array(const core::Quat& q) {
  return py::array_t<double>(4, q.coeffs().data());
}

/// An (F, 3) NumPy copy of triangles given as index triples (Model::net_faces,
/// Model::net_surface_faces).
py::array_t<int> triangle_rows(const std::vector<std::array<int, 3>>& triangles) {
  py::array_t<int> rows({static_cast<py::ssize_t>(triangles.size()), py::ssize_t{3}});
  for (std::size_t f = 0; f < triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) rows.mutable_at(static_cast<py::ssize_t>(f), k) = triangles[f][static_cast<std::size_t>(k)];
  return rows;
}

/// A (P, 3) NumPy copy of one Vec3 member of every Model::net_surface_points entry (its weights
/// or its offset), in order.
py::array_t<double> surface_point_rows(const core::Model& mo, core::Vec3 core::NetSurfacePoint::*member) {
  py::array_t<double> rows({static_cast<py::ssize_t>(mo.net_surface_points.size()), py::ssize_t{3}});
  for (std::size_t i = 0; i < mo.net_surface_points.size(); ++i)
    for (int k = 0; k < 3; ++k) rows.mutable_at(static_cast<py::ssize_t>(i), k) = (mo.net_surface_points[i].*member)[k];
  return rows;
}

}  // namespace

std::filesystem::path module_data_dir() {
#ifndef NUMEN_DATA_FROM_MODULE
#define NUMEN_DATA_FROM_MODULE "../../../share/numen"
#endif
  const std::string file = py::module_::import("numen").attr("__file__").cast<std::string>();
  return sim::shipped_data_dir_from(std::filesystem::path(file).parent_path(), NUMEN_DATA_FROM_MODULE);
}

double finite_time(double t, const char* what) {
  if (!std::isfinite(t))
    throw py::value_error(std::string(what) + " must be a finite time in seconds, got " +
                          sim::format_input_number(t));
  return t;
}

const sim::InputError* missing_part(const sim::Scene& scene, const char* part) {
  for (const sim::InputError& e : scene.run_missing)
    if (e.key() == part) return &e;
  return nullptr;
}

void bind_scene(py::module_& m) {
  // numen.InputError(ValueError): raised for a bad scene or input file; str() is sim::InputError's
  // located message "file:line:column: key: message"; attributes file, line, column (1-based,
  // 0 unknown), key (dotted key path, may be empty) and message (what is wrong).
  static py::exception<sim::InputError> input_error(m, "InputError", PyExc_ValueError);
  input_error.doc() =
      "A user input (scene file, trajectory) is wrong. A ValueError whose message is located "
      "like numen's C++ error, 'file:line:column: key: message'; attributes file (str), "
      "line and column (int, 1-based, 0: unknown), key (dotted key path, '' if none) and "
      "message (str, what is wrong).";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const sim::InputError& e) {
      py::object error = py::reinterpret_borrow<py::object>(input_error.ptr())(e.what());
      error.attr("file") = e.file();
      error.attr("line") = e.line();
      error.attr("column") = e.column();
      error.attr("key") = e.key();
      error.attr("message") = e.message();
      PyErr_SetObject(input_error.ptr(), error.ptr());
    }
  });

  // numen.SceneWarning(UserWarning): a load warning of Scene.warnings, raised by load_scene.
  // Never destroyed (a static py::object would be released after the interpreter is gone).
  static py::object* const scene_warning =
      new py::object(py::reinterpret_steal<py::object>(PyErr_NewExceptionWithDoc(
          "numen.SceneWarning",
          "A remark of the scene loader (one entry of Scene.warnings, e.g. 'no feedback: ...'), "
          "warned by load_scene, with the scene file's path in front when it is not located. "
          "warnings.simplefilter('error', numen.SceneWarning) makes it an error.",
          PyExc_UserWarning, nullptr)));
  if (!*scene_warning) throw py::error_already_set();
  m.attr("SceneWarning") = *scene_warning;

  py::class_<core::Model>(m, "Model",
                          "The compiled, immutable model of a scene (core::Model), read-only. "
                          "Lives as long as its Scene.")
      .def_property_readonly("dt", [](const core::Model& mo) { return mo.dt; },
                             "Fixed time step (s).")
      .def_property_readonly("gravity", [](const core::Model& mo) { return to_array(mo.gravity); },
                             "Gravity (m/s², world frame), shape (3,), a copy.")
      .def_property_readonly("integrator",
                             [](const core::Model& mo) { return sim::to_string(mo.integrator); },
                             "Integrator, as named in scene files ('implicit-euler', ...).")
      .def_property_readonly("coupling",
                             [](const core::Model& mo) { return sim::to_string(mo.coupling_mode); },
                             "Coupling mode, as named in scene files ('god-object', ...).")
      .def_property_readonly("num_bodies", &core::Model::num_bodies, "Dynamic bodies B.")
      .def_property_readonly("num_joints", &core::Model::num_joints, "Joints.")
      .def_property_readonly("num_nets", &core::Model::num_nets, "Deformable nets.")
      .def_property_readonly("num_nodes", &core::Model::num_nodes,
                             "Net nodes N over all nets (0 without nets).")
      .def_property_readonly(
          "body_names",
          [](const core::Model& mo) {
            std::vector<std::string> names;
            for (const core::BodyModel& b : mo.bodies) names.push_back(b.name);
            return names;
          },
          "Body names, in body index order (the rows of the Data views).")
      .def_property_readonly(
          "body_masses",
          [](const core::Model& mo) {
            std::vector<double> masses;
            for (const core::BodyModel& b : mo.bodies) masses.push_back(b.mass);
            return masses;
          },
          "Body masses (kg), in body index order.")
      .def(
          "body_spheres",
          [](const core::Model& mo, int body) {
            if (body < 0 || body >= mo.num_bodies())
              throw py::index_error("body " + std::to_string(body) + " out of range [0, " +
                                    std::to_string(mo.num_bodies()) + ") (Model.body_names)");
            const core::BodyModel& b = mo.bodies[static_cast<std::size_t>(body)];
            py::array_t<double> rows({static_cast<py::ssize_t>(b.sphere_count), py::ssize_t{4}});
            for (int i = 0; i < b.sphere_count; ++i) {
              const core::Sphere& sp =
                  mo.body_spheres[static_cast<std::size_t>(b.sphere_begin + i)];
              for (int k = 0; k < 3; ++k) rows.mutable_at(i, k) = sp.center[k];
              rows.mutable_at(i, 3) = sp.radius;
            }
            return rows;
          },
          py::arg("body"),
          "(S, 4) copy of body `body`'s collision spheres: centre x, y, z (m, in its "
          "centre-of-mass frame) and radius (m) (Model::body_spheres; (0, 4) for a body without "
          "spheres, e.g. a mesh body). With Data.body_positions / body_orientations they give "
          "where its surface is, e.g. a probe's lowest point.")
      .def_property_readonly(
          "joint_names",
          [](const core::Model& mo) {
            std::vector<std::string> names;
            for (const core::JointModel& j : mo.joints) names.push_back(j.name);
            return names;
          },
          "Joint names, in joint index order.")
      .def_property_readonly(
          "net_faces",
          [](const core::Model& mo) { return triangle_rows(mo.net_faces); },
          "(F, 3) int copy of the nets' surface triangles as global node indices, outward "
          "(Model::net_faces; each net's rows [face_begin, face_begin + face_count)); (0, 3) "
          "without nets. Data.node_contact_faces index its rows.")
      .def_property_readonly(
          "net_surface_point_faces",
          [](const core::Model& mo) {
            py::array_t<int> faces(static_cast<py::ssize_t>(mo.net_surface_points.size()));
            for (std::size_t i = 0; i < mo.net_surface_points.size(); ++i)
              faces.mutable_at(static_cast<py::ssize_t>(i)) = mo.net_surface_points[i].face;
            return faces;
          },
          "(P,) int copy: the net triangle each fine-surface vertex rides on, as a row of "
          "net_faces (Model::net_surface_points[i].face, global; net_surface_map.hpp). The nets' "
          "fine surfaces' vertices in order, each net's [surface_point_begin, + "
          "surface_point_count) of net_surface_ranges; (0,) without a fine surface.")
      .def_property_readonly(
          "net_surface_point_weights",
          [](const core::Model& mo) { return surface_point_rows(mo, &core::NetSurfacePoint::weights); },
          "(P, 3) float copy: each fine-surface vertex's barycentric weights on the corners of its "
          "net triangle (net_faces[net_surface_point_faces[i]], in that order; each >= 0, sum 1): "
          "its foot point. (0, 3) without a fine surface.")
      .def_property_readonly(
          "net_surface_point_offsets",
          [](const core::Model& mo) { return surface_point_rows(mo, &core::NetSurfacePoint::offset); },
          "(P, 3) float copy: each fine-surface vertex's offset from its foot point (m) in its net "
          "triangle's frame F = [e1, e2, n] (x0, x1, x2 its corners: e1 = (x1 - x0)/|x1 - x0|, "
          "n = (x1 - x0) x (x2 - x0) normalised, e2 = n x e1); the vertex is "
          "sum_m w_m x_m + F @ offset. (0, 3) without a fine surface.")
      .def_property_readonly(
          "net_surface_faces",
          [](const core::Model& mo) { return triangle_rows(mo.net_surface_faces); },
          "(S, 3) int copy of the fine surfaces' triangles as global indices into the "
          "net_surface_point_* rows, outward (Model::net_surface_faces; each net's rows "
          "[surface_face_begin, + surface_face_count) of net_surface_ranges); (0, 3) without a "
          "fine surface.")
      .def_property_readonly(
          "net_surface_ranges",
          [](const core::Model& mo) {
            py::array_t<int> r({static_cast<py::ssize_t>(mo.nets.size()), py::ssize_t{4}});
            for (std::size_t n = 0; n < mo.nets.size(); ++n) {
              const core::NetModel& net = mo.nets[n];
              const auto row = static_cast<py::ssize_t>(n);
              r.mutable_at(row, 0) = net.surface_point_begin;
              r.mutable_at(row, 1) = net.surface_point_count;
              r.mutable_at(row, 2) = net.surface_face_begin;
              r.mutable_at(row, 3) = net.surface_face_count;
            }
            return r;
          },
          "(num_nets, 4) int copy, per net (NetModel::surface_*): surface_point_begin, "
          "surface_point_count (its fine vertices: rows of net_surface_point_*), "
          "surface_face_begin, surface_face_count (its fine triangles: rows of "
          "net_surface_faces); counts 0 for a net without a fine surface (the tool then touches "
          "the net's own triangles).")
      .def_property_readonly(
          "grasp_names",
          [](const core::Model& mo) {
            std::vector<std::string> names;
            for (const core::GraspModel& g : mo.grasps) names.push_back(g.name);
            return names;
          },
          "Grasper names ([[grasp]] tables), in the order of Data.grasp(index).")
      .def_property_readonly(
          "obstacle_names",
          [](const core::Model& mo) {
            std::vector<std::string> names;
            for (const core::Obstacle& o : mo.obstacles) names.push_back(o.name);
            return names;
          },
          "Static obstacle names, in obstacle index order (the values of "
          "Data.contact_obstacles).")
      .def_property_readonly("initial_held_body",
                             [](const core::Model& mo) { return mo.initial_held_body; },
                             "Body the device holds after a reset (-1: none).")
      .def_property_readonly("initial_attached_body",
                             [](const core::Model& mo) { return mo.initial_held_body; },
                             "Alias of initial_held_body, kept for existing scripts.");

  py::class_<sim::Scene, std::shared_ptr<sim::Scene>>(
      m, "Scene",
      "A loaded scene (sim::Scene): the compiled model, the device, the simulated bus and the "
      "target trajectory. Made by load_scene().")
      .def_property_readonly("file", [](const sim::Scene& s) { return s.file; },
                             "Path of the scene file, as given.")
      .def_property_readonly("name", [](const sim::Scene& s) { return s.name; })
      .def_property_readonly("description", [](const sim::Scene& s) { return s.description; })
      .def_property_readonly("dt", [](const sim::Scene& s) { return s.model.dt; },
                             "Fixed time step (s) of the model and of the control loop.")
      .def_property_readonly("duration", [](const sim::Scene& s) { return s.duration_s; },
                             "Default run length (s).")
      .def_property_readonly("warnings", [](const sim::Scene& s) { return s.warnings; },
                             "Non-fatal remarks of the loader (list of str), e.g. 'no feedback: "
                             "...' for a device without [device.feedback] (docs/scenes.md).")
      .def_property_readonly("has_trajectory", [](const sim::Scene& s) { return s.has_trajectory; },
                             "The scene has a [trajectory] (target_at, set_targets_at, run_scene "
                             "need one).")
      .def_property_readonly("has_device", [](const sim::Scene& s) { return s.has_device; },
                             "The scene has a [device] (run_scene needs one; without it the "
                             "held body's target is set directly).")
      .def_property_readonly(
          "devices",
          [](const sim::Scene& s) {
            py::list out;
            for (const sim::DeviceLine& d : sim::device_lines(s)) {
              py::dict e;
              e["name"] = d.name;
              e["kind"] = d.kind;
              e["axes"] = d.axes;
              e["node_ids"] = d.node_ids;
              e["bodies"] = d.bodies;
              e["graspers"] = d.graspers;
              out.append(std::move(e));
            }
            return out;
          },
          "Every device, device 0 first (docs/scenes.md \"Several devices\"): a dict each of "
          "name, kind, axes (count), node_ids (its CANopen nodes; empty: minimal protocol), "
          "bodies (those its links drive) and graspers (whose jaws its axes turn).")
      .def_property_readonly(
          "model", [](const sim::Scene& s) -> const core::Model& { return s.model; },
          py::return_value_policy::reference_internal,
          "The compiled model (numen.Model, read-only; keeps the Scene alive).")
      .def_property_readonly(
          "trajectory_duration", [](const sim::Scene& s) { return s.trajectory.duration(); },
          "Time (s) of the trajectory's last knot; target_at() holds the last pose after it.")
      .def(
          "target_at",
          [](const sim::Scene& s, double t) {
            if (const sim::InputError* e = missing_part(s, "trajectory")) throw *e;
            const sim::TrajectorySample x = s.trajectory.at(finite_time(t, "Scene.target_at: t"));
            return py::make_tuple(to_array(x.pose.position), to_array(x.pose.orientation), x.jaw);
          },
          py::arg("t"),
          "The scene trajectory's sample at time t (s): the instrument's tool frame (trocar "
          "instrument: the tip, z along the shaft, with the recorded wrist) — not the held "
          "body's centre-of-mass frame that Data.set_target takes (Data.set_targets_at turns "
          "it into the bodies' targets): (position (3,) m, orientation (4,) unit quaternion in "
          "the order (x, y, z, w), jaw angle rad), world frame; copies. InputError for a scene "
          "without [trajectory], ValueError for a t that is not finite.")
      .def(
          "target_twist_at",
          [](const sim::Scene& s, double t) {
            if (const sim::InputError* e = missing_part(s, "trajectory")) throw *e;
            const core::Twist w = s.trajectory.twist_at(finite_time(t, "Scene.target_twist_at: t"));
            return py::make_tuple(to_array(w.linear), to_array(w.angular));
          },
          py::arg("t"),
          "Twist of the trajectory at time t (s): (linear (3,) m/s, angular (3,) rad/s), world "
          "frame; copies. InputError for a scene without [trajectory], ValueError for a t that is "
          "not finite.")
      .def(
          "make_data",
          [](const std::shared_ptr<sim::Scene>& s) {
            auto h = std::make_unique<DataHandle>();
            h->scene = s;
            h->model = &s->model;
            h->data = core::make_data(s->model);
            return h;
          },
          "A new numen.Data for this scene's model (core::make_data: allocated once, reset to "
          "the initial state). It keeps the Scene alive.");

  m.def(
      "load_scene",
      [](const std::string& path, const std::optional<std::string>& coupling) {
        sim::SceneOverrides overrides;
        overrides.caller_steps = true;
        if (coupling) overrides.coupling = sim::parse_coupling_mode(*coupling);
        auto scene = std::make_shared<sim::Scene>(sim::load_scene(path, overrides));
        // Each load warning (Scene.warnings) as a Python warning too: `no feedback: ...` is
        // otherwise only in a list nobody reads (`numen run` prints them on stderr).
        for (const std::string& w : scene->warnings) {
          const bool located = w.rfind(scene->file + ":", 0) == 0;  // "file:line:col: key: ..."
          if (PyErr_WarnEx(scene_warning->ptr(), (located ? w : scene->file + ": " + w).c_str(),
                           1) != 0)
            throw py::error_already_set();
        }
        return scene;
      },
      py::arg("path"), py::arg("coupling") = py::none(),
      "Loads and compiles the scene file at `path` (TOML, docs/scenes.md); `coupling` "
      "('god-object', 'first-order', 'direct'; None: the scene's) overrides the scene's "
      "coupling mode like `numen run --coupling`. The scene is to be stepped by the caller: "
      "[trajectory] and [device] may be left out (docs/scenes.md \"Drive it from your own "
      "program\"; run_scene then refuses it). Raises "
      "numen.InputError (a ValueError) with the located message 'file:line:column: key: "
      "message' and its parts as attributes. Each load warning (Scene.warnings) is also "
      "warned as a numen.SceneWarning.");
  m.def(
      "default_scene_path", [] { return (module_data_dir() / "scenes" / "default.toml").string(); },
      "Path of the shipped default scene: share/numen/scenes/default.toml of the prefix this "
      "module is installed in (found relative to the module, as the installed `numen` finds it "
      "relative to itself), else sim/scenes/default.toml of the source tree it was built from. "
      "The other shipped scenes (lattice.toml, probe.toml, ...) sit beside it.");
}

}  // namespace numen::python
