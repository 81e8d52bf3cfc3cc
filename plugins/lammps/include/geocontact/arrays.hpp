// geocontact: the law over many contacts at once, header-only C++17 (what the Python binding
// `geocontact.law.ContactArrays` runs; any DEM code that keeps its contacts in arrays can too).
//
//     geocontact::StateArrays state(n);                   // one ContactRecord per contact
//     geocontact::step(params, state, approach, force, stiffness, threads);
//     state[i].work, state[i].branch, ...                 // after refresh_envelopes (below)
//
// Each contact is advanced by `geocontact::step` of law.hpp, the same function the LAMMPS pair
// style calls, so there is one implementation of the law. The state is an array of records,
// one per contact (docs/law.md, "State per contact"), stepped in place: a contact's fields are
// loaded where the law reads them and stored where it writes them.
//
// Envelopes: the arrays are stepped by step<true> (law.hpp), which computes the envelope of a
// contact climbing the virgin curve only when it leaves the curve; refresh_envelopes() brings
// every such contact's residual approach, n_u, n_r and cycle count up to date (bitwise those of
// the one-contact step<false>). Call it before reading those fields (the Python binding does,
// whenever its state is read).
//
// Threads: contacts are independent, so a step cuts them into contiguous chunks that `threads`
// std::threads take in turn (parallel_blocks below); no sum or order depends on the split, and
// the results are bitwise the same for any thread count.
#ifndef GEOCONTACT_ARRAYS_HPP
#define GEOCONTACT_ARRAYS_HPP

#include "geocontact/law.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <thread>
#include <vector>

namespace geocontact {

// One contact's state in the arrays: ContactState's fields in its order, the branch as int8.
struct ContactRecord {
  double approach, force, max_approach, max_force, residual_approach, unloading_exponent,
      reloading_exponent, branch_value, ratchet_shift, pending_ratchet, cycles, work;
  std::int8_t branch;
};

// The state of n contacts: one ContactRecord per contact, contiguous (an array of structures).
// A contact's fields share one or two cache lines, so a step reads and writes one memory
// stream, not one per field: a struct of arrays (one array per field, 16 streams with the
// approach, force and stiffness) ran 1.25x slower on 10^6 contacts (docs/benchmarks.md).
struct StateArrays {
  std::vector<ContactRecord> contacts;

  StateArrays() = default;
  explicit StateArrays(std::size_t n) { resize(n); }

  std::size_t size() const { return contacts.size(); }
  ContactRecord &operator[](std::size_t i) { return contacts[i]; }
  const ContactRecord &operator[](std::size_t i) const { return contacts[i]; }

