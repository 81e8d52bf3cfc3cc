// pair_style geocontact: the hysteretic elastic-plastic normal law of geocontact
// (docs/law.md) with a Mindlin-Coulomb tangential force, for atom style sphere.
//
//   pair_style geocontact [memory pair|place] [range warn|error]
//   pair_coeff * * P.json [friction mu] [damping beta] [rolling sds k g mu_r]
//              [twisting marshall]
//
// Normal force: the law for each contact, state per contact kept across neighbor-list rebuilds,
// migrations and restarts (fix geocontact/history). Tangential force: the accumulated
// tangential force (not displacement) is stored; its increment is -k_t v_t dt with the Mindlin
// no-slip stiffness k_t = 8 G* a of the current contact radius a, capped by mu times the normal
// force (Coulomb). Optional viscous damping: ratio beta of the critical damping of the contact's
// unloading (normal) and Mindlin (tangential) stiffness. Optional rolling and twisting
// resistance as LAMMPS's pair granular `rolling sds` and `twisting marshall` (contact_forces.h).
// The tangential force is rescaled by a / a_prev when the contact radius falls (no spring gains
// energy) and acts at r - delta/2 from each centre. Units: the law file is SI and is converted to
// the run's unit style (si, cgs, micro, nano, metal, real, electron; lj is refused).
#ifdef PAIR_CLASS
// clang-format off
PairStyle(geocontact,PairGeocontact);
// clang-format on
#else

#ifndef LMP_PAIR_GEOCONTACT_H
#define LMP_PAIR_GEOCONTACT_H

#include "pair.h"
#include "fix_geocontact_history.h"
#include "contact_forces.h"
#include "geocontact/law.hpp"

#include <string>
#include <vector>

namespace LAMMPS_NS {

using geocontact_forces::RollingCoeffs;
class FixGeocontactHistory;

class PairGeocontact : public Pair {
 public:
  PairGeocontact(class LAMMPS *);
  ~PairGeocontact() override;
  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  double init_one(int, int) override;
  double single(int, int, int, int, double, double, double, double &) override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;
  double memory_usage() override;

  // per-contact values of single() (compute pair/local p1..p10)
  enum SingleValue {
    SV_APPROACH, SV_NORMAL_FORCE, SV_TANGENTIAL_FORCE, SV_MAX_APPROACH, SV_RESIDUAL_APPROACH,
    SV_BRANCH, SV_CYCLES, SV_WORK, SV_DISSIPATED, SV_CONTACT_RADIUS, SV_COUNT
  };
  // global values (compute pair geocontact, summed over ranks; 1-based in LAMMPS's c_ID[k])
  // [5] the largest normal contact stiffness (force/length) and [6] the critical time step it
  // implies for the lightest grain (time; finish_stiffness_outputs). [7-12] the energy ledger's
  // dissipated channels in the order of geocontact_forces::LedgerChannel (sliding, normal
  // damping, tangential damping, rolling, twisting, and of which the change of the contact
  // radius), [13-15] the energy stored in the tangential, rolling and twisting springs; energies
  // in the run's units, dissipations including the contacts already dropped (docs/dem.md).
  // [16] the contacts loaded beyond their law file's calibrated range (delta_max / delta_y >
  // calibrated_range.max_depth: the law extrapolates there) and [17] the largest
  // delta_max / delta_y among them (0: none; finish_stiffness_outputs, which warns once).
  // [18] memory place: the normal elastic energy the forgotten dents held less what the fresh
  // states took over at the same approach, >= 0 (of which in [1]: the reset never creates
  // energy; contact_forces.h forget_if_safe).
  enum GlobalValue {
    GV_DISSIPATED, GV_ELASTIC, GV_CONTACTS, GV_PLASTIC_CONTACTS, GV_MAX_STIFFNESS,
    GV_CRITICAL_DT, GV_SLIDING, GV_NORMAL_DAMPING, GV_TANGENTIAL_DAMPING, GV_ROLLING,
    GV_TWISTING, GV_RADIUS_CHANGE, GV_STORED_TANGENTIAL, GV_STORED_ROLLING, GV_STORED_TWISTING,
    GV_BEYOND_RANGE, GV_DEEPEST_BEYOND, GV_MEMORY_RESET, GV_COUNT
  };
  static_assert(GV_RADIUS_CHANGE - GV_SLIDING + 1 == geocontact_forces::kLedgerSlots,
                "the compute's ledger indices follow LedgerChannel");

