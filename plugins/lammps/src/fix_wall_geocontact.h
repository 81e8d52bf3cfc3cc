// fix wall/geocontact: rigid walls for grains with the geocontact law, in the manner of LAMMPS's
// fix wall/gran (examples/lammps/README.md "Walls"); fix wall/geocontact/region derives from it
// (fix_wall_geocontact_region.h) and shares its per-contact step, touch_wall.
//
//   fix ID group wall/geocontact P.json [friction mu] [damping beta]
//       [rolling sds k_roll gamma_roll mu_roll] [twisting marshall] [range warn|error]
//       [memory pair|place] wallstyle args [motion]
//     range: a contact loaded beyond the law file's calibrated range is counted and said once
//       (warn, the default) or stops the run with one line (error)
//     memory: pair (the default) keeps a wall contact's dent while its record lives; place
//       forgets it once the contact point has travelled past it over the grain's surface (the
//       wall is rigid: the grain's side only), as pair_style geocontact memory place does
//     wallstyle: xplane|yplane|zplane lo hi (NULL: no wall on that side) | zcylinder R
//     motion:    wiggle dim A period | velocity v | position v_name | shear dim V
//       shear: the wall slides in its own plane (along the axis of a zcylinder) at the velocity V
//       along dim, a constant (LAMMPS's fix wall/gran shear) or an equal-style variable v_name
//       evaluated every step (a base driven by a velocity record); the wall does not move along
//       its normal, so the grains feel it through the tangential force and rolling alone.
//
// A grain of radius r = s R (R the file's radius) at wall interference w feels the ball-wall
// law of the FE half model (docs/model.md §10): F = s^2 F_R(2 w / s), the pair law of two identical
// spheres of radius r at approach d = 2 w, with all its history rules; the same Mindlin-Coulomb
// tangential force and damping as the pair style (contact_forces.h), with the sphere-flat
// stiffnesses (twice the pair's, the same contact radius). Rolling and twisting resistance as
// LAMMPS's fix wall/gran: the wall neither spins nor is curved for them (R* = r, the grain's
// radius, also for the zcylinder), the same coefficients as the pair's keywords. One contact
// record per wall per atom (law state, tangential force, rolling displacement, twist angle)
// travels with the atom between ranks and into restart files.
//
// Output (the run's units; the law file is SI and converted, contact_forces.h RunUnits):
// global vector [1-3] force of the grains on the wall, [4] energy the law dissipated at the
// wall (contacts since the fix was defined), [5] stored elastic energy, [6] number of wall
// contacts, [7] the largest normal stiffness of a wall contact and [8] the critical time step it
// implies for the lightest grain of the group (0 while none touches); the energy ledger of the
// wall contacts (contact_forces.h LedgerChannel; since the fix was defined, forgotten contacts
// included): [9] sliding, [10] normal damping, [11] tangential damping, [12] rolling, [13]
// twisting, [14] of which the change of the contact radius, [15-17] the energy stored in the
// tangential, rolling and twisting springs, [18] the work the wall did on the grains, the sum
// over steps of F . v_wall dt (F the contact force on the grain); [19] the wall contacts loaded
// beyond the law file's calibrated range (delta_max / delta_y > calibrated_range.max_depth,
// where the law extrapolates; warned once, at the end of the first run that has any) and [20]
// the largest delta_max / delta_y among them (0: none), [21] memory place: the normal elastic
// energy the forgotten dents held less what the fresh states took over (>= 0, of which in [4]);
// per-atom array,
// kOutputColumns per wall (lo wall first): interference w, normal force, |tangential force|,
// max interference, residual interference, branch of the law.
#ifdef FIX_CLASS
// clang-format off
FixStyle(wall/geocontact,FixWallGeocontact);
// clang-format on
#else

#ifndef LMP_FIX_WALL_GEOCONTACT_H
#define LMP_FIX_WALL_GEOCONTACT_H

#include "contact_forces.h"
#include "fix.h"
#include "geocontact/law.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace LAMMPS_NS {