  // n untouched contacts (the values of a default ContactState); the same size keeps the buffer
  void resize(std::size_t n)
  {
    const ContactState f;
    const ContactRecord fresh{f.approach,           f.force,
                              f.max_approach,       f.max_force,
                              f.residual_approach,  f.unloading_exponent,
                              f.reloading_exponent, f.branch_value,
                              f.ratchet_shift,      f.pending_ratchet,
                              f.cycles,             f.work,
                              static_cast<std::int8_t>(f.branch)};
    contacts.reserve(std::max<std::size_t>(n, 1));  // data() never null (the binding's views)
    contacts.assign(n, fresh);
  }
};

// Bytes a step moves per contact, counted from the layout: the state record read and written
// back (its force is the output force, as the binding steps), the approach read, the stiffness
// written. What the hardware moves can be less (lines left unchanged are not written back) or
// more (the write-allocate read of the stiffness).
constexpr std::size_t kStateBytes = sizeof(ContactRecord);
constexpr std::size_t kStepBytes = 2 * kStateBytes + 2 * sizeof(double);
// Plain Hertz through the same structure: approach in, force and stiffness out, approach kept.
constexpr std::size_t kHertzStepBytes = 4 * sizeof(double);

namespace detail {

// Returns the largest delta_max (shifted coordinates) of the block's contacts after the step:
// one max of a field the step has just written (in L1), so a caller can tell whether any
// contact went beyond the law's calibrated depth without a pass over the records.
template <bool WriteForce>
inline double step_contacts(const LawParams &p, ContactRecord *contacts, const double *approach,
                            double *force, double *stiffness, std::size_t begin,
                            std::size_t end)
{
  // a local copy: the records' stores cannot alias it, so its constants stay in registers
  const LawParams local = p;
  double deepest = 0.0;
  for (std::size_t i = begin; i < end; ++i) {
    const StepResult r = step<true>(local, contacts[i], approach[i]);
    if (WriteForce) force[i] = r.force;
    stiffness[i] = r.stiffness;
    deepest = std::max(deepest, contacts[i].max_approach);
  }
  return deepest;
}

// (the test of `force` hoisted out of the loop: one loop each way)
inline double step_block(const LawParams &p, StateArrays &a, const double *approach,
                         double *force, double *stiffness, std::size_t begin, std::size_t end)
{
  if (force)
    return step_contacts<true>(p, a.contacts.data(), approach, force, stiffness, begin, end);
  return step_contacts<false>(p, a.contacts.data(), approach, force, stiffness, begin, end);
}

// target = max(target, value), from any thread (once per chunk of contacts)
inline void atomic_max(std::atomic<double> &target, double value)
{
  double seen = target.load(std::memory_order_relaxed);
  while (value > seen && !target.compare_exchange_weak(seen, value, std::memory_order_relaxed)) {
  }
}

// Plain elastic Hertz, F = Kh d^1.5 (the speed floor of a normal law): no history but the
// approach, kept in an array of its own. Force and tangent are those of law.hpp's elastic fast
// path.
inline void hertz_block(double kh, double *kept, const double *approach, double *force,
                        double *stiffness, std::size_t begin, std::size_t end)
{
  for (std::size_t i = begin; i < end; ++i) {
    const double d = approach[i];
    const double root = std::sqrt(std::max(d, 0.0));
    force[i] = kh * std::max(d, 0.0) * root;
    stiffness[i] = kHertzExponent * kh * root;
    kept[i] = d;
  }
}

// Run block(begin, end) over [0, n) on `threads` threads. The contacts are cut into chunks of
// whole multiples of 64 contacts (whole cache lines of the outputs, and of the records if the
// buffer is aligned, so threads rarely write one line), about kChunksPerThread per thread and
// at least kMinChunk contacts, and each thread takes the next chunk left until none is: a
// thread that gets less of a core (a shared machine) or slower contacts does fewer chunks
// instead of holding the others at the end of the step. Which thread steps a contact changes
// nothing in its result.
template <class Block>
void parallel_blocks(std::size_t n, int threads, const Block &block)
{
  constexpr std::size_t kAlign = 64, kMinChunk = 4 * kAlign, kChunksPerThread = 16;
  const std::size_t wanted = threads > 1 ? static_cast<std::size_t>(threads) : 1;
  const std::size_t workers = std::max<std::size_t>(1, std::min(wanted, n / kMinChunk));
  if (workers == 1) {
    block(0, n);
    return;
  }
  const std::size_t chunk =
      std::max(kMinChunk, (n / (workers * kChunksPerThread) + kAlign - 1) / kAlign * kAlign);
  std::atomic<std::size_t> next{0};
  const auto run = [&] {
    for (std::size_t begin; (begin = next.fetch_add(chunk, std::memory_order_relaxed)) < n;)
      block(begin, std::min(n, begin + chunk));
  };
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(run);
  run();
  for (auto &t : pool) t.join();
}

}  // namespace detail

// Advance contact i of `state` to approach[i] for every i; force[i], stiffness[i] as step().
// The caller guarantees finite approaches and arrays of state.size() elements. `force` may be
// null: the force of contact i is also state[i].force (what the Python binding returns, 16 B
// of memory traffic per update fewer than a separate array: its write and write-allocate read).
// Returns the largest delta_max of every contact after the step (shifted coordinates, m; 0 for
// none): against p.calibrated_depth * p.yield_approach it says whether any contact is beyond
// the calibrated range (the same for any thread count: a max has no order).
inline double step(const LawParams &p, StateArrays &state, const double *approach,
                   double *force, double *stiffness, int threads = 1)
{
  std::atomic<double> deepest{0.0};
  detail::parallel_blocks(state.size(), threads, [&](std::size_t begin, std::size_t end) {
    detail::atomic_max(deepest,
                       detail::step_block(p, state, approach, force, stiffness, begin, end));
  });
  return deepest.load();
}

// Bring the envelope of every contact on the virgin curve up to date (see the top of this file).
inline void refresh_envelopes(const LawParams &p, StateArrays &state)
{
  for (ContactRecord &c : state.contacts)
    if (c.branch == VIRGIN) refresh_envelope(p, c);
}

// Plain Hertz of coefficient kh through the same entry point and thread split (no hysteresis,
// no dissipation); `kept` (one per contact) keeps the approach, its only history.
inline void hertz_step(double kh, std::vector<double> &kept, const double *approach,
                       double *force, double *stiffness, int threads = 1)
{
  detail::parallel_blocks(kept.size(), threads, [&](std::size_t begin, std::size_t end) {
    detail::hertz_block(kh, kept.data(), approach, force, stiffness, begin, end);
  });
}

}  // namespace geocontact

#endif
