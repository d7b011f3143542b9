/// @file scene_task.cpp
/// [task] table (scene_task.hpp).

#include "scene_task.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include "numen/core/model.hpp"

namespace numen::sim {
namespace {

/// The names of list `key` of `t`: a non-empty array of strings.
std::vector<std::string> names(const TomlTable& t, std::string_view key, const char* example) {
  const toml::node* node = t.node(key);
  if (node == nullptr) t.fail(key, std::string("missing: ") + example);
  const toml::array* list = node->as_array();
  if (list == nullptr || list->empty()) t.fail(key, std::string("expected a list of names, e.g. ") + example);
  std::vector<std::string> out;
  for (const toml::node& n : *list) {
    const auto* name = n.as_string();
    if (name == nullptr) t.fail(key, std::string("expected a list of names, e.g. ") + example);
    if (std::find(out.begin(), out.end(), name->get()) != out.end())
      t.fail(key, "\"" + name->get() + "\" is named twice");
    out.push_back(name->get());
  }
  return out;
}

}  // namespace

void parse_task(const TomlTable& root, Scene& scene) {
  const std::optional<TomlTable> t = root.table("task");
  if (!t) return;
  t->allow_only({"objects", "pegs", "reach"});
  const core::Model& m = scene.model;
  SceneTask task;
  for (const std::string& name : names(*t, "objects", "objects = [\"object_1\", \"object_2\"]")) {
    int found = -1;
    for (int i = 0; i < m.num_bodies() && found < 0; ++i)
      if (m.bodies[static_cast<std::size_t>(i)].name == name) found = i;
    if (found < 0) t->fail("objects", "no body named \"" + name + "\"");
    if (m.bodies[static_cast<std::size_t>(found)].anchored)
      t->fail("objects", "body \"" + name + "\" is anchored: a task moves dynamic bodies");
    task.objects.push_back(found);
  }
  for (const std::string& name : names(*t, "pegs", "pegs = [\"peg_1\", \"peg_2\"]")) {
    int found = -1;
    for (int i = 0; i < static_cast<int>(m.obstacles.size()) && found < 0; ++i)
      if (m.obstacles[static_cast<std::size_t>(i)].name == name) found = i;
    if (found < 0) t->fail("pegs", "no obstacle named \"" + name + "\"");
    if (m.obstacles[static_cast<std::size_t>(found)].type != core::ShapeType::kCapsule)
      t->fail("pegs", "obstacle \"" + name + "\" is not a capsule: a peg is a capsule (its axis from–to)");
    task.pegs.push_back(found);
  }
  task.reach = t->number_in("reach", 0.0, 1.0, task.reach);
  if (!(task.reach > 0.0)) t->fail("reach", "must be > 0 (m)");
  scene.task = std::move(task);
}

}  // namespace numen::sim
