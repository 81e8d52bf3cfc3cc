// fix wall/geocontact/region (see fix_wall_geocontact_region.h and examples/lammps/README.md
// "Walls").
#include "fix_wall_geocontact_region.h"

#include "contact_forces.h"
#include "contact_setup.h"
#include "contact_state.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "region.h"
#include "update.h"

#include <algorithm>
#include <cstring>

using namespace LAMMPS_NS;
using namespace LAMMPS_NS::geocontact_forces;

namespace {

constexpr const char *kWho = "Fix wall/geocontact/region";
constexpr const char *kUsage =
    "fix ID group wall/geocontact/region P.json [friction mu] [damping beta | restitution e] "
    "[rolling sds k_roll gamma_roll mu_roll] [twisting marshall] [range warn|error] [memory pair|place] region-ID";
constexpr int kSlotHeader = 2;  // per record in a buffer: wall id, effective radius

}  // namespace

FixWallGeocontactRegion::FixWallGeocontactRegion(LAMMPS *lmp, int narg, char **arg) :
    FixWallGeocontact(lmp, narg, arg), region_(nullptr), nregion_(0), slots_(0)
{
  // the base read the law file and the contact keywords; what follows is the region's ID
  const int iarg = wall_arg_;
  if (iarg >= narg) error->all(FLERR, "{}: no region ID given: {}", kWho, kUsage);
  region_id_ = arg[iarg];
  region_ = domain->get_region_by_id(region_id_);
  if (!region_) {
    if (iarg + 1 < narg)
      error->all(FLERR, "{}: unknown keyword '{}' (allowed: friction, damping, restitution, "
                        "rolling, twisting, range, memory, then a region ID)", kWho, region_id_);
    error->all(FLERR, "{}: region '{}' does not exist (define it with the region command "
                      "first)", kWho, region_id_);
  }
  if (iarg + 1 < narg)
    error->all(FLERR, "{}: unknown keyword '{}' after the region ID {} (friction, damping, "
                      "restitution, rolling, twisting, range and memory come before it)", kWho, arg[iarg + 1],
               region_id_);
  region_style_ = region_->style;
  nregion_ = region_->nregion;
  slots_ = region_->tmax;
  if (slots_ < 1) error->all(FLERR, "{}: region '{}' has no walls to touch", kWho, region_id_);
  if (region_->dynamic_check()) time_depend = 1;

  // slots_ records per atom, each with its wall id and effective radius
  size_peratom_cols = slots_ * kSlotColumns;
  maxexchange = 1 + slots_ * (kSlotHeader + kRecordSize);
  register_storage();
}

// The region may have been deleted or redefined between runs (LAMMPS's fix wall/gran/region:
// its motion is reset then, as when the restart's region record does not match).
void FixWallGeocontactRegion::init()
{
  FixWallGeocontact::init();
  Region *region = domain->get_region_by_id(region_id_);
  if (!region)
    error->all(FLERR, "{}: region '{}' does not exist (deleted after the fix was defined)",
               kWho, region_id_);
  if (region->tmax != slots_)
    error->all(FLERR, "{}: region '{}' now has {} walls per grain, the fix was defined for {}; "
                      "define the fix again", kWho, region_id_, region->tmax, slots_);
  if (region != region_ || region_style_ != region->style || nregion_ != region->nregion) {
    if (comm->me == 0)
      error->warning(FLERR, "{}: region '{}' changed since the fix was defined; its motion is "
                            "reset", kWho, region_id_);
    region_ = region;
    region_style_ = region->style;
    nregion_ = region->nregion;
    region_->reset_vel();
  }
  if (motion_reset_) {
    if (comm->me == 0)
      error->warning(FLERR, "{}: region '{}' is not the one of the restart file; its motion is "
                            "reset", kWho, region_id_);
    region_->reset_vel();
    motion_reset_ = false;
  }

  // a per-atom restart record this fix could not read: refused on every rank, the lowest rank
  // that met one names it
  const int mine = unreadable_region_ ? comm->me : comm->nprocs;
  int first = comm->nprocs;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, world);
  if (first < comm->nprocs) {
    int64_t tag = unreadable_region_tag_;
    int version = unreadable_record_version_;
    MPI_Bcast(&tag, 1, MPI_INT64_T, first, world);
    MPI_Bcast(&version, 1, MPI_INT, first, world);
    if ((tag & ~int64_t(0xffffffff)) != kRegionAtomTagBase)
      error->all(FLERR, "{}: the restart file's per-atom region contacts have no "
                        "wall/geocontact/region layout tag (0x{:016x}); this fix reads region "
                        "layout version {} only", kWho, static_cast<uint64_t>(tag),
                 kRegionLayoutVersion);
    if ((tag & 0xffffffff) != kRegionLayoutVersion)
      error->all(FLERR, "{}: the restart file's per-atom region contacts have region layout "
                        "version {}; this fix reads region layout version {} only", kWho,
                 tag & 0xffffffff, kRegionLayoutVersion);
    error->all(FLERR, "{}: the restart file's region contacts have wall record layout version "
                      "{} or more records than the region's {} walls per grain; this fix reads "
                      "wall record layout versions 1 to {}", kWho, version, slots_,
               kRestartLayoutVersion);
  }
}