class FixWallGeocontact : public Fix {
 public:
  // doubles per wall record: 13 law slots, 3 tangential components, the active flag, 3 rolling
  // components, the twist angle, the contact radius, the ledger's channels, the 2 travelled
  // distances, the due flag, the forgotten law work and its change of stored energy, the last
  // step's normal (layout version 1: the first 17 of them, version 2: the first 21, version 3:
  // the first 22, version 4: up to the ledger's)
  static constexpr int kRecordSize = 30 + geocontact_forces::kLedgerSlots;
  static constexpr int kRecordSizeV1 = 17;
  static constexpr int kRecordSizeV2 = 21;
  static constexpr int kRecordSizeV3 = 22;
  static constexpr int kRecordSizeV4 = 22 + geocontact_forces::kLedgerSlots;
  static constexpr int kOutputColumns = 6;
  // Restart layouts, bumped whenever a packed record changes: per atom [length, tag, walls,
  // records], the tag "GCWA" in the high and the version in the low 32 bits; global [tag
  // "GCWG" + version, time origin, wall position and velocity of the position variable and its
  // step, dissipated energy of forgotten contacts, walls, (version 4) the ledger's channels of
  // forgotten contacts and the wall's work]. Version 2 adds rolling and twist to the per-atom
  // records, version 3 the contact radius (the global layout is unchanged), version 4 the
  // ledger (per atom and global), version 5 memory with a place (per atom: the travelled
  // distances, the due flag, the forgotten work and its change of stored energy, the last
  // normal; global: the forgotten contacts' change of stored energy); versions 1 to 4 are still
  // read, with what they lack at zero (the contact radius: from the law state; the normal: from
  // the next step).
  static constexpr int kRestartLayoutVersion = 5;
  static constexpr int64_t kAtomTagBase = static_cast<int64_t>(0x41574347) << 32;
  static constexpr int64_t kAtomTag = kAtomTagBase | kRestartLayoutVersion;
  static constexpr int64_t kAtomTagV1 = kAtomTagBase | 1;
  static constexpr int64_t kGlobalTagBase = static_cast<int64_t>(0x47574347) << 32;
  static constexpr int64_t kGlobalTag = kGlobalTagBase | kRestartLayoutVersion;
  static constexpr int kAtomHeader = 3;
  static constexpr int kGlobalSizeV3 = 7;
  static constexpr int kGlobalSizeV4 = kGlobalSizeV3 + geocontact_forces::kLedgerSlots + 1;
  static constexpr int kGlobalSize = kGlobalSizeV4 + 1;

  FixWallGeocontact(class LAMMPS *, int, char **);
  ~FixWallGeocontact() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void post_force(int) override;
  void post_run() override;
  double compute_vector(int) override;

