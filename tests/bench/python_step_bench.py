#!/usr/bin/env python3
"""Cost of a Python call of Data.step() against the C++ step, on the lattice scene (the default
scene with a rigid sphere-lattice organ; docs/python.md "Overhead"). A benchmark, not a test: run it by hand on a quiet machine.

    PYTHONPATH=build/sim/python /usr/bin/python3 tests/bench/python_step_bench.py \
        [--steps 20000] [--rounds 5] [--cpp-bench build/tests/numen_bench]

Each round runs the scripted loop (every target from the scene trajectory's sample at data.time
through the device, Data.set_targets_at(), then step; numen._testing.step_loop) twice on a new Data, alternately:
  python: the loop in Python; each data.step(scene) call is bracketed by time.perf_counter_ns
          (the cost of the bracket itself, measured on an empty bracket, is subtracted);
  c++:    the same loop in C++, each core::step bracketed by steady_clock.
Both loops step the same states bit for bit (tests/sim/python/data_bindings_test.py), so the
difference is the cost of the call from Python: argument conversion, the model check, the
binding's dispatch. Reported: medians over the rounds of the mean per call (µs), their ratio and
difference (the per-call overhead), and the whole Python loop per step (set_targets_at and
step). With --cpp-bench, the C++ benchmark
step_time/LatticeScene (Google Benchmark; core::step within the full control period of the
simulated bus) is run in the same process run for reference.
"""
import argparse
import json
import os
import statistics
import subprocess
import time

import numen


def python_loop(scene, steps):
    """Returns (seconds inside data.step calls, timer-corrected; seconds of the whole loop)."""
    data = scene.make_data()
    clock = time.perf_counter_ns
    in_step = 0
    t0 = clock()
    for _ in range(steps):
        data.set_targets_at()  # the trajectory's tip through the device to the tube's COM
        s0 = clock()
        data.step(scene)
        in_step += clock() - s0
    total = clock() - t0
    return in_step * 1e-9, total * 1e-9


def timer_cost_s(samples=200000):
    """Mean cost (s) of an empty perf_counter_ns bracket, as in python_loop."""
    clock = time.perf_counter_ns
    acc = 0
    for _ in range(samples):
        s0 = clock()
        acc += clock() - s0
    return acc * 1e-9 / samples


def cpp_benchmark(path):
    out = subprocess.run([path, "--benchmark_filter=step_time/LatticeScene/",
                          "--benchmark_format=json"], check=True, capture_output=True,
                         text=True).stdout
    b = json.loads(out)["benchmarks"][0]
    scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3}[b["time_unit"]]
    return b["real_time"] * scale, b.get("step_p50_us")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--cpp-bench", default="", help="path of numen_bench (optional)")
    args = ap.parse_args()
    scene = numen.load_scene(os.path.join(os.path.dirname(numen.default_scene_path()), "lattice.toml"))
    steps = min(args.steps, int(scene.duration / scene.dt))
    bracket = timer_cost_s()
    py_step, py_loop, cpp_step, cpp_loop = [], [], [], []
    for _ in range(args.rounds):
        s, total = python_loop(scene, steps)
        py_step.append((s / steps - bracket) * 1e6)
        py_loop.append(total / steps * 1e6)
        ref = numen._testing.step_loop(scene, steps)
        cpp_step.append(ref["step_s"] / steps * 1e6)
        cpp_loop.append(ref["wall_s"] / steps * 1e6)
    m = statistics.median
    print(f"lattice scene, {steps} steps x {args.rounds} rounds (medians of per-round means)")
    print(f"  timer bracket (subtracted)      {bracket * 1e6:8.3f} us")
    print(f"  C++   core::step                {m(cpp_step):8.3f} us/step")
    print(f"  Python data.step(scene)         {m(py_step):8.3f} us/call")
    print(f"  ratio Python/C++                {m(py_step) / m(cpp_step):8.2f}")
    print(f"  overhead per call               {m(py_step) - m(cpp_step):8.3f} us")
    print(f"  C++   loop per step             {m(cpp_loop):8.3f} us (target sampling + step)")
    print(f"  Python loop per step            {m(py_loop):8.3f} us (set_targets_at, step)")
    if args.cpp_bench:
        mean_us, p50 = cpp_benchmark(args.cpp_bench)
        print(f"  numen_bench step_time/LatticeScene: mean {mean_us:.3f} us, p50 {p50} us "
              f"(full control period, device-driven target)")


if __name__ == "__main__":
    main()
