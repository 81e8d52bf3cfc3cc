// fix wall/geocontact/region: the walls of any LAMMPS region, moving, rotating or changing shape,
// in the manner of LAMMPS's fix wall/gran/region (examples/lammps/README.md "Walls").
//
//   fix ID group wall/geocontact/region P.json [friction mu] [damping beta]
//       [rolling sds k_roll gamma_roll mu_roll] [twisting marshall] [range warn|error]
//       [memory pair|place] region-ID
//
// The same contact as fix wall/geocontact (it is derived from it and calls its per-contact step,
// FixWallGeocontact::touch_wall): the ball-wall law of the FE half model, the Mindlin-Coulomb
// tangential force, damping, rolling and twisting, the run's units. Where the region's surface
// is curved the grain of radius r is the flat wall's grain of the effective radius
// R_eff = r rho / (r + rho), rho the region's signed radius of curvature at the contact point
// (geocontact::wall_effective_radius; docs/dem.md "Region walls"); R_eff is also the rolling
// radius. The wall's velocity at the contact point (Region::velocity_contact: translation,
// rotation about the region's axis, a changing radius) enters the relative velocity.
// memory place: the contact point's travel over the grain (contact_forces.h track_place) takes
// the turn of the contact normal from step to step, which the region's curvature and its
// rotation give (FixWallGeocontact::track_wall_place).
//
// One contact record per (atom, region wall): a region reports each of its walls with an id
// (Region::Contact::iwall; a block's six faces, a cylinder's side and caps, the members of a
// union); an atom keeps up to the region's tmax records, each with its wall id and effective
// radius, created on first touch and forgotten (its dissipation tallied) once the atom is beyond
// the neighbor skin of that wall, as fix wall/geocontact does for its planes.
//
// Output as fix wall/geocontact: the same global vector; per-atom array of tmax slots of
// 1 + kOutputColumns columns each: the wall id of the slot's record (-1: none), then interference,
// normal force, |tangential force|, max and residual interference, branch of the law.
#ifdef FIX_CLASS
// clang-format off
FixStyle(wall/geocontact/region,FixWallGeocontactRegion);
// clang-format on
#else

#ifndef LMP_FIX_WALL_GEOCONTACT_REGION_H
#define LMP_FIX_WALL_GEOCONTACT_REGION_H

#include "fix_wall_geocontact.h"

#include <string>
#include <vector>

namespace LAMMPS_NS {

class FixWallGeocontactRegion : public FixWallGeocontact {
 public:
  static constexpr int kSlotColumns = 1 + kOutputColumns;
  // Restart layout of the region's records, bumped whenever it changes. Per atom [length, tag
  // "GCRA" + version, the wall record layout version (FixWallGeocontact::kRestartLayoutVersion),
  // count, count x (wall id, effective radius, wall record)]; global [tag "GCRG" + version,
  // the wall fix's global block (FixWallGeocontact::pack_global, its own tag and version
  // inside), then the region's own motion record (Region::write_restart, as fix
  // wall/gran/region)].
  static constexpr int kRegionLayoutVersion = 1;
  static constexpr int64_t kRegionAtomTagBase = static_cast<int64_t>(0x41524347) << 32;
  static constexpr int64_t kRegionAtomTag = kRegionAtomTagBase | kRegionLayoutVersion;
  static constexpr int64_t kRegionGlobalTagBase = static_cast<int64_t>(0x47524347) << 32;
  static constexpr int64_t kRegionGlobalTag = kRegionGlobalTagBase | kRegionLayoutVersion;
  static constexpr int kRegionAtomHeader = 4;

  FixWallGeocontactRegion(class LAMMPS *, int, char **);
  void init() override;
  void post_force(int) override;

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

 private:
  class Region *region_;
  std::string region_id_;
  std::string region_style_;
  int nregion_;
  int slots_;                      // records per atom: the region's tmax
  std::vector<int> walls_;         // the wall id of each record (-1: free), slots_ per atom
  std::vector<double> effective_;  // the effective radius of each record's last step
  std::vector<int> slot_of_;       // per reported contact: its record (-1: none)
  bool motion_reset_ = false;      // the restart's region record did not match this region

  void find_region();
  int count(int i) const;
  void match_records(int i, int ncontacts, bool commit);
  int pack_slots(int i, double *buf) const;
  int unpack_slots(int i, const double *buf, int record_version);
  // a per-atom restart record this fix could not read: reported in init() on every rank
  bool unreadable_region_ = false;
  int64_t unreadable_region_tag_ = 0;
  int unreadable_record_version_ = 0;
};

}  // namespace LAMMPS_NS

#endif
#endif
