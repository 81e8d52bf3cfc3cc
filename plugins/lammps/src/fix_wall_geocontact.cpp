// fix wall/geocontact (see fix_wall_geocontact.h and examples/lammps/README.md "Walls").
#include "fix_wall_geocontact.h"

#include "contact_forces.h"
#include "contact_setup.h"
#include "contact_state.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "input.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "update.h"
#include "utils.h"
#include "variable.h"

#include <algorithm>
#include <cmath>
#include <cstring>

using namespace LAMMPS_NS;
using namespace LAMMPS_NS::geocontact_forces;
using namespace FixConst;

namespace {

constexpr double kDefaultFriction = 0.5;

constexpr double kPi = 3.14159265358979323846;
constexpr const char *kWallNames[] = {"xplane", "yplane", "zplane", "zcylinder"};
constexpr const char *kUsage =
    "fix ID group wall/geocontact P.json [friction mu] [damping beta | restitution e] "
    "[rolling sds k_roll gamma_roll mu_roll] [twisting marshall] [range warn|error] "
    "[memory pair|place] xplane|yplane|zplane lo hi | zcylinder R [wiggle dim A period | velocity v | "
    "position v_name | shear dim V|v_name]";

}  // namespace

FixWallGeocontact::FixWallGeocontact(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), friction_(kDefaultFriction), damping_(0.0), resistance_{},
    wallstyle_(ZPLANE),
    lo_(0.0), hi_(0.0), cylinder_radius_(0.0), motion_(STATIC), wiggle_axis_(2),
    amplitude_(0.0), angular_frequency_(0.0), velocity_(0.0), shear_axis_(0), ivariable_(-1),
    last_position_(0.0), position_velocity_(0.0), last_position_step_(-1),
    forgotten_dissipated_(0.0), totals_current_(false), unreadable_restart_(false),
    unreadable_tag_(0), unreadable_walls_(0)
{
  if (narg < 5) error->all(FLERR, "Illegal fix wall/geocontact command: {}", kUsage);
  if (!atom->radius_flag || !atom->rmass_flag || !atom->omega_flag || !atom->torque_flag)
    error->all(FLERR, "Fix wall/geocontact requires atom style sphere (per-atom radius, mass, "
                      "angular velocity and torque); current atom style is {}",
               atom->atom_style);

  law_ = parse_law(lmp, read_text_collective(lmp, arg[3], "Fix wall/geocontact"), arg[3],
                   "Fix wall/geocontact");
  constants_ = stiffness_constants(law_, run_units(lmp, "Fix wall/geocontact"));

  int iarg = 4;
  char damping_given = 0;
  while (iarg < narg) {
    if (parse_resistance(lmp, iarg, narg, arg, resistance_, "Fix wall/geocontact")) continue;
    if (parse_range(lmp, iarg, narg, arg, range_error_, "Fix wall/geocontact")) continue;
    if (parse_memory(lmp, iarg, narg, arg, place_memory_, "Fix wall/geocontact")) continue;
    if (parse_damping(lmp, iarg, narg, arg, damping_, damping_given, "Fix wall/geocontact"))
      continue;
    if (strcmp(arg[iarg], "friction") != 0) break;
    if (iarg + 1 >= narg)
      error->all(FLERR, "Fix wall/geocontact: keyword '{}' needs a value", arg[iarg]);
    friction_ = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    if (friction_ < 0.0)
      error->all(FLERR, "Fix wall/geocontact: friction must be >= 0, got {}", friction_);
    iarg += 2;
  }
  wall_arg_ = iarg;
  if (utils::strmatch(style, "^wall/geocontact/region")) {
    wallstyle_ = REGION;  // the region ID and its walls: FixWallGeocontactRegion
  } else {
    parse_wall(iarg, narg, arg);
    parse_motion(iarg, narg, arg);
  }

  const int *periodic = domain->periodicity;
  if (wallstyle_ <= ZPLANE && periodic[wallstyle_])
    error->all(FLERR, "Fix wall/geocontact: {} wall in a periodic dimension",
               kWallNames[wallstyle_]);
  if (wallstyle_ == ZCYLINDER && (periodic[0] || periodic[1]))
    error->all(FLERR, "Fix wall/geocontact: zcylinder needs non-periodic x and y");

  vector_flag = 1;
  size_vector = G_COUNT;
  global_freq = 1;
  extvector = 1;
  peratom_flag = 1;
  size_peratom_cols = static_cast<int>(sides_.size()) * kOutputColumns;
  peratom_freq = 1;
  restart_global = 1;
  restart_peratom = 1;
  create_attribute = 1;
  dynamic_group_allow = 1;
  if (motion_ != STATIC) time_depend = 1;
  maxexchange = static_cast<int>(sides_.size()) * kRecordSize;
  for (int k = 0; k < G_COUNT; ++k) tally_[k] = totals_[k] = 0.0;
  time_origin_ = update->ntimestep;

  array_atom = nullptr;
  // a region's walls are read by FixWallGeocontactRegion, which then sizes the records
  if (wallstyle_ != REGION) register_storage();
}

FixWallGeocontact::~FixWallGeocontact()
{
  if (storage_registered_) {
    atom->delete_callback(id, Atom::GROW);
    atom->delete_callback(id, Atom::RESTART);
  }
  memory->destroy(array_atom);
}

// The per-atom records sized and registered with the atoms (once the walls are known; a fix
// whose constructor stops before has no callbacks to remove).
void FixWallGeocontact::register_storage()
{
  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
  atom->add_callback(Atom::RESTART);
  for (int i = 0; i < atom->nlocal; ++i) set_arrays(i);
  storage_registered_ = true;
}