  void write_restart(FILE *) override;
  void restart(char *) override;
  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  void set_arrays(int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;
  int pack_restart(int, double *) override;
  void unpack_restart(int, int) override;
  int size_restart(int) override;
  int maxsize_restart() override;
  double memory_usage() override;

 protected:
  // REGION: fix wall/geocontact/region (its walls are a LAMMPS region's, read by the derived fix)
  enum WallStyle { XPLANE = 0, YPLANE = 1, ZPLANE = 2, ZCYLINDER = 3, REGION = 4 };
  enum Motion { STATIC, WIGGLE, VELOCITY, POSITION, SHEAR };
  enum Side { LO, HI, CYLINDER };
  // the sums over ranks come first (compute_vector)
  enum Global {
    GF_X, GF_Y, GF_Z, G_DISSIPATED, G_ELASTIC, G_CONTACTS, G_MAX_STIFFNESS, G_CRITICAL_DT,
    G_SLIDING, G_NORMAL_DAMPING, G_TANGENTIAL_DAMPING, G_ROLLING, G_TWISTING, G_RADIUS_CHANGE,
    G_STORED_TANGENTIAL, G_STORED_ROLLING, G_STORED_TWISTING, G_BOUNDARY_WORK, G_BEYOND_RANGE,
    G_DEEPEST_BEYOND, G_MEMORY_RESET, G_COUNT
  };
  static_assert(G_RADIUS_CHANGE - G_SLIDING + 1 == geocontact_forces::kLedgerSlots,
                "the vector's ledger indices follow LedgerChannel");

  struct WallRecord {
    geocontact::ContactState law;  // in the calibrated spheres' units, at d = 2 w / s
    double tangential[3];          // accumulated tangential force on the atom (N)
    int active;                    // 1 while the atom is within the skin of the wall
    double rolling[3];             // rolling displacement (m)
    double twist;                  // twist angle (rad)
    double contact_radius;         // a of the last step (run lengths); < 0: not known
    double dissipated[geocontact_forces::kLedgerSlots];  // the contact's ledger (run energy)
    // memory place (contact_forces.h track_place): how far the contact point has moved over
    // the grain's surface [0] since the envelope was set ([1] the wall's: 0, it is rigid; run
    // lengths), the due flag, the law's work carried over forgotten dents and, of it, the
    // change of stored energy (run energy units), the unit normal of the last committed step
    // (its change turns the contact point over the grain; all 0: none yet)
    double travel[2];
    int due;
    double forgotten;
    double reset_stored;
    double normal[3];
  };

  // One grain on one wall at this step, whatever the wall's shape: the planes and the cylinder
  // here, the region walls of fix wall/geocontact/region (the same per-contact code path).
  struct WallContact {
    double interference;      // w = r - (distance from the wall's surface to the centre)
    double n[3];              // unit normal from the wall to the grain
    double velocity[3];       // the wall's velocity at the contact point
    // the grain's radius, or on a curved wall the effective one (geocontact::
    // wall_effective_radius): its wall_similarity gives the law, and it is the rolling radius R*
    double effective_radius;
  };
  void touch_wall(int i, WallRecord &stored, const WallContact &contact, bool commit,
                  double *out);
  void forget_contact(WallRecord &stored, const geocontact::Similarity &sim);
  static void clear_place(WallRecord &rec);
  void track_wall_place(WallRecord &rec, const WallContact &contact,
                        const geocontact::Similarity &sim, double arm, const double *omega);
  void begin_tally();
  void tally_contact(const WallRecord &rec, const WallRecord *springs_from,
                     const geocontact::Similarity &sim);
  void finish_tally();

  // The global tallies of a committed step are summed when they are read (compute_vector,
  // post_run), or before the records move (copy_arrays, pack_exchange), from the contacts the
  // step touched, in the step's order: the same sums to the bit as summing them contact by
  // contact during the step, and a run that reads them seldom does not pay for the energies,
  // the springs and the ledger of every contact at every step. One entry per contact of the
  // step (its record's index and the radius its similarity was taken at) or per contact the
  // step forgot (record < 0: -(k + 1), its dissipated energies at forgotten_step_[k]: the law's,
  // the ledger's channels, its memory resets' change of stored energy, kForgottenStride).
  struct TallyEntry {
    long record;
    double effective_radius;
  };
  std::vector<TallyEntry> tallied_;
  static constexpr int kForgottenStride = 2 + geocontact_forces::kLedgerSlots;
  std::vector<double> forgotten_step_;  // kForgottenStride per forgotten contact of the step
  bool tally_pending_ = false;
  void register_storage();
  void pack_global(double *data);
  int unpack_global(const char *buf);
  bool storage_registered_ = false;

  void parse_wall(int &iarg, int narg, char **arg);
  void parse_motion(int &iarg, int narg, char **arg);
  double wall_displacement(double &velocity);
  void check_atoms();
  static int pack_record(const WallRecord &r, double *buf);
  static int restart_record_head(double *buf, int64_t tag, double value, int body);
  const double *restart_record(int nlocal, int nth);
  static int record_size(int layout_version);
  static int unpack_record(WallRecord &r, const double *buf,
                           int layout_version = kRestartLayoutVersion);

  geocontact::LawParams law_;
  geocontact_forces::StiffnessConstants constants_;  // the law in the run's units
  double friction_, damping_;
  geocontact_forces::RollingCoeffs resistance_;
  int wallstyle_;
  double lo_, hi_, cylinder_radius_;
  std::vector<int> sides_;  // the walls of this fix: LO, HI (planes) or CYLINDER

  int motion_;
  int wiggle_axis_;
  double amplitude_, angular_frequency_, velocity_;
  int shear_axis_;
  int wall_arg_ = 0;      // the first argument after the contact keywords (REGION: its ID)
  std::string variable_;  // of position, or of the shear velocity (empty: a constant shear)
  int ivariable_;
  bigint time_origin_;
  // the position variable's last value, the wall velocity from it, and their step
  double last_position_, position_velocity_;
  bigint last_position_step_;

  std::vector<WallRecord> records_;  // sides_.size() per atom, local index major
  WallRecord setup_record_;          // the copy a setup step works on (touch_wall)
  int capacity_ = 0;                  // atoms array_atom and records_ are sized for
  double forgotten_dissipated_;      // this rank's share: contacts dropped beyond the skin
  double forgotten_ledger_[geocontact_forces::kLedgerSlots] = {};  // the same, other channels
  double forgotten_reset_ = 0.0;     // the same, memory place's change of stored energy
  double boundary_work_ = 0.0;       // this rank's share of the wall's work on the grains
  double deepest_beyond_ = 0.0;      // this rank's deepest contact beyond the calibrated range
  bool range_warned_ = false;        // the run was told of contacts beyond it
  bool range_error_ = false;         // range error: stop at the first contact beyond it
  bool place_memory_ = false;        // memory place: dents forgotten past 2 a_max of travel
  double tally_[G_COUNT];            // this rank's sums at the last post_force
  double totals_[G_COUNT];
  bool totals_current_;
  double max_stiffness_ = 0.0;       // this rank's stiffest wall contact at the last post_force

  bool unreadable_restart_;
  int64_t unreadable_tag_;
  int unreadable_walls_;
};

}  // namespace LAMMPS_NS

#endif
#endif
