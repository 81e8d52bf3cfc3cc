// geocontact.law._core: the C++ law header (plugins/lammps/include/geocontact/) bound to Python
// with nanobind. `geocontact.law.ContactArrays` (kernel.py) is the public face; this module only
// moves parameters in and exposes the state arrays, owned here, as numpy views by name.
#include "geocontact/arrays.hpp"
#include "geocontact/law.hpp"
#include "geocontact/params.hpp"

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace nb = nanobind;
using namespace nb::literals;

#ifndef GEOCONTACT_SOURCE_HASH
#define GEOCONTACT_SOURCE_HASH "unknown"
#endif

namespace {

using Approach = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
template <class T>
using View = nb::ndarray<nb::numpy, T, nb::ndim<1>>;

// n contacts of one law (or of plain Hertz), their state and the last step's outputs.
struct Contacts {
  geocontact::LawParams params;
  bool hertz_only = false;
  int threads = 1;
  geocontact::StateArrays state;
  std::vector<double> force, stiffness;  // the law's forces are its records' (force: Hertz's)
  std::vector<double> hertz_approach;    // plain Hertz's one history, the approach
  bool envelopes_current = true;       // no step since the last refresh_envelopes()

  Contacts(const geocontact::LawParams &p, std::size_t n, bool hertz, int threads_)
      : params(p), hertz_only(hertz), threads(threads_), state(n), force(hertz ? n : 0, 0.0),
        stiffness(n, 0.0), hertz_approach(hertz ? n : 0, 0.0)
  {
  }

  // returns the largest delta_max of the contacts after the step (shifted coordinates; 0 for
  // plain Hertz, which has no envelope): kernel.py compares it with the calibrated range
  double step(const double *approach)
  {
    double deepest = 0.0;
    if (hertz_only)
      geocontact::hertz_step(params.hertz_coefficient, hertz_approach, approach, force.data(),
                             stiffness.data(), threads);
    else
      deepest = geocontact::step(params, state, approach, nullptr, stiffness.data(), threads);
    envelopes_current = hertz_only;
    return deepest;
  }

  // the envelopes of contacts on the virgin curve, which the array step computes lazily
  // (a pass over every contact: done once after a step, however often the state is read)
  void refresh_envelopes()
  {
    if (envelopes_current) return;
    geocontact::refresh_envelopes(params, state);
    envelopes_current = true;
  }

  void reset()
  {
    // same size: assign() keeps the records' buffer, so the numpy views stay valid
    state.resize(state.size());
    std::fill(hertz_approach.begin(), hertz_approach.end(), 0.0);
    std::fill(force.begin(), force.end(), 0.0);
    std::fill(stiffness.begin(), stiffness.end(), 0.0);
  }
};

template <class T>
View<T> view(std::vector<T> &v, nb::handle owner)
{
  return View<T>(v.data(), {v.size()}, owner);
}

// One field of every contact record, as a strided numpy view (stride: one record).
template <class T>
View<T> field_view(geocontact::StateArrays &s, T geocontact::ContactRecord::*field,
                   nb::handle owner)
{
  static_assert(sizeof(geocontact::ContactRecord) % sizeof(T) == 0, "record stride");
  T *first = &(s.contacts.data()->*field);
  const std::int64_t stride = sizeof(geocontact::ContactRecord) / sizeof(T);
  return View<T>(first, {s.size()}, owner, {stride});
}

int checked_threads(int threads)
{
  if (threads < 1) throw nb::value_error(("threads: must be >= 1, got " +
                                          std::to_string(threads)).c_str());
  return threads;
}

}  // namespace

