#pragma once
/// @file multirate.hpp
/// The intermediate contact model of a multirate god-object (docs/multirate.md): the scene
/// loop, at the slow period, finds the god-object's contacts and hands the device loop one
/// local constraint per contact — a plane carried by the other side, with its penalty material
/// — which the device loop evaluates at its own pose every fast period, its stiffness and
/// damping implicit in the god-object's integrator (Mark et al., "Adding force feedback to
/// graphics systems", SIGGRAPH 1996; Otaduy & Lin, "A modular haptic rendering algorithm for
/// stable and transparent 6-DOF manipulation", IEEE T-RO 22(4), 2006; SOFA's
/// LCPForceFeedback plays the same role for constraint-based contact).
///
/// What is here: the god-object model the device loop steps (make_god_object_model), the
/// proximity model the scene loop detects with (make_proximity_model: the god-object's spheres
/// grown by a margin, so that a plane exists before its sphere reaches the surface), the planes
/// (ContactPlaneSet, build_contact_planes), the device step against them (step_god_object), and
/// the two loops interleaved on one thread, the scene bodies receiving the impulse the device
/// loop's planes gave the god-object (MultirateGodObject), with tool switching and a
/// single-rate view of both loops for the run harness; the two loops on two threads are
/// platform::MultirateThreads. The god-object is the held body with its articulation; a net on
/// one of its bodies (paper §4.2) stays in the scene loop, its mass lumped onto its rigid
/// component in the device loop, its node contacts handed over as node planes
/// (ContactPlane::node); the linearly implicit and symplectic Euler schemes.
///
/// The parts, one header each (numen/core/multirate/): the planes and their carriers
/// (planes.hpp), the two loops' models and the device step (device_loop.hpp), the exchange
/// between the loops (exchange.hpp), the god-object (god_object.hpp). This header includes them
/// all.

#include "numen/core/multirate/device_loop.hpp"
#include "numen/core/multirate/exchange.hpp"
#include "numen/core/multirate/god_object.hpp"
#include "numen/core/multirate/planes.hpp"