// xplane|yplane|zplane lo hi (NULL: no wall on that side) | zcylinder R
void FixWallGeocontact::parse_wall(int &iarg, int narg, char **arg)
{
  if (iarg >= narg)
    error->all(FLERR, "Fix wall/geocontact: no wall given (xplane, yplane, zplane or "
                      "zcylinder): {}", kUsage);
  const std::string style = arg[iarg];
  if (style == "xplane" || style == "yplane" || style == "zplane") {
    wallstyle_ = style[0] - 'x';
    if (iarg + 2 >= narg)
      error->all(FLERR, "Fix wall/geocontact: {} needs lo and hi (NULL for no wall)", style);
    const bool has_lo = strcmp(arg[iarg + 1], "NULL") != 0;
    const bool has_hi = strcmp(arg[iarg + 2], "NULL") != 0;
    if (has_lo) lo_ = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    if (has_hi) hi_ = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
    if (!has_lo && !has_hi)
      error->all(FLERR, "Fix wall/geocontact: {} NULL NULL has no wall", style);
    if (has_lo && has_hi && lo_ > hi_)
      error->all(FLERR, "Fix wall/geocontact: {} lo ({}) must not be above hi ({})", style,
                 lo_, hi_);
    if (has_lo) sides_.push_back(LO);
    if (has_hi) sides_.push_back(HI);
    iarg += 3;
  } else if (style == "zcylinder") {
    wallstyle_ = ZCYLINDER;
    if (iarg + 1 >= narg) error->all(FLERR, "Fix wall/geocontact: zcylinder needs a radius R");
    cylinder_radius_ = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    if (!(cylinder_radius_ > 0.0))
      error->all(FLERR, "Fix wall/geocontact: zcylinder radius must be > 0, got {}",
                 cylinder_radius_);
    sides_.push_back(CYLINDER);
    iarg += 2;
  } else {
    error->all(FLERR, "Fix wall/geocontact: unknown keyword '{}' (allowed: friction, damping, "
                      "restitution, rolling, twisting, xplane, yplane, zplane, zcylinder)", style);
  }
}

// wiggle dim A period | velocity v | position v_name | shear dim V|v_name (at most one)
void FixWallGeocontact::parse_motion(int &iarg, int narg, char **arg)
{
  while (iarg < narg) {
    const std::string key = arg[iarg];
    if (key != "wiggle" && key != "velocity" && key != "position" && key != "shear")
      error->all(FLERR, "Fix wall/geocontact: unknown keyword '{}' (allowed after the wall: "
                        "wiggle, velocity, position, shear)", key);
    if (motion_ != STATIC)
      error->all(FLERR, "Fix wall/geocontact: '{}' after another wall motion (one of wiggle, "
                        "velocity, position, shear)", key);
    if (key == "shear") {
      if (iarg + 2 >= narg)
        error->all(FLERR, "Fix wall/geocontact: shear needs dim and a velocity (a number or "
                          "v_name)");
      const std::string dim = arg[iarg + 1];
      if (dim != "x" && dim != "y" && dim != "z")
        error->all(FLERR, "Fix wall/geocontact: shear dim must be x, y or z, got '{}'", dim);
      shear_axis_ = dim[0] - 'x';
      if (wallstyle_ == ZCYLINDER && shear_axis_ != 2)
        error->all(FLERR, "Fix wall/geocontact: a zcylinder shears along z only, got '{}'", dim);
      if (wallstyle_ <= ZPLANE && shear_axis_ == wallstyle_)
        error->all(FLERR, "Fix wall/geocontact: shear dim must lie in the {} wall (not its "
                          "normal {}), got '{}'", kWallNames[wallstyle_], dim, dim);
      if (strncmp(arg[iarg + 2], "v_", 2) == 0) {
        variable_ = arg[iarg + 2] + 2;
        if (variable_.empty())
          error->all(FLERR, "Fix wall/geocontact: shear velocity 'v_' names no variable");
      } else {
        velocity_ = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
      }
      motion_ = SHEAR;
      iarg += 3;
    } else if (key == "wiggle") {
      if (iarg + 3 >= narg)
        error->all(FLERR, "Fix wall/geocontact: wiggle needs dim amplitude period");
      const std::string dim = arg[iarg + 1];
      if (dim != "x" && dim != "y" && dim != "z")
        error->all(FLERR, "Fix wall/geocontact: wiggle dim must be x, y or z, got '{}'", dim);
      wiggle_axis_ = dim[0] - 'x';
      if (wallstyle_ == ZCYLINDER && wiggle_axis_ != 2)
        error->all(FLERR, "Fix wall/geocontact: a zcylinder wiggles along z only, got '{}'",
                   dim);
      amplitude_ = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
      const double period = utils::numeric(FLERR, arg[iarg + 3], false, lmp);
      if (!(period > 0.0))
        error->all(FLERR, "Fix wall/geocontact: wiggle period must be > 0, got {}", period);
      angular_frequency_ = 2.0 * kPi / period;
      motion_ = WIGGLE;
      iarg += 4;
    } else {
      if (iarg + 1 >= narg)
        error->all(FLERR, "Fix wall/geocontact: keyword '{}' needs a value", key);
      if (key == "velocity") {
        velocity_ = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
        motion_ = VELOCITY;
      } else {
        if (strncmp(arg[iarg + 1], "v_", 2) != 0)
          error->all(FLERR, "Fix wall/geocontact: position needs an equal-style variable "
                            "v_name, got '{}'", arg[iarg + 1]);
        variable_ = arg[iarg + 1] + 2;
        motion_ = POSITION;
      }
      iarg += 2;
    }
  }
}

