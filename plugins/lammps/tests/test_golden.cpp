// Replays the golden vectors of the Python reference law (tests/golden.json, written by
// `python scripts/make_golden_vectors.py`) through the C++ header and checks forces, stiffnesses,
// branches and final states; then the array path (arrays.hpp) against the one-contact path.
// Exit status 0 when every case agrees.
#include "geocontact/arrays.hpp"
#include "geocontact/law.hpp"
#include "geocontact/params.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

using geocontact::json::Value;

namespace {

// Relative tolerance against the case's scale (peak force, peak stiffness, ...): the two sides
// do the same arithmetic, so only libm/numpy rounding separates them.
constexpr double kTolerance = 1e-11;

int failures = 0;

void check(bool ok, const std::string &where, const std::string &what, double got,
           double expected)
{
  if (ok) return;
  if (++failures <= 20)
    std::fprintf(stderr, "FAIL %s: %s = %.17g, reference %.17g\n", where.c_str(), what.c_str(),
                 got, expected);
}

double number(const Value &v, const char *key)
{
  const Value *x = v.find(key);
  if (!x || x->kind != Value::NUMBER) throw geocontact::InputError(std::string("golden: ") + key);
  return x->number;
}

double max_abs(const Value &arr)
{
  double m = 0.0;
  for (const Value &x : arr.array) m = std::fmax(m, std::fabs(x.number));
  return m;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// The arrays' state, their virgin contacts' envelopes brought up to date (the array step
// computes them lazily), against the one-contact step's: every field, bit for bit.
void check_state(const geocontact::LawParams &p, geocontact::StateArrays &arrays,
                 const std::vector<geocontact::ContactState> &single, const std::string &what)
{
  geocontact::refresh_envelopes(p, arrays);
  for (std::size_t j = 0; j < single.size(); ++j) {
    const geocontact::ContactState &s = single[j];
    check(same_bits(arrays[j].approach, s.approach) && same_bits(arrays[j].force, s.force) &&
              same_bits(arrays[j].max_approach, s.max_approach) &&
              same_bits(arrays[j].max_force, s.max_force) &&
              same_bits(arrays[j].residual_approach, s.residual_approach) &&
              same_bits(arrays[j].unloading_exponent, s.unloading_exponent) &&
              same_bits(arrays[j].reloading_exponent, s.reloading_exponent) &&
              same_bits(arrays[j].work, s.work) && same_bits(arrays[j].cycles, s.cycles) &&
              same_bits(arrays[j].ratchet_shift, s.ratchet_shift) &&
              same_bits(arrays[j].pending_ratchet, s.pending_ratchet) &&
              same_bits(arrays[j].branch_value, s.branch_value) && arrays[j].branch == s.branch,
          what + ", contact " + std::to_string(j), "state (work)", arrays[j].work, s.work);
  }
}

// The array path (arrays.hpp, what the Python binding runs) on all cases of one parameter
// variant at once, on 1 and 3 threads: bit for bit the one-contact path of the loop in main().
// Histories are right-aligned; an untouched contact held at approach 0 stays as it was.
void check_arrays(const geocontact::LawParams &p, const std::vector<const Value *> &cases,
                  const std::string &variant)
{
  std::size_t steps = 0;
  for (const Value *c : cases) steps = std::max(steps, c->find("approaches")->array.size());
  const std::size_t n = cases.size();
  for (int threads : {1, 3}) {
    geocontact::StateArrays arrays(n);
    std::vector<geocontact::ContactState> single(n);
    std::vector<double> approach(n), force(n), stiffness(n);
    for (std::size_t k = 0; k < steps; ++k) {
      for (std::size_t j = 0; j < n; ++j) {
        const auto &a = cases[j]->find("approaches")->array;
        approach[j] = k + a.size() >= steps ? a[k + a.size() - steps].number : 0.0;
      }
      geocontact::step(p, arrays, approach.data(), force.data(), stiffness.data(), threads);
      for (std::size_t j = 0; j < n; ++j) {
        const auto r = geocontact::step(p, single[j], approach[j]);
        const std::string where = variant + " arrays, " + std::to_string(threads) +
            " thread(s), contact " + std::to_string(j) + " step " + std::to_string(k);
        check(same_bits(force[j], r.force), where, "force", force[j], r.force);
        // the record holds the returned force (the binding returns the records' forces)
        check(same_bits(arrays[j].force, r.force), where, "record force", arrays[j].force,
              r.force);
        check(same_bits(stiffness[j], r.stiffness), where, "stiffness", stiffness[j],
              r.stiffness);
        check(arrays[j].branch == single[j].branch, where, "branch", arrays[j].branch,
              single[j].branch);
      }
      // the state read between steps (from a copy: the steps that follow must not depend on it)
      if (k % 7 == 3) {
        geocontact::StateArrays copy = arrays;
        check_state(p, copy, single, variant + " step " + std::to_string(k));
      }
    }
    check_state(p, arrays, single, variant + " arrays final");
  }
}

}  // namespace

// The LAMMPS plugin's step (step<false, true>: n_r computed when the contact leaves the virgin
// curve) against the one-contact step<false> on a golden history: the same forces, stiffnesses
// and states to the bit, n_r included once refresh_envelope() has brought it up to date.
void check_lazy_reloading(const geocontact::LawParams &p, const Value &c)
{
  const std::string name = c.find("name")->string + " (plugin step)";
  geocontact::ContactState eager, lazy;
  size_t k = 0;
  for (const Value &x : c.find("approaches")->array) {
    const auto a = geocontact::step(p, eager, x.number);
    const auto b = geocontact::step<false, true>(p, lazy, x.number);
    const std::string where = name + " step " + std::to_string(k++);
    check(same_bits(a.force, b.force), where, "force", b.force, a.force);
    check(same_bits(a.stiffness, b.stiffness), where, "stiffness", b.stiffness, a.stiffness);
    geocontact::ContactState read = lazy;
    geocontact::refresh_envelope(p, read);
    const double pairs[][2] = {{eager.force, read.force},
                               {eager.work, read.work},
                               {eager.max_approach, read.max_approach},
                               {eager.residual_approach, read.residual_approach},
                               {eager.unloading_exponent, read.unloading_exponent},
                               {eager.reloading_exponent, read.reloading_exponent},
                               {eager.branch_value, read.branch_value},
                               {eager.cycles, read.cycles},
                               {eager.ratchet_shift, read.ratchet_shift}};
    for (const auto &pr : pairs) check(same_bits(pr[0], pr[1]), where, "state", pr[1], pr[0]);
    check(eager.branch == read.branch, where, "branch", read.branch, eager.branch);
  }
}

// The law's step three ways on one approach history: step<false> (fast paths, the Python
// binding's one-contact step), step<false, true> (the LAMMPS plugin's: n_r computed when the
// contact leaves the virgin curve), and, on every step up the virgin curve, the general loop
// (detail::step_moves, what such a step ran before its fast path virgin_climb) from the same
// state: the same forces, stiffnesses and states to the bit, n_r of the plugin's state once
// refresh_envelope() has brought it up to date. Returns the number of virgin steps compared.
size_t check_step_forms(const geocontact::LawParams &p, const std::vector<double> &approaches,
                        const std::string &name)
{
  geocontact::ContactState eager, lazy;
  size_t climbs = 0;
  auto same_state = [](const geocontact::ContactState &a, const geocontact::ContactState &b,
                       const std::string &where) {
    const double pairs[][2] = {{a.approach, b.approach},
                               {a.force, b.force},
                               {a.work, b.work},
                               {a.max_approach, b.max_approach},
                               {a.max_force, b.max_force},
                               {a.residual_approach, b.residual_approach},
                               {a.unloading_exponent, b.unloading_exponent},
                               {a.reloading_exponent, b.reloading_exponent},
                               {a.branch_value, b.branch_value},
                               {a.cycles, b.cycles},
                               {a.ratchet_shift, b.ratchet_shift},
                               {a.pending_ratchet, b.pending_ratchet}};
    for (const auto &pr : pairs) check(same_bits(pr[0], pr[1]), where, "state", pr[1], pr[0]);
    check(a.branch == b.branch, where, "branch", b.branch, a.branch);
  };
  for (size_t k = 0; k < approaches.size(); ++k) {
    const double x = approaches[k];
    const std::string where = name + " step " + std::to_string(k);
    const bool climb = eager.branch == geocontact::VIRGIN && x > eager.approach &&
                       x - eager.ratchet_shift > 0.0;
    geocontact::ContactState loop = eager;
    const auto a = geocontact::step(p, eager, x);
    const auto b = geocontact::step<false, true>(p, lazy, x);
    check(same_bits(a.force, b.force), where, "force", b.force, a.force);
    check(same_bits(a.stiffness, b.stiffness), where, "stiffness", b.stiffness, a.stiffness);
    geocontact::ContactState read = lazy;
    geocontact::refresh_envelope(p, read);
    same_state(eager, read, where + " (plugin step)");
    if (climb) {
      const auto c = geocontact::detail::step_moves<false, false>(p, loop, x);
      check(same_bits(a.force, c.force), where, "force (loop)", c.force, a.force);
      check(same_bits(a.stiffness, c.stiffness), where, "stiffness (loop)", c.stiffness,
            a.stiffness);
      same_state(eager, loop, where + " (loop)");
      ++climbs;
    }
  }
  return climbs;
}

// Random load paths in units of delta_y (a seeded generator, the same paths on every run):
// virgin loading in DEM-sized increments to one of several depths (1.5 to 300 delta_y, beyond
// every regime's start in the golden parameter sets), partial or full unloading, reloading
// below, to and beyond the envelope, and separation.
std::vector<double> random_load_path(unsigned seed, double dy)
{
  unsigned state = seed * 2654435761u + 12345u;
  auto uniform = [&state]() {
    state = state * 1664525u + 1013904223u;
    return (state >> 8) / 16777216.0;
  };
  std::vector<double> path{0.0};
  double here = 0.0, deepest = 0.0;
  for (int leg = 0; leg < 8; ++leg) {
    double to;
    if (leg % 2 == 0) {  // load: to a new depth, or back under the envelope
      const double depth = 1.5 * std::pow(200.0, uniform());
      to = uniform() < 0.7 ? std::fmax(depth, deepest * (1.0 + 0.3 * uniform())) : depth;
      deepest = std::fmax(deepest, to);
    } else {  // unload: part-way, fully, or apart
      const double u = uniform();
      to = u < 0.6 ? here * (0.3 + 0.65 * uniform()) : u < 0.85 ? 0.0 : -1.0;
    }
    const int steps = 20 + static_cast<int>(60 * uniform());
    for (int k = 1; k <= steps; ++k) path.push_back((here + (to - here) * k / steps) * dy);
    here = to;
  }
  path.push_back(-dy);
  return path;
}

int main(int argc, char **argv)
{
  if (argc != 2) {
    std::fprintf(stderr, "usage: test_golden golden.json\n");
    return 2;
  }
  const Value golden =
      geocontact::json::parse(geocontact::read_text_file(argv[1]), argv[1]);
  std::map<std::string, geocontact::LawParams> params;
  for (const auto &kv : golden.find("params")->object)
    params[kv.first] = geocontact::params_from_json(kv.second);

  size_t n_cases = 0, n_steps = 0;
  for (const Value &c : golden.find("cases")->array) {
    const std::string name = c.find("name")->string;
    const geocontact::LawParams &p = params.at(c.find("params")->string);
    const Value &approaches = *c.find("approaches");
    const Value &forces = *c.find("forces");
    const Value &stiffnesses = *c.find("stiffnesses");
    const Value &branches = *c.find("branches");
    const double force_scale = std::fmax(max_abs(forces), 1e-300);
    const double stiffness_scale = std::fmax(max_abs(stiffnesses), 1e-300);
    const double approach_scale = std::fmax(max_abs(approaches), 1e-300);

    geocontact::ContactState s;
    for (size_t k = 0; k < approaches.array.size(); ++k) {
      const auto r = geocontact::step(p, s, approaches.array[k].number);
      const std::string where = name + " step " + std::to_string(k);
      const double f = forces.array[k].number, kk = stiffnesses.array[k].number;
      check(std::fabs(r.force - f) <= kTolerance * force_scale, where, "force", r.force, f);
      check(std::fabs(r.stiffness - kk) <= kTolerance * stiffness_scale, where, "stiffness",
            r.stiffness, kk);
      check(s.branch == static_cast<int>(branches.array[k].number), where, "branch", s.branch,
            branches.array[k].number);
      ++n_steps;
    }
    const Value &fs = *c.find("final_state");
    const std::string where = name + " final";
    const double work_scale = std::fmax(force_scale * approach_scale, 1e-300);
    struct Field {
      const char *key;
      double value, scale;
    };
    const Field fields[] = {
        {"approach", s.approach, approach_scale},
        {"force", s.force, force_scale},
        {"max_approach", s.max_approach, approach_scale},
        {"max_force", s.max_force, force_scale},
        {"residual_approach", s.residual_approach, approach_scale},
        {"unloading_exponent", s.unloading_exponent, 1.0},
        {"reloading_exponent", s.reloading_exponent, 1.0},
        {"branch_value", s.branch_value, std::fmax(1.0, std::fabs(number(fs, "branch_value")))},
        {"ratchet_shift", s.ratchet_shift, approach_scale},
        {"pending_ratchet", s.pending_ratchet, approach_scale},
        {"cycles", s.cycles, std::fmax(1.0, number(fs, "cycles"))},
        {"work", s.work, work_scale},
    };
    for (const Field &fd : fields) {
      const double expected = number(fs, fd.key);
      check(std::fabs(fd.value - expected) <= kTolerance * fd.scale, where, fd.key, fd.value,
            expected);
    }
    check(s.branch == static_cast<int>(number(fs, "branch")), where, "branch", s.branch,
          number(fs, "branch"));
    const double ee = number(c, "elastic_energy"), de = number(c, "dissipated_energy");
    check(std::fabs(geocontact::elastic_energy(p, s) - ee) <= kTolerance * work_scale, where,
          "elastic_energy", geocontact::elastic_energy(p, s), ee);
    check(std::fabs(geocontact::dissipated_energy(p, s) - de) <= kTolerance * work_scale, where,
          "dissipated_energy", geocontact::dissipated_energy(p, s), de);
    ++n_cases;
  }
  for (const Value &c : golden.find("cases")->array)
    check_lazy_reloading(params.at(c.find("params")->string), c);
  size_t n_forms = 0, n_climbs = 0;
  for (const Value &c : golden.find("cases")->array) {
    std::vector<double> approaches;
    for (const Value &x : c.find("approaches")->array) approaches.push_back(x.number);
    n_climbs += check_step_forms(params.at(c.find("params")->string), approaches,
                                 c.find("name")->string + " (step forms)");
    ++n_forms;
  }
  for (const auto &kv : params)
    for (unsigned seed = 0; seed < 40; ++seed, ++n_forms)
      n_climbs += check_step_forms(kv.second, random_load_path(seed, kv.second.yield_approach),
                                   kv.first + " random path " + std::to_string(seed));
  if (n_climbs < 10000) {
    std::fprintf(stderr, "FAIL: only %zu virgin steps compared with the general loop\n", n_climbs);
    return 1;
  }
  std::printf("step forms: %zu paths, %zu virgin steps compared\n",
              n_forms, n_climbs);
  std::map<std::string, std::vector<const Value *>> by_variant;
  // each case 10 times, so a variant has enough contacts (> 512) to be split over threads
  for (int copy = 0; copy < 10; ++copy)
    for (const Value &c : golden.find("cases")->array)
      by_variant[c.find("params")->string].push_back(&c);
  for (const auto &kv : by_variant) check_arrays(params.at(kv.first), kv.second, kv.first);
  if (n_cases < 100) {
    std::fprintf(stderr, "FAIL: only %zu golden cases\n", n_cases);
    return 1;
  }
  std::printf("golden: %zu histories, %zu steps, %d failures\n", n_cases, n_steps, failures);
  return failures == 0 ? 0 : 1;
}
