// geocontact: the law over many contacts at once, header-only C++17 (what the Python binding
// `geocontact.law.ContactArrays` runs; any DEM code that keeps its contacts in arrays can too).
//
//     geocontact::StateArrays state(n);                   // one array per ContactState field
//     geocontact::step(params, state, approach, force, stiffness, threads);
//
// Each contact is advanced by `geocontact::step` of law.hpp, the same function the LAMMPS pair
// style calls, so there is one implementation of the law. The state is a struct of arrays
// (docs/law.md, "State per contact"), stepped in place (ContactRef): a contact's fields are
// loaded where the law reads them and stored where it writes them.
//
// Envelopes: the arrays are stepped by step<true> (law.hpp), which computes the envelope of a
// contact climbing the virgin curve only when it leaves the curve; refresh_envelopes() brings
// every such contact's residual approach, n_u, n_r and cycle count up to date (bitwise those of
// the one-contact step<false>). Call it before reading those fields (the Python binding does,
// whenever its state is read).
//
// Threads: contacts are independent, so a step splits them into `threads` contiguous blocks, one
// per std::thread; no sum or order depends on the split, and the results are bitwise the same
// for any thread count.
#ifndef GEOCONTACT_ARRAYS_HPP
#define GEOCONTACT_ARRAYS_HPP

#include "geocontact/law.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <thread>
#include <vector>

namespace geocontact {

// ContactState of n contacts as a struct of arrays (same names, same meaning).
struct StateArrays {
  std::vector<double> approach, force, max_approach, max_force, residual_approach,
      unloading_exponent, reloading_exponent, branch_value, ratchet_shift, pending_ratchet,
      cycles, work;
  std::vector<std::int8_t> branch;

  StateArrays() = default;
  explicit StateArrays(std::size_t n) { resize(n); }

  std::size_t size() const { return approach.size(); }

  // n untouched contacts (the values of a default ContactState)
  void resize(std::size_t n)
  {
    const ContactState fresh;
    approach.assign(n, fresh.approach);
    force.assign(n, fresh.force);
    max_approach.assign(n, fresh.max_approach);
    max_force.assign(n, fresh.max_force);
    residual_approach.assign(n, fresh.residual_approach);
    unloading_exponent.assign(n, fresh.unloading_exponent);
    reloading_exponent.assign(n, fresh.reloading_exponent);
    branch_value.assign(n, fresh.branch_value);
    ratchet_shift.assign(n, fresh.ratchet_shift);
    pending_ratchet.assign(n, fresh.pending_ratchet);
    cycles.assign(n, fresh.cycles);
    work.assign(n, fresh.work);
    branch.assign(n, static_cast<std::int8_t>(fresh.branch));
  }
};

// The data pointers of StateArrays, taken once per block of contacts. A loop that indexes the
// vectors themselves reloads their pointers after every store to the int8 branch array (a char
// type may alias anything, the vectors' own pointers included); a local copy cannot be aliased.
struct StatePointers {
  double *approach, *force, *max_approach, *max_force, *residual_approach, *unloading_exponent,
      *reloading_exponent, *branch_value, *ratchet_shift, *pending_ratchet, *cycles, *work;
  std::int8_t *branch;

  explicit StatePointers(StateArrays &a)
      : approach(a.approach.data()), force(a.force.data()), max_approach(a.max_approach.data()),
        max_force(a.max_force.data()), residual_approach(a.residual_approach.data()),
        unloading_exponent(a.unloading_exponent.data()),
        reloading_exponent(a.reloading_exponent.data()), branch_value(a.branch_value.data()),
        ratchet_shift(a.ratchet_shift.data()), pending_ratchet(a.pending_ratchet.data()),
        cycles(a.cycles.data()), work(a.work.data()), branch(a.branch.data())
  {
  }
};

// One contact of StateArrays, read and written in place by law.hpp's step(): a field is loaded
// where the law reads it and stored where the law writes it (the fast paths touch four or five
// of the thirteen), with no copy of the state in between.
struct ContactRef {
  double &approach, &force, &max_approach, &max_force, &residual_approach, &unloading_exponent,
      &reloading_exponent, &branch_value, &ratchet_shift, &pending_ratchet, &cycles, &work;
  std::int8_t &branch;