int FixWallGeocontact::setmask()
{
  return POST_FORCE | POST_RUN;
}

void FixWallGeocontact::init()
{
  if (!variable_.empty()) {
    const char *what = motion_ == POSITION ? "position" : "shear";
    ivariable_ = input->variable->find(variable_.c_str());
    if (ivariable_ < 0)
      error->all(FLERR, "Fix wall/geocontact: variable '{}' of {} does not exist", variable_,
                 what);
    if (!input->variable->equalstyle(ivariable_))
      error->all(FLERR, "Fix wall/geocontact: variable '{}' of {} is not equal-style",
                 variable_, what);
  }
  // A per-atom restart record this fix could not read: refused on every rank, the lowest rank
  // that met one names it.
  const int mine = unreadable_restart_ ? comm->me : comm->nprocs;
  int first = comm->nprocs;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, world);
  if (first < comm->nprocs) {
    int64_t tag = unreadable_tag_;
    int walls = unreadable_walls_;
    MPI_Bcast(&tag, 1, MPI_INT64_T, first, world);
    MPI_Bcast(&walls, 1, MPI_INT, first, world);
    if ((tag & ~int64_t(0xffffffff)) != kAtomTagBase)
      error->all(FLERR, "Fix wall/geocontact: the restart file's per-atom wall contacts have no "
                        "wall/geocontact layout tag (0x{:016x}); this fix reads wall layout "
                        "versions 1 to {} only", static_cast<uint64_t>(tag), kRestartLayoutVersion);
    if ((tag & 0xffffffff) < 1 || (tag & 0xffffffff) > kRestartLayoutVersion)
      error->all(FLERR, "Fix wall/geocontact: the restart file's per-atom wall contacts have wall "
                        "layout version {}; this fix reads wall layout versions 1 to {} only",
                 tag & 0xffffffff, kRestartLayoutVersion);
    error->all(FLERR, "Fix wall/geocontact: the restart file's wall contacts are for {} wall(s), "
                      "this fix {} has {}", walls, id, sides_.size());
  }
  check_atoms();
}

void FixWallGeocontact::check_atoms()
{
  const double *radius = atom->radius;
  const int *mask = atom->mask;
  tagint bad = -1;
  double bad_radius = 0.0;
  for (int i = 0; i < atom->nlocal && bad < 0; ++i)
    if ((mask[i] & groupbit) && !(radius[i] > 0.0)) {
      bad = atom->tag[i];
      bad_radius = radius[i];
    }
  tagint any = -1;
  MPI_Allreduce(&bad, &any, 1, MPI_LMP_TAGINT, MPI_MAX, world);
  if (any < 0) return;
  double r = any == bad ? bad_radius : -INFINITY, rall = 0.0;
  MPI_Allreduce(&r, &rall, 1, MPI_DOUBLE, MPI_MAX, world);
  error->all(FLERR, "Fix wall/geocontact: atom {} has radius {} m; every grain needs a radius "
                    "> 0 (set diameter)", any, rall);
}

void FixWallGeocontact::setup(int vflag)
{
  post_force(vflag);
}

// Displacement of the wall along its normal (planes; the radius of a cylinder) or along the
// wiggle axis, and its velocity, at the current step.
double FixWallGeocontact::wall_displacement(double &velocity)
{
  const double t = static_cast<double>(update->ntimestep - time_origin_) * update->dt;
  velocity = 0.0;
  if (motion_ == WIGGLE) {
    const double phase = angular_frequency_ * t;
    velocity = amplitude_ * angular_frequency_ * std::sin(phase);
    return amplitude_ - amplitude_ * std::cos(phase);  // starts at rest at its given place
  }
  if (motion_ == VELOCITY) {
    velocity = velocity_;
    return velocity_ * t;
  }
  if (motion_ == SHEAR) {  // in the wall's plane: the velocity only, the wall stays in place
    if (variable_.empty()) {
      velocity = velocity_;
    } else {
      modify->clearstep_compute();
      velocity = input->variable->compute_equal(ivariable_);
      modify->addstep_compute(update->ntimestep + 1);
    }
    return 0.0;
  }
  if (motion_ == POSITION) {
    modify->clearstep_compute();
    const double position = input->variable->compute_equal(ivariable_);
    modify->addstep_compute(update->ntimestep + 1);
    // the velocity from the last two steps at which the wall was placed (0 before there are two)
    const bigint step = update->ntimestep;
    if (step != last_position_step_) {
      if (last_position_step_ >= 0)
        position_velocity_ = (position - last_position_) /
            (static_cast<double>(step - last_position_step_) * update->dt);
      last_position_ = position;
      last_position_step_ = step;
    }
    velocity = position_velocity_;
    return position;
  }
  return 0.0;
}