// The records of atom i are matched to the region's contacts by wall id (as fix
// wall/gran/region): slot_of_[ic] is the record of contact ic, a free one taken for a wall the
// grain touches for the first time; the records of walls not reported (the grain is beyond the
// skin of that wall, or left the region) are forgotten when the step commits.
void FixWallGeocontactRegion::match_records(int i, int ncontacts, bool commit)
{
  const size_t base = static_cast<size_t>(i) * slots_;
  const double radius = atom->radius[i];
  if (static_cast<int>(slot_of_.size()) < ncontacts) slot_of_.resize(ncontacts);
  for (int s = 0; s < slots_; ++s) {
    const int wall = walls_[base + s];
    if (wall < 0) continue;
    int ic = 0;
    while (ic < ncontacts && region_->contact[ic].iwall != wall) ++ic;
    if (ic < ncontacts || !commit) continue;
    forget_contact(records_[base + s],
                   geocontact::wall_similarity(effective_[base + s],
                                               constants_.calibrated_radius));
    walls_[base + s] = -1;
  }
  for (int ic = 0; ic < ncontacts; ++ic) {
    const int wall = region_->contact[ic].iwall;
    int slot = -1;
    for (int s = 0; s < slots_ && slot < 0; ++s)
      if (walls_[base + s] == wall) slot = s;
    if (slot < 0 && region_->contact[ic].r < radius) {  // a first touch: a free record
      for (int s = 0; s < slots_ && slot < 0; ++s)
        if (walls_[base + s] < 0) slot = s;
      if (slot < 0)
        error->one(FLERR, "{}: atom {} touches more than the {} walls per grain of region '{}'",
                   kWho, atom->tag[i], slots_, region_id_);
      walls_[base + slot] = wall;
      records_[base + slot].active = 0;
    }
    slot_of_[ic] = slot;
  }
}

