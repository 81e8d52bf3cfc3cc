// The law kernel without Python: bench_law.py's population (each contact its own sinusoidal
// approach, amplitude log-uniform in 0.2-60 delta_y, offset, phase and period random) stepped by
// arrays.hpp, for instruction counts and paired timings of two versions of the header
// (docs/benchmarks.md, "Law kernel"). Same distributions as bench_law.py, other random numbers.
//
//   mkdir -p build/kernel && cmake -DOUT=build/kernel -P plugins/lammps/cmake/law_schema.cmake
//   g++ -std=c++17 -O3 -fno-math-errno -g -Iplugins/lammps/include -Ibuild/kernel
//       benchmarks/kernel_driver.cpp -o build/kernel/driver -lpthread   (one command)
//   build/kernel/driver examples/params-reference.json 1000000 100 1 3     # contacts steps threads repeats
//   build/kernel/driver examples/params-reference.json 100000 100 1 1 check
//       (then also replays every contact with the one-contact step<false> of law.hpp and
//        compares each state field bit for bit, the arrays' envelopes brought up to date)
//   valgrind --tool=callgrind --toggle-collect='*step_contacts*'
//       build/kernel/driver examples/params-reference.json 20000 100 1 1   (one command)
//
// Prints the best wall and CPU time of the repeats as updates/s and a checksum of the final state.
#include "geocontact/arrays.hpp"
#include "geocontact/params.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <string>
#include <cstring>
#include <vector>

int main(int argc, char **argv)
{
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s PARAMS.json [contacts] [steps] [threads] [repeats]\n",
                 argv[0]);
    return 2;
  }
  const geocontact::LawParams p = geocontact::load_params(argv[1]);
  const std::size_t n = argc > 2 ? std::strtoul(argv[2], nullptr, 10) : 20000;
  const int steps = argc > 3 ? std::atoi(argv[3]) : 100;
  const int threads = argc > 4 ? std::atoi(argv[4]) : 1;
  const int repeats = argc > 5 ? std::atoi(argv[5]) : 1;
  const double pi = 3.14159265358979323846;

  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<double> path(n * steps);
  for (std::size_t i = 0; i < n; ++i) {
    const double amplitude =
        p.yield_approach * std::exp(std::log(0.2) + uniform(rng) * std::log(60.0 / 0.2));
    const double offset = amplitude * (-0.3 + 0.9 * uniform(rng));
    const double phase = 2.0 * pi * uniform(rng);
    const double period = 20.0 + 40.0 * uniform(rng);
    for (int t = 0; t < steps; ++t)
      path[t * n + i] = offset + amplitude * std::sin(2.0 * pi * t / period + phase);
  }

  std::vector<double> stiffness(n);  // the forces: the records' force fields (as the binding)
  geocontact::StateArrays state(n);
  double wall = 1e300, cpu = 1e300;
  for (int r = 0; r < repeats; ++r) {
    state.resize(n);
    const auto start = std::chrono::steady_clock::now();
    const std::clock_t start_cpu = std::clock();
    for (int t = 0; t < steps; ++t)
      geocontact::step(p, state, &path[t * n], nullptr, stiffness.data(), threads);
    wall = std::min(wall,
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    cpu = std::min(cpu, double(std::clock() - start_cpu) / CLOCKS_PER_SEC);
  }
  if (argc > 6 && std::string(argv[6]) == "check") {
    geocontact::refresh_envelopes(p, state);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < n; ++i) {
      geocontact::ContactState s;
      for (int t = 0; t < steps; ++t) geocontact::step(p, s, path[t * n + i]);
      const double ours[] = {state[i].approach, state[i].force, state[i].max_approach,
                             state[i].max_force, state[i].residual_approach,
                             state[i].unloading_exponent, state[i].reloading_exponent,
                             state[i].branch_value, state[i].ratchet_shift,
                             state[i].pending_ratchet, state[i].cycles, state[i].work};
      const double theirs[] = {s.approach, s.force, s.max_approach, s.max_force,
                               s.residual_approach, s.unloading_exponent, s.reloading_exponent,
                               s.branch_value, s.ratchet_shift, s.pending_ratchet, s.cycles,
                               s.work};
      differ += std::memcmp(ours, theirs, sizeof ours) != 0 || state[i].branch != s.branch;
    }
    std::printf("check: %zu of %zu contacts differ in some bit from the one-contact step\n",
                differ, n);
    if (differ) return 1;
  }
  double checksum = 0.0;
  for (std::size_t i = 0; i < n; ++i) checksum += state[i].work + state[i].force;
  const double updates = double(n) * steps;
  std::printf("%zu contacts x %d steps, %d thread(s): %.4g updates/s wall, %.4g per CPU-second; "
              "checksum %.17g\n",
              n, steps, threads, updates / wall, updates / cpu, checksum);
  return 0;
}