void FixWallGeocontact::post_force(int /*vflag*/)
{
  // During setup the forces are evaluated but the history is not advanced (as fix wall/gran):
  // the first step of the run then moves from the stored state.
  const bool commit = !update->setupflag;

  double wall_velocity = 0.0;
  const double shift = wall_displacement(wall_velocity);
  // the wall's velocity: along the wiggle axis, or along the plane's normal axis
  double vwall[3] = {0.0, 0.0, 0.0};
  double lo = lo_, hi = hi_, cylinder = cylinder_radius_;
  const int normal_axis = wallstyle_ <= ZPLANE ? wallstyle_ : -1;
  if (motion_ == WIGGLE) {
    vwall[wiggle_axis_] = wall_velocity;
    if (wiggle_axis_ == normal_axis) {
      lo += shift;
      hi += shift;
    }
  } else if (motion_ == SHEAR) {
    vwall[shear_axis_] = wall_velocity;
  } else if (motion_ != STATIC) {
    if (normal_axis >= 0) {
      vwall[normal_axis] = wall_velocity;
      lo += shift;
      hi += shift;
    } else {
      cylinder += shift;  // the radius grows at wall_velocity (radial, set per contact)
    }
  }

  double **x = atom->x;
  const double *radius = atom->radius;
  const int *mask = atom->mask;
  const int nlocal = atom->nlocal;
  const int nwalls = static_cast<int>(sides_.size());

  begin_tally();

  for (int i = 0; i < nlocal; ++i) {
    double *out = array_atom[i];
    const bool member = mask[i] & groupbit;
    for (int w = 0; w < nwalls; ++w, out += kOutputColumns) {
      for (int c = 0; c < kOutputColumns; ++c) out[c] = 0.0;
      if (!member) continue;
      // distance from the wall to the centre, and the unit normal from the wall to the grain
      double distance;
      WallContact contact{0.0, {0.0, 0.0, 0.0}, {vwall[0], vwall[1], vwall[2]}, radius[i]};
      double *n = contact.n;
      if (sides_[w] == LO) {
        distance = x[i][normal_axis] - lo;
        n[normal_axis] = 1.0;
      } else if (sides_[w] == HI) {
        distance = hi - x[i][normal_axis];
        n[normal_axis] = -1.0;
      } else {
        const double rho = std::sqrt(x[i][0] * x[i][0] + x[i][1] * x[i][1]);
        if (!(rho > 0.0)) continue;  // on the axis: no direction to the wall
        distance = cylinder - rho;
        n[0] = -x[i][0] / rho;
        n[1] = -x[i][1] / rho;
        if (motion_ == VELOCITY || motion_ == POSITION)
          for (int c = 0; c < 2; ++c) contact.velocity[c] = -wall_velocity * n[c];
      }
      contact.interference = radius[i] - distance;
      touch_wall(i, records_[static_cast<size_t>(i) * nwalls + w], contact, commit, out);
    }
  }
  tally_pending_ = commit;
}

// The tallies of this rank start from the dissipation of the contacts already forgotten.
void FixWallGeocontact::begin_tally()
{
  for (int k = 0; k < G_COUNT; ++k) tally_[k] = 0.0;
  tally_[G_DISSIPATED] = forgotten_dissipated_;
  for (int k = 0; k < kLedgerSlots; ++k) tally_[G_SLIDING + k] = forgotten_ledger_[k];
  tally_[G_MEMORY_RESET] = forgotten_reset_;
  totals_current_ = false;
  max_stiffness_ = 0.0;
  deepest_beyond_ = 0.0;
  tally_pending_ = false;
  tallied_.clear();
  forgotten_step_.clear();
}

// A contact left beyond the skin is forgotten, as a pair leaving the neighbor list; the energy
// it dissipated stays in the tally (when the step's tallies are summed: finish_tally).
void FixWallGeocontact::forget_contact(WallRecord &stored, const geocontact::Similarity &sim)
{
  double dissipated = sim.energy * constants_.energy_to_run *
                      geocontact::dissipated_energy(law_, stored.law);
  if (place_memory_) dissipated += stored.forgotten;  // the law's work over forgotten dents
  forgotten_dissipated_ += dissipated;
  tallied_.push_back({-static_cast<long>(forgotten_step_.size() / kForgottenStride) - 1, 0.0});
  forgotten_step_.push_back(dissipated);
  for (int k = 0; k < kLedgerSlots; ++k) {
    forgotten_ledger_[k] += stored.dissipated[k];
    forgotten_step_.push_back(stored.dissipated[k]);
  }
  forgotten_reset_ += stored.reset_stored;
  forgotten_step_.push_back(stored.reset_stored);
  stored.law = geocontact::ContactState();
  clear_springs(stored);
  clear_ledger(stored);
  clear_place(stored);
  stored.active = 0;
}

// No travel, nothing due or forgotten, no normal yet (a new or forgotten contact).
void FixWallGeocontact::clear_place(WallRecord &rec)
{
  rec.travel[0] = rec.travel[1] = 0.0;
  rec.due = 0;
  rec.forgotten = rec.reset_stored = 0.0;
  rec.normal[0] = rec.normal[1] = rec.normal[2] = 0.0;
}

// memory place, one committed step of a known contact before its law step: the contact point
// moves over the grain at b |dn/dt - w x n| (contact_forces.h travel_rates, with the wall as the
// rigid body j: only the grain's side has a dent), b = r - w the arm. dn/dt is taken from the
// last step's normal, (n - n_prev) / dt, which holds for any wall: 0 on a fixed plane, the turn
// of the normal as the grain moves along a curved wall (its motion relative to the wall's
// surface) or as a rotating region turns under it. The dent is forgotten by the same
// energy-safe rule as the pair's (track_place).
void FixWallGeocontact::track_wall_place(WallRecord &rec, const WallContact &contact,
                                         const geocontact::Similarity &sim, double arm,
                                         const double *omega)
{
  const double dt = update->dt;
  const double *n = contact.n, *before = rec.normal;
  const bool turned = before[0] != 0.0 || before[1] != 0.0 || before[2] != 0.0;
  double spin[3];
  cross3(omega, n, spin);
  double slip[3];
  for (int k = 0; k < 3; ++k) slip[k] = (turned ? (n[k] - before[k]) / dt : 0.0) - spin[k];
  track_place(law_, constants_, sim, rec, arm * std::sqrt(dot3(slip, slip)), 0.0, dt);
}