 protected:
  struct TypePairLaw {
    int law;                // index into laws_
    double friction;        // Coulomb coefficient mu
    double damping;         // fraction of critical damping beta
    RollingCoeffs resistance;  // rolling sds and twisting marshall
  };

  void allocate();
  void check_atoms();
  void index_contacts();
  void sync_mirrors();
  int add_law(const std::string &text, const std::string &source);
  void tally_contact(const geocontact::LawParams &law,
                     const geocontact_forces::StiffnessConstants &constants,
                     const ContactRecord &rec, const ContactRecord *springs_from,
                     const geocontact::Similarity &sim, const RollingCoeffs &resistance,
                     bool owned_pair);
  void note_stiffness(double normal_stiffness);
  void stop_beyond_range(const geocontact::LawParams &law, const geocontact::ContactState &state,
                         tagint i, tagint j);
  void finish_stiffness_outputs();
  void touch_pair(int i, int j, int k, const double *del, double rsq, double radsum,
                  bool commit, double dt, int eflag);
  void apply_contact_force(int i, int j, double fn, const double *ft, const double *n,
                           const double *del, double energy, const double *extra_torque,
                           double half_overlap);

  FixGeocontactHistory *history_;
  std::vector<geocontact::LawParams> laws_;
  // per law: its numbers in the run's units (contact_forces.h)
  std::vector<geocontact_forces::StiffnessConstants> stiffness_constants_;
  std::vector<std::string> law_texts_;  // the parameter documents, for restart files
  TypePairLaw **coeffs_;
  double *type_max_radius_;             // largest radius of each type's atoms (m): cutoffs

  // Between neighbor-list rebuilds the records live here, one per contact, dense: those of the
  // last rebuild in list order, then the contacts made since in the order they were made (read
  // and written nearly sequentially each step, in a fraction of the memory one record per
  // neighbor-list pair took: most pairs of a list never touch); record_of_ gives each
  // neighbor-list pair its record (-1: none). sync_mirrors() writes them back to the per-atom
  // tables of both grains before the tables are moved, saved or read.
  std::vector<ContactRecord> pair_records_;
  // the copy of a record that a setup step works on (its springs are not advanced): a member,
  // as a local it was constructed at every contact of every step (8 M instructions of the
  // poly sample's 370 M, docs/benchmarks.md)
  ContactRecord setup_record_;
  std::vector<int> record_of_;
  std::vector<int> first_pair_;
  // The law's dissipation (J) carried away by contacts whose records were dropped (pairs that
  // separated beyond the neighbor skin), summed over all ranks: compute pair geocontact's [1]
  // adds it, so the total never falls when a contact leaves the neighbor list.
  double departed_dissipation_ = 0.0;
  // the same for the ledger's other channels (geocontact_forces::LedgerChannel)
  double departed_ledger_[geocontact_forces::kLedgerSlots] = {};
  double departed_reset_ = 0.0;  // memory place: the dropped contacts' reset_stored
  double max_stiffness_ = 0.0;  // this rank's stiffest contact since the last energy step
  // this rank's contacts beyond their law's calibrated range at this energy step (weighted as
  // the other tallies) and the deepest of them (delta_max / delta_y), and whether the run was
  // told (once: the first energy step that finds one)
  double beyond_range_ = 0.0, deepest_beyond_ = 0.0;
  bool range_warned_ = false;
  // pair_style geocontact memory place|pair: the dent forgotten once the contact point has
  // travelled 2 a_max on either grain and forgetting creates no energy (place), or kept for as
  // long as the pair stays in the neighbor list (pair, the default; docs/dem.md "Memory with a
  // place")
  bool place_memory_ = false;
  // pair_style geocontact range error: stop at the first contact beyond the law file's
  // calibrated range (range warn, the default: count it, say so once)
  bool range_error_ = false;
};

}  // namespace LAMMPS_NS

#endif
#endif
