#pragma once
/// @file mujoco_engine.hpp
/// A numen scene simulated by MuJoCo (Debian's libmujoco 2.2): the model compiled from the MJCF
/// translation through an in-memory virtual file system, fed the same StepInput as numen every
/// period, and read back as numen body states (COM frames, world twists) so that both engines
/// are measured by the same code (peer_metrics.hpp).

#include <mujoco/mujoco.h>

#include <memory>
#include <string>
#include <vector>

#include "mjcf_translation.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "step_inputs.hpp"

namespace numen::peer {

/// Owns an mjModel and its mjData.
class MujocoEngine {
 public:
  /// Translates `model` (translate_to_mjcf with `drive` and `held_bodies`) and compiles it.
  /// `model` must outlive the engine. Throws std::invalid_argument from the translation and
  /// std::runtime_error with MuJoCo's compiler message.
  MujocoEngine(const core::Model& model, Drive drive, const std::vector<int>& held_bodies);
  ~MujocoEngine();
  MujocoEngine(const MujocoEngine&) = delete;
  MujocoEngine& operator=(const MujocoEngine&) = delete;

  /// Writes the device inputs of one period: kMocapWeld — the held body's mocap body goes to
  /// the target pose and only its weld is active (none when nothing is held); kPdForce — for
  /// the held body and every body with an enabled own target, numen's coupling wrench
  /// (core::coupling_wrench, Eq. 2 / Eq. 6, the body's gains) at the current state into
  /// xfrc_applied (world, at the COM). Prescribed joints: their equality's polycoef[0] =
  /// value + dt·rate − offset (the coordinate numen's step aims at). No allocation.
  void apply(const StepInput& input) noexcept;

  /// One mj_step (nothing else: this is what the comparison times).
  void step() noexcept;

  /// Body states in numen's convention (COM position, body→world quaternion, world linear
  /// velocity of the COM and world angular velocity), one per numen body; `states` is resized
  /// once to the body count. After mj_step, MuJoCo's xpos/xquat/cvel still describe the state
  /// before the integration: they are recomputed first from the new qpos/qvel (mj_kinematics,
  /// mj_comPos, mj_comVel; the next mj_step recomputes them anyway). No allocation after the
  /// first call.
  void read_states(std::vector<core::BodyState>& states);

  /// Times MuJoCo found a bad number in qacc (non-finite or > 1e10) and reset the state
  /// (mjWARN_BADQACC): the run diverged.
  int divergences() const noexcept;
  /// Contacts MuJoCo detected in the last step.
  int num_contacts() const noexcept;

  const mjModel* mj_model() const noexcept { return m_; }
  const mjData* mj_data() const noexcept { return d_; }
  const MjcfTranslation& translation() const noexcept { return tr_; }
  /// MuJoCo body id of numen body `b`.
  int body_id(int b) const noexcept { return body_id_[static_cast<std::size_t>(b)]; }

 private:
  void read_state(int b, core::BodyState& s) const noexcept;
  void refresh() noexcept;  // kinematics of the current qpos/qvel, if a step made them stale

  const core::Model* model_;
  Drive drive_;
  MjcfTranslation tr_;
  mjModel* m_ = nullptr;
  mjData* d_ = nullptr;
  std::vector<int> body_id_;        // per numen body
  std::vector<int> weld_id_;        // per numen body: equality id, -1
  std::vector<int> mocap_id_;       // per numen body: mocap index, -1
  std::vector<int> prescribed_id_;  // per numen joint: equality id, -1
  bool stale_ = false;              // a step ran since the last refresh()
};

}  // namespace numen::peer