// One contact's share of the tallies: its law state (`rec`, after the step) and the springs and
// ledger of `springs_from` (the stored record; none for a contact not yet recorded in setup).
void FixWallGeocontact::tally_contact(const WallRecord &rec, const WallRecord *springs_from,
                                      const geocontact::Similarity &sim)
{
  const double energy_scale = sim.energy * constants_.energy_to_run;
  const geocontact::ContactState &st = rec.law;
  const double stored_energy = energy_scale * geocontact::elastic_energy(law_, st);
  double law_dissipated = energy_scale * st.work - stored_energy;
  if (place_memory_) {
    law_dissipated += rec.forgotten;  // the law's work over the dents it forgot
    tally_[G_MEMORY_RESET] += rec.reset_stored;
  }
  tally_[G_DISSIPATED] += law_dissipated;
  tally_[G_ELASTIC] += stored_energy;
  if (st.force > 0.0) tally_[G_CONTACTS] += 1.0;
  if (springs_from) {
    for (int k = 0; k < kLedgerSlots; ++k) tally_[G_SLIDING + k] += springs_from->dissipated[k];
    const SpringEnergy springs = spring_energy(*springs_from, constants_, sim, resistance_);
    tally_[G_STORED_TANGENTIAL] += springs.tangential;
    tally_[G_STORED_ROLLING] += springs.rolling;
    tally_[G_STORED_TWISTING] += springs.twisting;
  }
  const double depth = st.max_approach / law_.yield_approach;
  if (depth > law_.calibrated_depth) {  // calibrated_range.max_depth (infinite: none)
    tally_[G_BEYOND_RANGE] += 1.0;
    deepest_beyond_ = std::max(deepest_beyond_, depth);
  }
}

// The committed step's tallies, in its order (tallied_), from the records as the step left
// them.
void FixWallGeocontact::finish_tally()
{
  if (!tally_pending_) return;
  tally_pending_ = false;
  for (const TallyEntry &entry : tallied_) {
    if (entry.record < 0) {
      const double *gone = &forgotten_step_[(-entry.record - 1) * kForgottenStride];
      tally_[G_DISSIPATED] += gone[0];
      for (int k = 0; k < kLedgerSlots; ++k) tally_[G_SLIDING + k] += gone[1 + k];
      tally_[G_MEMORY_RESET] += gone[1 + kLedgerSlots];
      continue;
    }
    const WallRecord &rec = records_[entry.record];
    tally_contact(rec, &rec,
                  geocontact::wall_similarity(entry.effective_radius,
                                              constants_.calibrated_radius));
  }
  tallied_.clear();
  forgotten_step_.clear();
}

// One grain on one wall: the law's step and the contact forces (contact_forces.h contact_step),
// the force and torque on the grain, the tallies and the per-atom output `out` (kOutputColumns).
// `stored` is the grain's record for this wall; it is advanced only when `commit` (not in setup).
void FixWallGeocontact::touch_wall(int i, WallRecord &stored, const WallContact &contact,
                                   bool commit, double *out)
{
  const double interference = contact.interference;
  if (!stored.active && interference <= 0.0) return;  // apart, never touched
  const StiffnessConstants &c = constants_;
  // the FE half model: F(w) = F_pair(2 w), energies half the pair's (law.hpp)
  const geocontact::Similarity sim =
      geocontact::wall_similarity(contact.effective_radius, c.calibrated_radius);
  if (stored.active && interference < -neighbor->skin) {
    if (commit) forget_contact(stored, sim);
    return;
  }

  const double *radius = atom->radius;
  const double *n = contact.n;
  const double no_spin[3] = {0.0, 0.0, 0.0};
  // the stored record itself when the step commits (most calls), a copy in setup (a member:
  // a local would be constructed at every call)
  WallRecord &rec = commit ? stored : (setup_record_ = stored);
  const bool known = rec.active;
  if (!rec.active) {
    rec.law = geocontact::ContactState();
    clear_springs(rec);
    clear_ledger(rec);
    clear_place(rec);
    rec.active = 1;
  } else if (rec.contact_radius < 0.0) {  // an older restart's record: a before this step
    rec.contact_radius = contact_stiffness(law_, c, rec.law, sim).radius;
  }
  // the contact is on the wall's surface, r - w from the centre (contact_frame)
  const double arm = radius[i] - interference;
  const bool place = place_memory_ && commit;
  if (place && known) track_wall_place(rec, contact, sim, arm, atom->omega[i]);
  const double envelope = rec.law.max_approach;
  const ContactGeometry geometry{interference,   sim,     n,   atom->v[i],
                                 contact.velocity, atom->omega[i], no_spin, arm,
                                 0.0,            contact.effective_radius, 0.0,
                                 atom->rmass[i], 0.0,     true};
  const ContactCoeffs cc{friction_, damping_, &resistance_};
  const ContactResult res = contact_step(law_, c, cc, rec, geometry, update->dt, commit);
  if (place) {
    envelope_moved(rec, envelope);  // virgin loading: the dent is where the contact is now
    for (int k = 0; k < 3; ++k) rec.normal[k] = n[k];
  }
  if (range_error_ && commit) {
    const double depth = depth_beyond_range(law_, rec.law);
    if (depth > 0.0)
      error->one(FLERR, "Fix {} {}: the wall contact of atom {} is loaded to delta_max/delta_y "
                        "{:.6g}, beyond the law file's calibrated range (calibrated_range."
                        "max_depth {:.6g}); range error stops the run there (range warn "
                        "extrapolates and says so once)",
                 style, id, atom->tag[i], depth, law_.calibrated_depth);
  }
  const double fn = res.fn;
  const double *ft = res.ft;
  double *torque = atom->torque[i];
  if (res.stiffness > 0.0) {
    max_stiffness_ = std::max(max_stiffness_, res.stiffness);
    const double tor[3] = {n[1] * ft[2] - n[2] * ft[1], n[2] * ft[0] - n[0] * ft[2],
                           n[0] * ft[1] - n[1] * ft[0]};
    for (int k = 0; k < 3; ++k) torque[k] += res.torque[k] - arm * tor[k];
  }

  const double fc[3] = {fn * n[0] + ft[0], fn * n[1] + ft[1], fn * n[2] + ft[2]};
  double *f = atom->f[i];
  for (int k = 0; k < 3; ++k) {
    f[k] += fc[k];
    tally_[GF_X + k] -= fc[k];  // the grain pushes the wall the other way
  }
  // the wall's work on the grain: the contact force times the wall's velocity at the contact
  // (the rest of the contact force's work on the grain is the contact's, in its ledger)
  if (commit) boundary_work_ += dot3(fc, contact.velocity) * update->dt;
  // the tallies: summed when read (finish_tally) after a committed step; in setup now, from the
  // scratch copy's law state and the stored record's springs (the scratch copy's Coulomb reset
  // at dt = 0 may differ from what the next step starts from; a contact not yet recorded has
  // none)
  if (commit)
    tallied_.push_back({static_cast<long>(&stored - records_.data()), contact.effective_radius});
  else
    tally_contact(rec, stored.active ? &stored : nullptr, sim);
  const geocontact::ContactState &st = rec.law;
  // the state's approaches are the pair's in the calibrated units: w = d / approach
  const double half_scale = c.length_to_run / sim.approach;
  out[0] = interference;
  out[1] = sim.force * st.force * c.force_to_run;
  out[2] = std::sqrt(dot3(rec.tangential, rec.tangential));
  out[3] = half_scale * (st.max_approach + st.ratchet_shift);
  out[4] = half_scale * (st.residual_approach + st.ratchet_shift);
  out[5] = st.branch;
}

