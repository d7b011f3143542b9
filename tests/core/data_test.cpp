// Tests of core/data: the stages' scratch behind Data::scratch (DataScratchPtr)
// has value semantics — a copied Data owns its own scratch and steps bit for bit
// like the original, assigning a Data of the same model reuses the buffers (no
// allocation), a move takes the block along, a Data not made by make_data() has
// none.
#include "numen/core/data.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <utility>

#include "alloc_counter.hpp"
#include "lean_scenes.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"

namespace core = numen::core;
using numen::test::LeanPart;
using numen::test::make_lean_model;

namespace {

/// Drives the held body down onto the floor (kObstacle) and sideways, so
/// that contacts, warm starts and the sort-and-sweep order are in the scratch.
void drive(core::Data& d, int k) {
  d.target.position = core::Vec3(1e-4 * k, 0.0, 0.1 - 1e-3 * k);
  d.target_twist.linear = core::Vec3(0.1, 0.0, -1.0);
}

/// Exact (bitwise) equality of the states and outputs a caller reads.
void expect_identical(const core::Data& a, const core::Data& b) {
  ASSERT_EQ(a.bodies.size(), b.bodies.size());
  for (std::size_t i = 0; i < a.bodies.size(); ++i) {
    EXPECT_EQ(0, std::memcmp(a.bodies[i].position.data(), b.bodies[i].position.data(),
                             3 * sizeof(double)));
    EXPECT_EQ(0, std::memcmp(a.bodies[i].linear_velocity.data(),
                             b.bodies[i].linear_velocity.data(), 3 * sizeof(double)));
    EXPECT_EQ(0, std::memcmp(a.bodies[i].orientation.coeffs().data(),
                             b.bodies[i].orientation.coeffs().data(), 4 * sizeof(double)));
  }
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  for (std::size_t i = 0; i < a.nodes.size(); ++i) {
    EXPECT_EQ(0, std::memcmp(a.nodes[i].position.data(), b.nodes[i].position.data(),
                             3 * sizeof(double)));
    EXPECT_EQ(0, std::memcmp(a.nodes[i].velocity.data(), b.nodes[i].velocity.data(),
                             3 * sizeof(double)));
  }
  EXPECT_EQ(0, std::memcmp(a.feedback_wrench.force.data(), b.feedback_wrench.force.data(),
                           3 * sizeof(double)));
  EXPECT_EQ(a.num_contacts, b.num_contacts);
  EXPECT_EQ(a.solver_iterations, b.solver_iterations);
  EXPECT_EQ(a.status, b.status);
}

std::vector<LeanPart> all_parts() {
  std::vector<LeanPart> parts = numen::test::lean_parts();
  if (core::kWithArticulation && core::kWithDeformable) parts.push_back(LeanPart::kJointAndNet);
  return parts;
}

}  // namespace

TEST(Data, MakeDataAllocatesTheScratchBlock) {
  const core::Data d = core::make_data(make_lean_model(LeanPart::kNone));
  ASSERT_TRUE(d.scratch);
  EXPECT_EQ(d.scratch->solver.delta.size(), d.bodies.size());
}

TEST(Data, DefaultConstructedDataHasNoScratchAndCopiesAsNone) {
  const core::Data d;
  EXPECT_FALSE(d.scratch);
  const core::Data copy = d;
  EXPECT_FALSE(copy.scratch);
}

TEST(Data, CopyOwnsItsScratchAndStepsBitForBitLikeTheOriginal) {
  for (LeanPart part : all_parts()) {
    SCOPED_TRACE(static_cast<int>(part));
    const core::Model m = make_lean_model(part);
    core::Data a = core::make_data(m);
    int k = 0;
    for (; k < 50; ++k) {
      drive(a, k);
      core::step(m, a);
    }
    core::Data b = a;  // copy construction
    ASSERT_TRUE(b.scratch);
    EXPECT_NE(b.scratch.get(), a.scratch.get());
    core::Data c = core::make_data(m);
    c = a;  // copy assignment into a Data of the same model
    EXPECT_NE(c.scratch.get(), a.scratch.get());
    for (int j = 0; j < 50; ++j, ++k) {
      drive(a, k);
      drive(b, k);
      drive(c, k);
      core::step(m, a);
      core::step(m, b);
      core::step(m, c);
    }
    expect_identical(a, b);
    expect_identical(a, c);
  }
}

TEST(Data, AssigningADataOfTheSameModelDoesNotAllocate) {
  for (LeanPart part : all_parts()) {
    SCOPED_TRACE(static_cast<int>(part));
    const core::Model m = make_lean_model(part);
    core::Data a = core::make_data(m);
    drive(a, 10);
    core::step(m, a);
    core::Data b = core::make_data(m);
    const core::DataScratch* block = b.scratch.get();
    {
      numen::test::AllocationGuard guard;
      b = a;
      EXPECT_EQ(guard.count(), 0);
    }
    EXPECT_EQ(b.scratch.get(), block);  // the block is reused, its content copied
  }
}

TEST(Data, MoveTakesTheScratchBlockAlong) {
  const core::Model m = make_lean_model(LeanPart::kNone);
  core::Data a = core::make_data(m);
  const core::DataScratch* block = a.scratch.get();
  core::Data b = std::move(a);
  EXPECT_EQ(b.scratch.get(), block);
  core::Data c;
  c = std::move(b);
  EXPECT_EQ(c.scratch.get(), block);
}