NB_MODULE(_core, m)
{
  m.doc() = "The geocontact law header bound to Python (see geocontact.law.kernel).";
  m.attr("SOURCE_HASH") = GEOCONTACT_SOURCE_HASH;
  m.attr("STATE_BYTES") = geocontact::kStateBytes;
  m.attr("STEP_BYTES") = geocontact::kStepBytes;
  m.attr("HERTZ_STEP_BYTES") = geocontact::kHertzStepBytes;
  m.attr("HERTZ_EXPONENT") = geocontact::kHertzExponent;

  using geocontact::CyclicLaw;
  using geocontact::LawParams;
  using geocontact::Material;
  using geocontact::RadiusTable;
  using geocontact::ResidualTable;
  nb::class_<Material>(m, "Material")
      .def(nb::init<>())
      .def_rw("youngs_modulus", &Material::youngs_modulus)
      .def_rw("poissons_ratio", &Material::poissons_ratio)
      .def_rw("compressive_yield_stress", &Material::compressive_yield_stress)
      .def_rw("friction_angle_deg", &Material::friction_angle_deg)
      .def_rw("hardening_ratio", &Material::hardening_ratio)
      .def_rw("radius", &Material::radius);
  nb::class_<CyclicLaw>(m, "CyclicLaw")
      .def(nb::init<>())
      .def_rw("enabled", &CyclicLaw::enabled)
      .def_rw("residual_ratio_coefficient", &CyclicLaw::residual_ratio_coefficient)
      .def_rw("residual_ratio_power", &CyclicLaw::residual_ratio_power)
      .def_rw("plastic_work_ratio_coefficient", &CyclicLaw::plastic_work_ratio_coefficient)
      .def_rw("plastic_work_ratio_power", &CyclicLaw::plastic_work_ratio_power)
      .def_rw("tolerance", &CyclicLaw::tolerance)
      .def_rw("shakedown", &CyclicLaw::shakedown);
  nb::class_<ResidualTable>(m, "ResidualTable")
      .def(nb::init<>())
      .def_rw("depth", &ResidualTable::depth)
      .def_rw("ratio", &ResidualTable::ratio)
      .def_ro("slope", &ResidualTable::slope, "dg/du at the knots (derived)");
  nb::class_<RadiusTable>(m, "RadiusTable")
      .def(nb::init<>())
      .def_rw("depth", &RadiusTable::depth)
      .def_rw("envelope_ratio", &RadiusTable::envelope_ratio)
      .def_rw("unloading_offset", &RadiusTable::unloading_offset)
      .def_rw("unloading_power", &RadiusTable::unloading_power);
  nb::class_<LawParams>(m, "LawParams")
      .def(nb::init<>())
      .def_rw("material", &LawParams::material)
      .def_rw("yield_approach", &LawParams::yield_approach)
      .def_rw("elastic_plastic_exponent", &LawParams::elastic_plastic_exponent)
      .def_rw("fully_plastic_approach_ratio", &LawParams::fully_plastic_approach_ratio)
      .def_rw("fully_plastic_exponent", &LawParams::fully_plastic_exponent)
      .def_rw("unloading_power", &LawParams::unloading_power)
      .def_rw("reloading_power", &LawParams::reloading_power)
      .def_rw("residual_limit", &LawParams::residual_limit)
      .def_rw("residual_power", &LawParams::residual_power)
      .def_rw("residual_transition", &LawParams::residual_transition)
      .def_rw("residual_log_power", &LawParams::residual_log_power)
      .def_rw("plastic_work_limit", &LawParams::plastic_work_limit)
      .def_rw("plastic_work_power", &LawParams::plastic_work_power)
      .def_rw("plastic_work_transition", &LawParams::plastic_work_transition)
      .def_rw("plastic_work_log_power", &LawParams::plastic_work_log_power)
      .def_rw("deep_plastic_approach_ratio", &LawParams::deep_plastic_approach_ratio)
      .def_rw("deep_plastic_exponent", &LawParams::deep_plastic_exponent)
      .def_rw("calibrated_depth", &LawParams::calibrated_depth)
      .def_rw("cyclic", &LawParams::cyclic)
      .def(
          "set_loading_segments",
          [](LawParams &p, const std::vector<double> &depth, const std::vector<double> &exponent) {
            if (depth.size() != exponent.size() || depth.size() < 2 ||
                depth.size() > static_cast<std::size_t>(LawParams::kMaxSegments))
              throw std::invalid_argument("loading.segments: depth and exponent must have the "
                                          "same length, 2 to " +
                                          std::to_string(LawParams::kMaxSegments));
            p.loading_segments = static_cast<int>(depth.size());
            for (std::size_t k = 0; k < depth.size(); ++k) {
              p.segment_depth[k] = depth[k];
              p.segment_exponent[k] = exponent[k];
            }
          },
          "depth"_a, "exponent"_a,
          "The virgin curve as power-law segments (`loading.segments`); derive() after.")
      .def_prop_ro("segment_depths",
                   [](const LawParams &p) {
                     return std::vector<double>(p.segment_depth, p.segment_depth + p.segments);
                   })
      .def_prop_ro("segment_exponents",
                   [](const LawParams &p) {
                     return std::vector<double>(p.segment_exponent,
                                                p.segment_exponent + p.segments);
                   })
      .def_rw("residual_table", &LawParams::residual_table)
      .def_rw("radius_table", &LawParams::radius_table)
      .def("residual_ratio", &LawParams::residual_ratio, "depth"_a,
           "delta_res / delta_max at the plastic depth x (closed form or table).")
      .def("derive", &LawParams::derive, "Set the derived constants from the fields.")
      .def_ro("hertz_coefficient", &LawParams::hertz_coefficient)
      .def_ro("yield_force", &LawParams::yield_force)
      .def_ro("fully_plastic_approach", &LawParams::fully_plastic_approach)
      .def_ro("fully_plastic_force", &LawParams::fully_plastic_force)
      .def_ro("deep_plastic_approach", &LawParams::deep_plastic_approach)
      .def_ro("deep_plastic_force", &LawParams::deep_plastic_force);

  // The C++ reader of the parameter file, so Python can hold it to the same messages as
  // geocontact.law.params (tests/test_law_schema.py replays the bad-document corpus).
  nb::exception<geocontact::InputError>(m, "InputError", PyExc_ValueError);
  m.def("parse_params", &geocontact::parse_params, "text"_a, "source"_a = "parameters",
        "A `geocontact.law/1` document read and validated by params.hpp.");

  // the similarity rule of law.hpp (docs/model.md §10), its one owner: grains of any size
  using geocontact::Similarity;
  nb::class_<Similarity>(m, "Similarity",
                         "A contact's similarity to the calibrated pair (law.hpp, docs/model.md §10).")
      .def_ro("scale", &Similarity::scale)
      .def_ro("approach", &Similarity::approach)
      .def_ro("force", &Similarity::force)
      .def_ro("stiffness", &Similarity::stiffness)
      .def_ro("energy", &Similarity::energy);
  m.def("pair_similarity", &geocontact::pair_similarity, "r1"_a, "r2"_a, "calibrated_radius"_a,
        "Two grains of radii r1, r2: s = 2 r1 r2 / ((r1 + r2) R).");
  m.def("wall_similarity", &geocontact::wall_similarity, "r"_a, "calibrated_radius"_a,
        "A grain of radius r on a rigid flat (the FE half model): s = r / R, approach 2 w / s.");
  m.def(
      "pair_similarity_scales",
      [](Approach r1, Approach r2, double calibrated_radius,
         nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu> out) {
        const std::size_t n = out.shape(0);
        if (r1.shape(0) != n || r2.shape(0) != n)
          throw nb::value_error("pair_similarity_scales: r1, r2 and out differ in length");
        for (std::size_t k = 0; k < n; ++k)
          out.data()[k] =
              geocontact::pair_similarity(r1.data()[k], r2.data()[k], calibrated_radius).scale;
      },
      "r1"_a, "r2"_a, "calibrated_radius"_a, "out"_a,
      "pair_similarity(r1[k], r2[k], R).scale into out[k].");

  auto contacts = nb::class_<Contacts>(m, "Contacts");
  contacts
      .def(
          "__init__",
          [](Contacts *self, const LawParams &params, std::size_t n, int threads) {
            new (self) Contacts(params, n, false, checked_threads(threads));
          },
          "params"_a, "n"_a, "threads"_a = 1)
      .def_static(
          "hertz",
          [](double hertz_coefficient, std::size_t n, int threads) {
            LawParams p;
            p.hertz_coefficient = hertz_coefficient;
            return new Contacts(p, n, true, checked_threads(threads));
          },
          "hertz_coefficient"_a, "n"_a, "threads"_a = 1, nb::rv_policy::take_ownership)
      .def_ro("params", &Contacts::params)
      .def_ro("hertz_only", &Contacts::hertz_only)
      .def_prop_rw(
          "threads", [](const Contacts &c) { return c.threads; },
          [](Contacts &c, int threads) { c.threads = checked_threads(threads); })
      .def_prop_ro("n", [](const Contacts &c) { return c.state.size(); })
      .def(
          "step",
          [](Contacts &c, Approach approach) {
            if (approach.shape(0) != c.state.size())
              throw nb::value_error(("approach: expected shape (" +
                                     std::to_string(c.state.size()) + ",), got (" +
                                     std::to_string(approach.shape(0)) + ",)")
                                        .c_str());
            nb::gil_scoped_release release;
            return c.step(approach.data());
          },
          "approach"_a,
          "Advance contact i to approach[i]; the results are in force and stiffness. Returns "
          "the largest delta_max of the contacts after the step (shifted coordinates, m).")
      .def(
          "contact_radius",
          [](const Contacts &c, nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu> out) {
            if (c.hertz_only || out.shape(0) != c.state.size())
              throw nb::value_error("contact_radius: a law's contacts and out of their number");
            for (std::size_t k = 0; k < c.state.size(); ++k) {
              const geocontact::ContactRecord &r = c.state[k];
              geocontact::ContactState s;
              s.approach = r.approach;
              s.force = r.force;
              s.max_approach = r.max_approach;
              s.max_force = r.max_force;
              s.residual_approach = r.residual_approach;
              s.unloading_exponent = r.unloading_exponent;
              s.ratchet_shift = r.ratchet_shift;
              s.branch = r.branch;
              out.data()[k] = geocontact::contact_radius(c.params, s);
            }
          },
          "out"_a, "The contact radius of each contact (law.hpp contact_radius) into out (m).")
      .def("reset", &Contacts::reset, "Every contact back to untouched.")
      .def("refresh_envelopes", &Contacts::refresh_envelopes,
           "Bring the envelope (residual approach, n_u, n_r, cycles) of every contact on the "
           "virgin curve up to date: the step computes it when a contact leaves the curve.")
      .def_prop_ro("force", [](nb::handle h) {
        // the law's: its records' force field (strided), which the step writes; Hertz's array
        Contacts &c = nb::cast<Contacts &>(h);
        return c.hertz_only ? view(c.force, h)
                            : field_view(c.state, &geocontact::ContactRecord::force, h);
      }, nb::rv_policy::reference_internal)
      .def_prop_ro("stiffness", [](nb::handle h) {
        return view(nb::cast<Contacts &>(h).stiffness, h);
      }, nb::rv_policy::reference_internal)
      .def(
          "state_views",
          [](nb::handle h) {
            // every ContactState field as a numpy view of this object's records (strided: one
            // record per contact), by name, in the order of ContactState (docs/law.md "State
            // per contact")
            geocontact::StateArrays &s = nb::cast<Contacts &>(h).state;
            nb::dict views;
#define GEOCONTACT_FIELD(name) \
  views[#name] = nb::cast(field_view(s, &geocontact::ContactRecord::name, h));
            GEOCONTACT_FIELD(approach)
            GEOCONTACT_FIELD(force)
            GEOCONTACT_FIELD(max_approach)
            GEOCONTACT_FIELD(max_force)
            GEOCONTACT_FIELD(residual_approach)
            GEOCONTACT_FIELD(unloading_exponent)
            GEOCONTACT_FIELD(reloading_exponent)
            GEOCONTACT_FIELD(branch_value)
            GEOCONTACT_FIELD(ratchet_shift)
            GEOCONTACT_FIELD(pending_ratchet)
            GEOCONTACT_FIELD(cycles)
            GEOCONTACT_FIELD(work)
            GEOCONTACT_FIELD(branch)
#undef GEOCONTACT_FIELD
            return views;
          },
          "The state arrays by field name (numpy views of this object's memory).");
}