// Sums over ranks, except [7-8]: the largest normal stiffness of a wall contact k_max and the
// critical time step it implies for the lightest grain of the group, velocity Verlet on one
// grain of mass m against the rigid wall being stable for omega dt < 2, omega = sqrt(k / m)
// (sqrt(k ftm2v / m) in the run's units): dt_crit = 2 sqrt(m_min / k_max), 0 while no grain
// touches.
double FixWallGeocontact::compute_vector(int n)
{
  finish_tally();
  if (!totals_current_) {
    tally_[G_BOUNDARY_WORK] = boundary_work_;
    MPI_Allreduce(tally_, totals_, G_MAX_STIFFNESS, MPI_DOUBLE, MPI_SUM, world);
    MPI_Allreduce(tally_ + G_SLIDING, totals_ + G_SLIDING, G_BEYOND_RANGE + 1 - G_SLIDING,
                  MPI_DOUBLE, MPI_SUM, world);
    MPI_Allreduce(tally_ + G_MEMORY_RESET, totals_ + G_MEMORY_RESET, 1, MPI_DOUBLE, MPI_SUM,
                  world);
    double lightest = INFINITY;
    for (int i = 0; i < atom->nlocal; ++i)
      if (atom->mask[i] & groupbit) lightest = std::min(lightest, atom->rmass[i]);
    double local[3] = {max_stiffness_, -lightest, deepest_beyond_}, all[3] = {0.0, 0.0, 0.0};
    MPI_Allreduce(local, all, 3, MPI_DOUBLE, MPI_MAX, world);
    totals_[G_DEEPEST_BEYOND] = all[2];
    const double k = all[0], m = -all[1];
    totals_[G_MAX_STIFFNESS] = k;
    totals_[G_CRITICAL_DT] =
        k > 0.0 && std::isfinite(m) ? 2.0 * std::sqrt(m / (k * force->ftm2v)) : 0.0;
    totals_current_ = true;
  }
  return totals_[n];
}

// Issue 37, no silent extrapolation: at the end of a run (collective), one warning the first
// time wall contacts are beyond the law's calibrated range; [19-20] count them at any step.
void FixWallGeocontact::post_run()
{
  finish_tally();
  if (range_warned_) return;
  double all[2] = {0.0, 0.0};
  MPI_Allreduce(&tally_[G_BEYOND_RANGE], &all[0], 1, MPI_DOUBLE, MPI_SUM, world);
  MPI_Allreduce(&deepest_beyond_, &all[1], 1, MPI_DOUBLE, MPI_MAX, world);
  if (!(all[0] > 0.0)) return;
  range_warned_ = true;
  if (comm->me == 0)
    error->warning(FLERR, "Fix {} {}: {:.0f} wall contact(s) loaded beyond the calibrated range "
                          "of the law file (largest delta_max/delta_y {:.4g}; "
                          "calibrated_range.max_depth): the law extrapolates there (f_{}[19] "
                          "counts them, [20] the deepest; said once)",
                   style, id, all[0], all[1], id);
}

// --- per-atom storage: exchange, sorting, restart ---------------------------------------------

