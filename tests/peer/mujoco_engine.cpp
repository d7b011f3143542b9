/// @file mujoco_engine.cpp
/// A numen scene in MuJoCo: compile from memory, feed inputs, read states.

#include "mujoco_engine.hpp"

#include <cstring>
#include <stdexcept>

#include "numen/core/coupling.hpp"

namespace numen::peer {

MujocoEngine::MujocoEngine(const core::Model& model, Drive drive,
                           const std::vector<int>& held_bodies)
    : model_(&model), drive_(drive), tr_(translate_to_mjcf(model, drive, held_bodies)) {
  // The MJCF lives in a virtual file system (mjVFS is ~2 MB of fixed arrays: on the heap).
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  const char* file = "numen_peer.xml";
  if (mj_makeEmptyFileVFS(vfs.get(), file, static_cast<int>(tr_.xml.size())) != 0)
    throw std::runtime_error("mujoco: cannot create the in-memory MJCF file");
  const int idx = mj_findFileVFS(vfs.get(), file);
  std::memcpy(vfs->filedata[idx], tr_.xml.data(), tr_.xml.size());
  char err[1000] = "";
  m_ = mj_loadXML(file, vfs.get(), err, sizeof err);
  mj_deleteVFS(vfs.get());
  if (!m_) throw std::runtime_error(std::string("mujoco: MJCF translation rejected: ") + err);
  d_ = mj_makeData(m_);
  if (!d_) {
    mj_deleteModel(m_);
    throw std::runtime_error("mujoco: mj_makeData failed");
  }
  const int nb = model.num_bodies();
  body_id_.assign(static_cast<std::size_t>(nb), -1);
  weld_id_.assign(static_cast<std::size_t>(nb), -1);
  mocap_id_.assign(static_cast<std::size_t>(nb), -1);
  for (int b = 0; b < nb; ++b) {
    const auto i = static_cast<std::size_t>(b);
    body_id_[i] = mj_name2id(m_, mjOBJ_BODY, tr_.body_names[i].c_str());
    if (!tr_.weld_names[i].empty()) {
      weld_id_[i] = mj_name2id(m_, mjOBJ_EQUALITY, tr_.weld_names[i].c_str());
      mocap_id_[i] = m_->body_mocapid[mj_name2id(m_, mjOBJ_BODY, tr_.mocap_names[i].c_str())];
    }
  }
  prescribed_id_.assign(static_cast<std::size_t>(model.num_joints()), -1);
  for (int j = 0; j < model.num_joints(); ++j)
    if (!tr_.prescribed_names[static_cast<std::size_t>(j)].empty())
      prescribed_id_[static_cast<std::size_t>(j)] =
          mj_name2id(m_, mjOBJ_EQUALITY, tr_.prescribed_names[static_cast<std::size_t>(j)].c_str());
  mj_forward(m_, d_);
}

MujocoEngine::~MujocoEngine() {
  mj_deleteData(d_);
  mj_deleteModel(m_);
}

void MujocoEngine::read_state(int b, core::BodyState& s) const noexcept {
  const int id = body_id_[static_cast<std::size_t>(b)];
  const mjtNum* p = d_->xpos + 3 * id;
  const mjtNum* q = d_->xquat + 4 * id;
  s.position = core::Vec3(p[0], p[1], p[2]);
  s.orientation = core::Quat(q[0], q[1], q[2], q[3]);
  mjtNum v[6];  // [angular; linear] at the body frame's origin (the COM), world axes
  mj_objectVelocity(m_, d_, mjOBJ_BODY, id, v, 0);
  s.angular_velocity = core::Vec3(v[0], v[1], v[2]);
  s.linear_velocity = core::Vec3(v[3], v[4], v[5]);
}

void MujocoEngine::apply(const StepInput& in) noexcept {
  const core::Model& model = *model_;
  const int nb = model.num_bodies();
  if (drive_ == Drive::kMocapWeld) {
    for (int b = 0; b < nb; ++b) {
      const auto i = static_cast<std::size_t>(b);
      if (weld_id_[i] < 0) continue;
      const bool held = b == in.held_body;
      m_->eq_active[weld_id_[i]] = held ? 1 : 0;
      if (!held) continue;
      mjtNum* p = d_->mocap_pos + 3 * mocap_id_[i];
      mjtNum* q = d_->mocap_quat + 4 * mocap_id_[i];
      const core::Quat& t = in.target.orientation;
      for (int k = 0; k < 3; ++k) p[k] = in.target.position[k];
      q[0] = t.w(), q[1] = t.x(), q[2] = t.y(), q[3] = t.z();
    }
  } else {
    refresh();  // the wrench depends on the current state
    std::memset(d_->xfrc_applied, 0, sizeof(mjtNum) * 6 * static_cast<std::size_t>(m_->nbody));
    for (int b = 0; b < nb; ++b) {
      const auto i = static_cast<std::size_t>(b);
      const core::BodyTarget* own =
          i < in.body_targets.size() && in.body_targets[i].enabled ? &in.body_targets[i] : nullptr;
      const bool held = b == in.held_body;
      if (!held && !own) continue;
      core::BodyState s;
      read_state(b, s);
      const core::Wrench w =
          held ? core::coupling_wrench(model.bodies[i].coupling, in.target, in.target_twist, s)
               : core::coupling_wrench(model.bodies[i].coupling, own->pose, own->twist, s);
      mjtNum* f = d_->xfrc_applied + 6 * body_id_[i];
      for (int k = 0; k < 3; ++k) f[k] = w.force[k], f[3 + k] = w.torque[k];
    }
  }
  for (int j = 0; j < model.num_joints(); ++j) {
    const int e = prescribed_id_[static_cast<std::size_t>(j)];
    if (e < 0 || static_cast<std::size_t>(j) >= in.joint_prescribed.size()) continue;
    const core::JointPrescription& jp = in.joint_prescribed[static_cast<std::size_t>(j)];
    m_->eq_data[mjNEQDATA * e] =
        jp.value + model.dt * jp.rate - tr_.coordinate_offset[static_cast<std::size_t>(j)];
  }
}

void MujocoEngine::step() noexcept {
  mj_step(m_, d_);
  stale_ = true;
}

void MujocoEngine::refresh() noexcept {
  if (!stale_) return;
  mj_kinematics(m_, d_);
  mj_comPos(m_, d_);
  mj_comVel(m_, d_);
  stale_ = false;
}

void MujocoEngine::read_states(std::vector<core::BodyState>& states) {
  refresh();
  states.resize(static_cast<std::size_t>(model_->num_bodies()));
  for (int b = 0; b < model_->num_bodies(); ++b) read_state(b, states[static_cast<std::size_t>(b)]);
}

int MujocoEngine::divergences() const noexcept { return d_->warning[mjWARN_BADQACC].number; }

int MujocoEngine::num_contacts() const noexcept { return d_->ncon; }

}  // namespace numen::peer