void FixWallGeocontactRegion::post_force(int /*vflag*/)
{
  // During setup the forces are evaluated but the history is not advanced (as fix wall/gran).
  const bool commit = !update->setupflag;
  const bool moving = region_->dynamic_check();
  // the region's variables (its motion, its shape) once per step, on every rank
  modify->clearstep_compute();
  region_->prematch();
  if (moving) region_->set_velocity();  // from the region's last two positions and angles
  modify->addstep_compute(update->ntimestep + 1);

  double **x = atom->x;
  const double *radius = atom->radius;
  const int *mask = atom->mask;
  const int nlocal = atom->nlocal;
  const double skin = neighbor->skin;

  begin_tally();

  for (int i = 0; i < nlocal; ++i) {
    double *out = array_atom[i];
    for (int c = 0; c < size_peratom_cols; ++c) out[c] = 0.0;
    for (int s = 0; s < slots_; ++s) out[s * kSlotColumns] = -1.0;
    if (!(mask[i] & groupbit)) continue;
    // the region's walls within the skin of the grain's surface
    int ncontacts = 0;
    if (region_->match(x[i][0], x[i][1], x[i][2]))
      ncontacts = region_->surface(x[i][0], x[i][1], x[i][2], radius[i] + skin);
    match_records(i, ncontacts, commit);
    const size_t base = static_cast<size_t>(i) * slots_;
    for (int ic = 0; ic < ncontacts; ++ic) {
      const int slot = slot_of_[ic];
      if (slot < 0) continue;  // apart, never touched
      const Region::Contact &rc = region_->contact[ic];
      if (!(rc.r > 0.0)) continue;  // the centre on the surface: no direction to the wall
      const double effective = geocontact::wall_effective_radius(radius[i], rc.radius);
      if (!(effective > 0.0))
        error->one(FLERR, "{}: atom {} of radius {} touches a concave wall of region '{}' whose "
                          "radius of curvature {} is not larger; the law needs a grain smaller "
                          "than the wall's curvature (docs/dem.md, Region walls)", kWho,
                   atom->tag[i], radius[i], region_id_, -rc.radius);
      WallContact contact{radius[i] - rc.r,
                          {rc.delx / rc.r, rc.dely / rc.r, rc.delz / rc.r},
                          {0.0, 0.0, 0.0},
                          effective};
      if (moving) region_->velocity_contact(contact.velocity, x[i], ic);
      effective_[base + slot] = effective;
      double *slot_out = out + slot * kSlotColumns;
      slot_out[0] = rc.iwall;
      touch_wall(i, records_[base + slot], contact, commit, slot_out + 1);
    }
  }
  tally_pending_ = commit;
}

// --- per-atom storage: exchange, sorting, restart ---------------------------------------------

int FixWallGeocontactRegion::count(int i) const
{
  const size_t base = static_cast<size_t>(i) * slots_;
  return static_cast<int>(std::count_if(walls_.begin() + base, walls_.begin() + base + slots_,
                                        [](int wall) { return wall >= 0; }));
}

void FixWallGeocontactRegion::grow_arrays(int nmax)
{
  // only ever grows (FixWallGeocontact::grow_arrays)
  if (nmax <= capacity_) return;
  capacity_ = nmax;
  const size_t size = static_cast<size_t>(nmax) * slots_;
  if (records_.size() < size) {
    records_.resize(size);
    walls_.resize(size, -1);
    effective_.resize(size, 0.0);
  }
  memory->grow(array_atom, nmax, size_peratom_cols, "wall/geocontact/region:array_atom");
}

void FixWallGeocontactRegion::copy_arrays(int i, int j, int /*delflag*/)
{
  finish_tally();  // before the records move
  const size_t from = static_cast<size_t>(i) * slots_, to = static_cast<size_t>(j) * slots_;
  std::copy_n(records_.begin() + from, slots_, records_.begin() + to);
  std::copy_n(walls_.begin() + from, slots_, walls_.begin() + to);
  std::copy_n(effective_.begin() + from, slots_, effective_.begin() + to);
  for (int c = 0; c < size_peratom_cols; ++c) array_atom[j][c] = array_atom[i][c];
}

void FixWallGeocontactRegion::set_arrays(int i)
{
  const size_t base = static_cast<size_t>(i) * slots_;
  for (int s = 0; s < slots_; ++s) {
    WallRecord &r = records_[base + s];
    r.law = geocontact::ContactState();
    clear_springs(r);
    clear_ledger(r);
    r.active = 0;
    walls_[base + s] = -1;
    effective_[base + s] = 0.0;
  }
  for (int c = 0; c < size_peratom_cols; ++c) array_atom[i][c] = 0.0;
}

// [count, count x (wall id, effective radius, wall record)]
int FixWallGeocontactRegion::pack_slots(int i, double *buf) const
{
  const size_t base = static_cast<size_t>(i) * slots_;
  int m = 0;
  buf[m++] = count(i);
  for (int s = 0; s < slots_; ++s) {
    if (walls_[base + s] < 0) continue;
    buf[m++] = walls_[base + s];
    buf[m++] = effective_[base + s];
    m += pack_record(records_[base + s], buf + m);
  }
  return m;
}

int FixWallGeocontactRegion::unpack_slots(int i, const double *buf, int record_version)
{
  const size_t base = static_cast<size_t>(i) * slots_;
  int m = 0;
  const int n = static_cast<int>(buf[m++]);
  for (int s = 0; s < n; ++s) {
    walls_[base + s] = static_cast<int>(buf[m++]);
    effective_[base + s] = buf[m++];
    m += unpack_record(records_[base + s], buf + m, record_version);
  }
  return m;
}