void FixWallGeocontact::grow_arrays(int nmax)
{
  const size_t nwalls = sides_.size();
  // only ever grows: unpack_exchange/unpack_restart ask for nlocal + 1, which is below the
  // atom arrays' nmax that copy_arrays and the output may index (memory->grow reallocates to
  // exactly the size asked, so growing to nlocal + 1 would shrink array_atom)
  if (nmax <= capacity_) return;
  capacity_ = nmax;
  if (records_.size() < static_cast<size_t>(nmax) * nwalls)
    records_.resize(static_cast<size_t>(nmax) * nwalls);
  memory->grow(array_atom, nmax, size_peratom_cols, "wall/geocontact:array_atom");
}

void FixWallGeocontact::copy_arrays(int i, int j, int /*delflag*/)
{
  finish_tally();  // before the records move
  const size_t nwalls = sides_.size();
  std::copy_n(records_.begin() + i * nwalls, nwalls, records_.begin() + j * nwalls);
  for (int c = 0; c < size_peratom_cols; ++c) array_atom[j][c] = array_atom[i][c];
}

void FixWallGeocontact::set_arrays(int i)
{
  const size_t nwalls = sides_.size();
  for (size_t w = 0; w < nwalls; ++w) {
    WallRecord &r = records_[i * nwalls + w];
    r.law = geocontact::ContactState();
    clear_springs(r);
    clear_ledger(r);
    clear_place(r);
    r.active = 0;
  }
  for (int c = 0; c < size_peratom_cols; ++c) array_atom[i][c] = 0.0;
}

int FixWallGeocontact::pack_record(const WallRecord &r, double *buf)
{
  int m = pack_state(r.law, buf);
  buf[m++] = r.tangential[0];
  buf[m++] = r.tangential[1];
  buf[m++] = r.tangential[2];
  buf[m++] = r.active;
  for (int k = 0; k < 3; ++k) buf[m++] = r.rolling[k];
  buf[m++] = r.twist;
  buf[m++] = r.contact_radius;
  for (double d : r.dissipated) buf[m++] = d;
  buf[m++] = r.travel[0];  // version 5
  buf[m++] = r.travel[1];
  buf[m++] = r.due;
  buf[m++] = r.forgotten;
  buf[m++] = r.reset_stored;
  for (int k = 0; k < 3; ++k) buf[m++] = r.normal[k];
  return m;
}

int FixWallGeocontact::unpack_record(WallRecord &r, const double *buf, int layout_version)
{
  const bool with_rolling = layout_version >= 2, with_radius = layout_version >= 3;
  const bool with_ledger = layout_version >= 4, with_place = layout_version >= 5;
  int m = unpack_state(r.law, buf);
  r.tangential[0] = buf[m++];
  r.tangential[1] = buf[m++];
  r.tangential[2] = buf[m++];
  r.active = static_cast<int>(buf[m++]);
  for (int k = 0; k < 3; ++k) r.rolling[k] = with_rolling ? buf[m++] : 0.0;
  r.twist = with_rolling ? buf[m++] : 0.0;
  r.contact_radius = with_radius ? buf[m++] : -1.0;
  for (double &d : r.dissipated) d = with_ledger ? buf[m++] : 0.0;
  clear_place(r);
  if (with_place) {
    r.travel[0] = buf[m++];
    r.travel[1] = buf[m++];
    r.due = static_cast<int>(buf[m++]);
    r.forgotten = buf[m++];
    r.reset_stored = buf[m++];
    for (int k = 0; k < 3; ++k) r.normal[k] = buf[m++];
  }
  return m;
}

// Doubles per wall record in a restart file of the given layout version (unpack_record).
int FixWallGeocontact::record_size(int layout_version)
{
  return layout_version == 1   ? kRecordSizeV1
         : layout_version == 2 ? kRecordSizeV2
         : layout_version == 3 ? kRecordSizeV3
         : layout_version == 4 ? kRecordSizeV4
                               : kRecordSize;
}

int FixWallGeocontact::pack_exchange(int i, double *buf)
{
  finish_tally();  // before the records move
  const size_t nwalls = sides_.size();
  int m = 0;
  for (size_t w = 0; w < nwalls; ++w) m += pack_record(records_[i * nwalls + w], buf + m);
  return m;
}

int FixWallGeocontact::unpack_exchange(int nlocal, double *buf)
{
  grow_arrays(nlocal + 1);
  const size_t nwalls = sides_.size();
  int m = 0;
  for (size_t w = 0; w < nwalls; ++w) m += unpack_record(records_[nlocal * nwalls + w], buf + m);
  return m;
}

// Per atom: [length, layout tag, walls, records].
int FixWallGeocontact::pack_restart(int i, double *buf)
{
  return restart_record_head(buf, kAtomTag, static_cast<double>(sides_.size()),
                             pack_exchange(i, buf + kAtomHeader));
}

// The head of a per-atom restart record of the wall fixes, [length, layout tag, value, body]
// (the body, `body` doubles, already at buf + 3; buf[0] counts itself): its length.
int FixWallGeocontact::restart_record_head(double *buf, int64_t tag, double value, int body)
{
  buf[0] = 3 + body;
  buf[1] = ubuf(tag).d;
  buf[2] = value;
  return 3 + body;
}

// This fix's per-atom restart record of atom nlocal (the nth of the fixes' records), the atom's
// records sized and cleared first (a record not read leaves the atom without wall contacts).
const double *FixWallGeocontact::restart_record(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;
  for (int k = 0; k < nth; ++k) m += static_cast<int>(extra[nlocal][m]);
  grow_arrays(nlocal + 1);
  set_arrays(nlocal);
  return &extra[nlocal][m];
}