  ContactRef(const StatePointers &a, std::size_t i)
      : approach(a.approach[i]), force(a.force[i]), max_approach(a.max_approach[i]),
        max_force(a.max_force[i]), residual_approach(a.residual_approach[i]),
        unloading_exponent(a.unloading_exponent[i]),
        reloading_exponent(a.reloading_exponent[i]), branch_value(a.branch_value[i]),
        ratchet_shift(a.ratchet_shift[i]), pending_ratchet(a.pending_ratchet[i]),
        cycles(a.cycles[i]), work(a.work[i]), branch(a.branch[i])
  {
  }
  ContactRef(StateArrays &a, std::size_t i) : ContactRef(StatePointers(a), i) {}
};

// Bytes a step moves per contact, counted from the layout: the state read and written back
// (all fields: a population's contacts share cache lines), the approach read, force and
// stiffness written. What the hardware moves can be less (lines of unchanged fields are not
// written back) or more (write-allocate reads of the outputs).
constexpr std::size_t kStateBytes = 12 * sizeof(double) + sizeof(std::int8_t);
constexpr std::size_t kStepBytes = 2 * kStateBytes + 3 * sizeof(double);
// Plain Hertz through the same structure: approach in, force and stiffness out, approach kept.
constexpr std::size_t kHertzStepBytes = 4 * sizeof(double);

namespace detail {

inline void step_block(const LawParams &p, StateArrays &a, const double *approach,
                       double *force, double *stiffness, std::size_t begin, std::size_t end)
{
  const StatePointers pointers(a);
  for (std::size_t i = begin; i < end; ++i) {
    ContactRef s(pointers, i);
    const StepResult r = step<true>(p, s, approach[i]);
    force[i] = r.force;
    stiffness[i] = r.stiffness;
  }
}

// Plain elastic Hertz, F = Kh d^1.5 (the speed floor of a normal law): no history but the
// approach. Force and tangent are those of law.hpp's elastic fast path.
inline void hertz_block(double kh, StateArrays &a, const double *approach, double *force,
                        double *stiffness, std::size_t begin, std::size_t end)
{
  for (std::size_t i = begin; i < end; ++i) {
    const double d = approach[i];
    const double root = std::sqrt(std::max(d, 0.0));
    force[i] = kh * std::max(d, 0.0) * root;
    stiffness[i] = kHertzExponent * kh * root;
    a.approach[i] = d;
  }
}

// Run block(begin, end) over [0, n) on `threads` threads; blocks start on multiples of 64
// contacts (a cache line of the int8 branch array), so no two threads write one line.
template <class Block>
void parallel_blocks(std::size_t n, int threads, const Block &block)
{
  constexpr std::size_t kAlign = 64;
  const std::size_t wanted = threads > 1 ? static_cast<std::size_t>(threads) : 1;
  const std::size_t workers = std::max<std::size_t>(1, std::min(wanted, n / (4 * kAlign)));
  if (workers == 1) {
    block(0, n);
    return;
  }
  const std::size_t per = (n / workers + kAlign - 1) / kAlign * kAlign;
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  for (std::size_t w = 1; w < workers; ++w) {
    const std::size_t begin = std::min(n, w * per), end = std::min(n, (w + 1) * per);
    pool.emplace_back([&block, begin, end] { block(begin, end); });
  }
  block(0, std::min(n, per));
  for (auto &t : pool) t.join();
}

}  // namespace detail

// Advance contact i of `state` to approach[i] for every i; force[i], stiffness[i] as step().
// The caller guarantees finite approaches and arrays of state.size() elements.
inline void step(const LawParams &p, StateArrays &state, const double *approach, double *force,
                 double *stiffness, int threads = 1)
{
  detail::parallel_blocks(state.size(), threads, [&](std::size_t begin, std::size_t end) {
    detail::step_block(p, state, approach, force, stiffness, begin, end);
  });
}

// Bring the envelope of every contact on the virgin curve up to date (see the top of this file).
inline void refresh_envelopes(const LawParams &p, StateArrays &state)
{
  const StatePointers pointers(state);
  for (std::size_t i = 0, n = state.size(); i < n; ++i) {
    if (pointers.branch[i] != VIRGIN) continue;
    ContactRef s(pointers, i);
    refresh_envelope(p, s);
  }
}

// Plain Hertz of coefficient kh through the same structure (no hysteresis, no dissipation).
inline void hertz_step(double kh, StateArrays &state, const double *approach, double *force,
                       double *stiffness, int threads = 1)
{
  detail::parallel_blocks(state.size(), threads, [&](std::size_t begin, std::size_t end) {
    detail::hertz_block(kh, state, approach, force, stiffness, begin, end);
  });
}

}  // namespace geocontact

#endif
