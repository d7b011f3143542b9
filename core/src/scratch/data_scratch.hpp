#pragma once
/// @file data_scratch.hpp
/// Private to numen::core (core/src/scratch; tests and benchmarks reach it through
/// numen_core_internal): DataScratch, the stages' scratch behind Data::scratch.

#include "scratch/articulation_solve.hpp"
#include "scratch/collision_scratch.hpp"
#include "scratch/net_scratch.hpp"
#include "scratch/solver_scratch.hpp"
#include "scratch/thread_scratch.hpp"

namespace numen::core {

/// Every stage's scratch of one Data, in one heap block allocated by make_data()
/// (DataScratchPtr, data.hpp) and sized there once for the model: what step()
/// works in and keeps between steps (the collision sweep order, the nets' and the
/// joints' warm starts, the state saved for the non-finite rollback) but no caller
/// reads. A buffer a model does not need is empty (data_size.hpp).
struct DataScratch {
  CollisionScratch collision;        ///< Collision stage (detect_contacts, detect_node_contacts).
  SolverScratch solver;              ///< Integrator: the bodies' implicit system and its solves.
  ArticulationScratch articulation;  ///< Joints' tree solve; empty without joints.
  NetScratch net;                    ///< Nets' forces, collision and coupled solve; empty without nets.
  std::vector<ThreadScratch> threads;  ///< Per thread (thread.hpp); empty without threads.
};

}  // namespace numen::core