// A record of another layout or wall count is never unpacked: the atom is left without wall
// contacts and init() refuses the run on every rank. Layout version 1 (no rolling and twist)
// is read with both at zero, versions 1-2 (no contact radius) with the radius taken from the
// law state at the record's next step, versions 1-3 (no ledger) with the ledger at zero.
void FixWallGeocontact::unpack_restart(int nlocal, int nth)
{
  const double *record = restart_record(nlocal, nth);
  const int64_t tag = ubuf(record[1]).i;
  const int version = (tag & ~int64_t(0xffffffff)) == kAtomTagBase
                          ? static_cast<int>(tag & 0xffffffff) : 0;
  const bool known = version >= 1 && version <= kRestartLayoutVersion;
  const int walls = known ? static_cast<int>(record[2]) : -1;
  const int length = static_cast<int>(record[0]);
  const int size = record_size(version);
  const int expected = kAtomHeader + static_cast<int>(sides_.size()) * size;
  if (walls != static_cast<int>(sides_.size()) || length != expected) {
    if (!unreadable_restart_) {
      unreadable_tag_ = tag;
      unreadable_walls_ = walls;
    }
    unreadable_restart_ = true;
    return;
  }
  const size_t nwalls = sides_.size();
  const double *buf = record + kAtomHeader;
  for (size_t w = 0; w < nwalls; ++w)
    buf += unpack_record(records_[nlocal * nwalls + w], buf, version);
}

int FixWallGeocontact::size_restart(int /*i*/)
{
  return kAtomHeader + static_cast<int>(sides_.size()) * kRecordSize;
}

int FixWallGeocontact::maxsize_restart()
{
  return size_restart(0);
}

// Global: the wall's clock and position variable, so a moving wall continues where it was, the
// energy dissipated by contacts already forgotten and the wall's work (summed over ranks).
void FixWallGeocontact::write_restart(FILE *fp)
{
  double data[kGlobalSize];
  pack_global(data);
  if (comm->me != 0) return;
  const int size = kGlobalSize * sizeof(double);
  fwrite(&size, sizeof(int), 1, fp);
  fwrite(data, sizeof(double), kGlobalSize, fp);
}

// The global restart block (kGlobalSize doubles; collective, complete on rank 0), shared with
// fix wall/geocontact/region, which writes its region's record after it.
void FixWallGeocontact::pack_global(double *data)
{
  double mine[3 + kLedgerSlots] = {forgotten_dissipated_, boundary_work_};
  for (int k = 0; k < kLedgerSlots; ++k) mine[2 + k] = forgotten_ledger_[k];
  mine[2 + kLedgerSlots] = forgotten_reset_;
  double all[3 + kLedgerSlots] = {};
  MPI_Allreduce(mine, all, 3 + kLedgerSlots, MPI_DOUBLE, MPI_SUM, world);
  double values[kGlobalSize] = {ubuf(kGlobalTag).d,
                                static_cast<double>(time_origin_),
                                last_position_,
                                position_velocity_,
                                static_cast<double>(last_position_step_),
                                all[0],
                                static_cast<double>(sides_.size())};
  for (int k = 0; k < kLedgerSlots; ++k) values[kGlobalSizeV3 + k] = all[2 + k];
  values[kGlobalSizeV3 + kLedgerSlots] = all[1];
  values[kGlobalSizeV4] = all[2 + kLedgerSlots];  // version 5
  std::copy_n(values, kGlobalSize, data);
}

void FixWallGeocontact::restart(char *buf)
{
  unpack_global(buf);
}

// Reads the global block at buf; returns its length in bytes (the region's record follows it).
int FixWallGeocontact::unpack_global(const char *buf)
{
  double data[kGlobalSize] = {};
  memcpy(data, buf, sizeof(double));
  const int64_t tag = ubuf(data[0]).i;
  const int64_t version = tag & 0xffffffff;  // the global layout is the same in versions 1-3
  if ((tag & ~int64_t(0xffffffff)) != kGlobalTagBase || version < 1 ||
      version > kRestartLayoutVersion)
    error->all(FLERR, "Fix wall/geocontact: the restart file's global wall data has {} (tag "
                      "0x{:016x}); this fix reads wall layout versions 1 to {} only",
               (tag & ~int64_t(0xffffffff)) == (kGlobalTag & ~int64_t(0xffffffff))
                   ? "another layout version" : "no wall/geocontact layout tag",
               static_cast<uint64_t>(tag), kRestartLayoutVersion);
  const int size = version >= 5 ? kGlobalSize : version == 4 ? kGlobalSizeV4 : kGlobalSizeV3;
  memcpy(data, buf, size * sizeof(double));
  time_origin_ = static_cast<bigint>(data[1]);
  last_position_ = data[2];
  position_velocity_ = data[3];
  last_position_step_ = static_cast<bigint>(data[4]);
  forgotten_dissipated_ = comm->me == 0 ? data[5] : 0.0;
  // version 4: the ledger of forgotten contacts and the wall's work (before: not recorded)
  for (int k = 0; k < kLedgerSlots; ++k)
    forgotten_ledger_[k] = comm->me == 0 ? data[kGlobalSizeV3 + k] : 0.0;
  boundary_work_ = comm->me == 0 ? data[kGlobalSizeV3 + kLedgerSlots] : 0.0;
  // version 5: the forgotten contacts' change of stored energy at memory resets (before: none)
  forgotten_reset_ = comm->me == 0 ? data[kGlobalSizeV4] : 0.0;
  return size * static_cast<int>(sizeof(double));
}

double FixWallGeocontact::memory_usage()
{
  return static_cast<double>(records_.capacity()) * sizeof(WallRecord) +
      static_cast<double>(atom->nmax) * size_peratom_cols * sizeof(double);
}