int FixWallGeocontactRegion::pack_exchange(int i, double *buf)
{
  finish_tally();  // before the records move
  return pack_slots(i, buf);
}

int FixWallGeocontactRegion::unpack_exchange(int nlocal, double *buf)
{
  grow_arrays(nlocal + 1);
  set_arrays(nlocal);
  return unpack_slots(nlocal, buf, kRestartLayoutVersion);
}

// Per atom: [length, layout tag, wall record layout version, slots]; buf[0] counts itself.
int FixWallGeocontactRegion::pack_restart(int i, double *buf)
{
  return restart_record_head(buf, kRegionAtomTag, kRestartLayoutVersion,
                             pack_slots(i, buf + kRegionAtomHeader - 1));
}

// A record of another layout, or with more records than the region has walls per grain, is
// never unpacked: the atom is left without wall contacts and init() refuses the run on every
// rank.
void FixWallGeocontactRegion::unpack_restart(int nlocal, int nth)
{
  const double *record = restart_record(nlocal, nth);
  const int64_t tag = ubuf(record[1]).i;
  const int version = static_cast<int>(record[2]);
  const int n = tag == kRegionAtomTag ? static_cast<int>(record[3]) : -1;
  const bool readable = tag == kRegionAtomTag && version >= 1 &&
                        version <= kRestartLayoutVersion && n >= 0 && n <= slots_ &&
                        static_cast<int>(record[0]) ==
                            kRegionAtomHeader + n * (kSlotHeader + record_size(version));
  if (!readable) {
    if (!unreadable_region_) {
      unreadable_region_tag_ = tag;
      unreadable_record_version_ = version;
    }
    unreadable_region_ = true;
    return;
  }
  unpack_slots(nlocal, record + kRegionAtomHeader - 1, version);
}

int FixWallGeocontactRegion::size_restart(int i)
{
  return kRegionAtomHeader + count(i) * (kSlotHeader + kRecordSize);
}

int FixWallGeocontactRegion::maxsize_restart()
{
  return kRegionAtomHeader + slots_ * (kSlotHeader + kRecordSize);
}

// Global: [tag "GCRG" + version, the wall fix's global block (FixWallGeocontact::pack_global:
// the energy dissipated by contacts already forgotten, summed over ranks), then the region's
// record of its last position and angle, so a moving region's velocity continues
// (Region::write_restart, as fix wall/gran/region).
void FixWallGeocontactRegion::write_restart(FILE *fp)
{
  double data[1 + kGlobalSize];
  data[0] = ubuf(kRegionGlobalTag).d;
  pack_global(data + 1);
  if (comm->me != 0) return;
  int region_length = 0;
  region_->length_restart_string(region_length);
  const int size = static_cast<int>(sizeof(data)) + region_length;
  fwrite(&size, sizeof(int), 1, fp);
  fwrite(data, sizeof(double), 1 + kGlobalSize, fp);
  region_->write_restart(fp);
}

void FixWallGeocontactRegion::restart(char *buf)
{
  double head;
  memcpy(&head, buf, sizeof(head));
  const int64_t tag = ubuf(head).i;
  if (tag != kRegionGlobalTag)
    error->all(FLERR, "{}: the restart file's global region wall data has {} (tag 0x{:016x}); "
                      "this fix reads region layout version {} only", kWho,
               (tag & ~int64_t(0xffffffff)) == kRegionGlobalTagBase
                   ? "another layout version" : "no wall/geocontact/region layout tag",
               static_cast<uint64_t>(tag), kRegionLayoutVersion);
  int offset = static_cast<int>(sizeof(head));
  offset += unpack_global(buf + offset);
  if (!region_->restart(buf, offset)) motion_reset_ = true;
}

double FixWallGeocontactRegion::memory_usage()
{
  return static_cast<double>(records_.capacity()) * sizeof(WallRecord) +
         static_cast<double>(walls_.capacity()) * (sizeof(int) + sizeof(double)) +
         static_cast<double>(atom->nmax) * size_peratom_cols * sizeof(double);
}
