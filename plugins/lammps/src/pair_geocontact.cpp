// pair_style geocontact (see pair_geocontact.h and docs in examples/lammps/README.md).
#include "pair_geocontact.h"

#include "contact_forces.h"
#include "contact_setup.h"
#include "contact_state.h"
#include "fix_geocontact_history.h"
#include "geocontact/params.hpp"

#include "atom.h"
#include "comm.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neigh_list.h"
#include "neighbor.h"
#include "update.h"
#include "utils.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>
#include <vector>

using namespace LAMMPS_NS;
using namespace LAMMPS_NS::geocontact_forces;

namespace {

constexpr const char *kHistoryFixId = "GEOCONTACT_HISTORY";
constexpr double kDefaultFriction = 0.5;
// Restart layout of the pair: the tag (the bytes "GCPS" in the file, little-endian) and a layout
// version come first, so a file of another layout is refused instead of misread. Bump the
// version whenever write_restart changes.
constexpr int kRestartTag = 0x53504347;
// Version 2 adds the rolling and twisting coefficients of each type pair, version 3 the law's
// dissipation of the dropped contacts, version 4 their other ledger channels, version 5 the
// memory keyword and the dropped contacts' memory-reset energy, version 6 the range keyword;
// older versions are read without them (at zero; memory pair and range warn, the defaults).
constexpr int kRestartLayoutVersion = 6;

}  // namespace

PairGeocontact::PairGeocontact(LAMMPS *lmp) : Pair(lmp)
{
  single_enable = 1;
  no_virial_fdotr_compute = 1;  // forces only on owned atoms of a newton-off list: tally pairs
  finitecutflag = 1;
  restartinfo = 1;
  single_extra = SV_COUNT;
  svector = new double[SV_COUNT];
  nextra = GV_COUNT;
  pvector = new double[GV_COUNT];
  for (int k = 0; k < GV_COUNT; ++k) pvector[k] = 0.0;
  history_ = nullptr;
  coeffs_ = nullptr;
  type_max_radius_ = nullptr;
}

PairGeocontact::~PairGeocontact()
{
  delete[] svector;
  delete[] pvector;
  if (history_ && modify && modify->get_fix_by_id(kHistoryFixId)) history_->sync_mirrors = nullptr;
  // Deleting the pair style (a new pair_style, clear) drops the contact history with it.
  if (history_ && modify && modify->get_fix_by_id(kHistoryFixId))
    modify->delete_fix(kHistoryFixId);
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
    memory->sfree(coeffs_);
    delete[] type_max_radius_;
  }
}

void PairGeocontact::allocate()
{
  allocated = 1;
  const int n = atom->ntypes + 1;
  memory->create(setflag, n, n, "pair:setflag");
  memory->create(cutsq, n, n, "pair:cutsq");
  coeffs_ = static_cast<TypePairLaw **>(memory->smalloc(sizeof(TypePairLaw *) * n +
                                                        sizeof(TypePairLaw) * n * n,
                                                        "pair:coeffs"));
  auto *block = reinterpret_cast<TypePairLaw *>(coeffs_ + n);
  for (int i = 0; i < n; ++i) coeffs_[i] = block + i * n;
  type_max_radius_ = new double[n];
  for (int i = 0; i < n; ++i) {
    type_max_radius_[i] = 0.0;
    for (int j = 0; j < n; ++j) {
      setflag[i][j] = 0;
      coeffs_[i][j] = {-1, kDefaultFriction, 0.0, RollingCoeffs{}};
    }
  }
}

static void require_sphere(Atom *atom, Error *error)
{
  if (!atom->radius_flag || !atom->rmass_flag || !atom->omega_flag || !atom->torque_flag)
    error->all(FLERR, "Pair style geocontact requires atom style sphere (per-atom radius, mass, "
                      "angular velocity and torque); current atom style is {}",
               atom->atom_style);
}

// pair_style geocontact [memory pair|place] [range warn|error]: memory pair (the default) keeps
// a contact's dent however far its point moves; place forgets it once its point has travelled
// past the dent's diameter, at the first step where that stores no more normal energy than the
// dent held (docs/dem.md, "Memory with a place"); range error stops the run at the first contact loaded beyond the
// law file's calibrated range (warn, the default: counted, said once)
void PairGeocontact::settings(int narg, char **arg)
{
  place_memory_ = false;
  range_error_ = false;
  for (int iarg = 0; iarg < narg;) {
    if (parse_range(lmp, iarg, narg, arg, range_error_, "pair_style geocontact")) continue;
    if (parse_memory(lmp, iarg, narg, arg, place_memory_, "pair_style geocontact")) continue;
    error->all(FLERR, "Illegal pair_style geocontact command: unexpected argument '{}' (allowed: "
                      "memory place|pair, range warn|error; the parameters go in pair_coeff "
                      "* * P.json)",
               arg[iarg]);
  }
}

// Keep one copy of each distinct parameter document.
int PairGeocontact::add_law(const std::string &text, const std::string &source)
{
  for (size_t k = 0; k < law_texts_.size(); ++k)
    if (law_texts_[k] == text) return static_cast<int>(k);
  laws_.push_back(parse_law(lmp, text, source, "pair_coeff geocontact"));
  stiffness_constants_.push_back(
      stiffness_constants(laws_.back(), run_units(lmp, "Pair geocontact")));
  law_texts_.push_back(text);
  return static_cast<int>(laws_.size()) - 1;
}

void PairGeocontact::coeff(int narg, char **arg)
{
  if (narg < 3)
    error->all(FLERR, "Incorrect args for pair coefficients: pair_coeff I J P.json "
                      "[friction mu] [damping beta | restitution e] "
                      "[rolling sds k_roll gamma_roll mu_roll] "
                      "[twisting marshall]");
  require_sphere(atom, error);
  if (!allocated) allocate();
  int ilo, ihi, jlo, jhi;
  utils::bounds(FLERR, arg[0], 1, atom->ntypes, ilo, ihi, error);
  utils::bounds(FLERR, arg[1], 1, atom->ntypes, jlo, jhi, error);

  // Rank 0 reads the file; every rank parses the same text, so errors are collective.
  const std::string path = arg[2];
  const std::string text = read_text_collective(lmp, path, "pair_coeff geocontact");
  const int law = add_law(text, path);

  double friction = kDefaultFriction, damping = 0.0;
  char damping_given = 0;
  RollingCoeffs resistance{};
  for (int iarg = 3; iarg < narg;) {
    if (parse_resistance(lmp, iarg, narg, arg, resistance, "pair_coeff geocontact")) continue;
    if (parse_damping(lmp, iarg, narg, arg, damping, damping_given, "pair_coeff geocontact"))
      continue;
    if (iarg + 1 >= narg)
      error->all(FLERR, "pair_coeff geocontact: keyword '{}' needs a value", arg[iarg]);
    if (strcmp(arg[iarg], "friction") == 0) {
      friction = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      if (friction < 0.0)
        error->all(FLERR, "pair_coeff geocontact: friction must be >= 0, got {}", friction);
    } else {
      error->all(FLERR, "pair_coeff geocontact: unknown keyword '{}' (allowed: friction, "
                        "damping, restitution, rolling, twisting)", arg[iarg]);
    }
    iarg += 2;
  }

  int count = 0;
  for (int i = ilo; i <= ihi; ++i) {
    for (int j = std::max(jlo, i); j <= jhi; ++j) {
      coeffs_[i][j] = {law, friction, damping, resistance};
      setflag[i][j] = 1;
      ++count;
    }
  }
  if (count == 0) error->all(FLERR, "Incorrect args for pair coefficients: no type pairs set");
}

void PairGeocontact::init_style()
{
  require_sphere(atom, error);
  if (!atom->tag_enable) error->all(FLERR, "Pair style geocontact requires atom IDs");
  if (comm->ghost_velocity == 0)
    error->all(FLERR, "Pair style geocontact requires ghost atoms store velocity: use "
                      "comm_modify vel yes");
  // A half list with newton off: a pair across ranks is computed on both, each rank applying
  // the force to its own atom and keeping that atom's copy of the history current, so the
  // history needs no reverse communication.
  neighbor->add_request(this, NeighConst::REQ_SIZE | NeighConst::REQ_NEWTON_OFF);

  for (int t = 1; t <= atom->ntypes; ++t)
    if (!setflag[t][t])
      error->all(FLERR, "Pair geocontact: no pair_coeff for atom type {} with itself", t);

  history_ = dynamic_cast<FixGeocontactHistory *>(modify->get_fix_by_id(kHistoryFixId));
  if (!history_)
    history_ = dynamic_cast<FixGeocontactHistory *>(
        modify->add_fix(std::string(kHistoryFixId) + " all geocontact/history"));
  if (!history_) error->all(FLERR, "Pair geocontact: could not create its history fix");
  history_->sync_mirrors = [this]() { sync_mirrors(); };
  history_->neighbors_rebuilt = true;
  check_atoms();
}

// Every atom must be a sphere (radius > 0); any radius is fine (similarity, r_eq). The largest
// radius of each type sets the pair cutoffs (init_one), as in pair granular.
void PairGeocontact::check_atoms()
{
  const double *radius = atom->radius;
  const int *type = atom->type;
  const tagint *tag = atom->tag;
  const int n = atom->ntypes + 1;
  std::vector<double> local(n, 0.0);
  tagint bad = -1;
  double bad_radius = 0.0;
  for (int i = 0; i < atom->nlocal; ++i) {
    if (!(radius[i] > 0.0) && bad < 0) {
      bad = tag[i];
      bad_radius = radius[i];
    }
    local[type[i]] = std::max(local[type[i]], radius[i]);
  }
  MPI_Allreduce(local.data(), type_max_radius_, n, MPI_DOUBLE, MPI_MAX, world);
  tagint any = -1;
  MPI_Allreduce(&bad, &any, 1, MPI_LMP_TAGINT, MPI_MAX, world);
  if (any >= 0) {
    double r = any == bad ? bad_radius : -INFINITY, rall = 0.0;
    MPI_Allreduce(&r, &rall, 1, MPI_DOUBLE, MPI_MAX, world);
    error->all(FLERR, "Pair geocontact: atom {} has radius {} m; every grain needs a radius > 0 "
                      "(set diameter)", any, rall);
  }
}

double PairGeocontact::init_one(int i, int j)
{
  if (!setflag[i][j]) {
    // Unlike types share a law only if both use the same parameter file.
    const TypePairLaw &a = coeffs_[i][i], &b = coeffs_[j][j];
    if (a.law != b.law)
      error->all(FLERR, "Pair geocontact: types {} and {} use different parameter files; give "
                        "pair_coeff {} {} explicitly", i, j, i, j);
    const RollingCoeffs &ra = a.resistance, &rb = b.resistance;
    if (ra.rolling != rb.rolling || ra.twisting != rb.twisting)
      error->all(FLERR, "Pair geocontact: types {} and {} differ in rolling or twisting "
                        "resistance; give pair_coeff {} {} explicitly", i, j, i, j);
    const RollingCoeffs mixed{0.5 * (ra.stiffness + rb.stiffness),
                              0.5 * (ra.damping + rb.damping),
                              0.5 * (ra.friction + rb.friction), ra.rolling, ra.twisting};
    coeffs_[i][j] = {a.law, 0.5 * (a.friction + b.friction), 0.5 * (a.damping + b.damping),
                     mixed};
  }
  coeffs_[j][i] = coeffs_[i][j];
  // grains touch when their centres are closer than the sum of their radii: the largest pair
  // of the two types (the parameter file's radius if no atom of a type exists yet)
  const double fallback = stiffness_constants_[coeffs_[i][j].law].calibrated_radius;
  const double ri = type_max_radius_[i] > 0.0 ? type_max_radius_[i] : fallback;
  const double rj = type_max_radius_[j] > 0.0 ? type_max_radius_[j] : fallback;
  return ri + rj;
}

// Slots of each neighbor pair in the atoms' tables; records of partners no longer in the
// neighbor list are forgotten (the history of a pair that separated by more than the skin).
void PairGeocontact::index_contacts()
{
  history_->mirrors_stale = false;  // synced before the exchange that preceded this rebuild
  auto &tables = history_->tables;
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  const int inum = list->inum;
  const int *ilist = list->ilist;
  const int *numneigh = list->numneigh;
  int **firstneigh = list->firstneigh;

  first_pair_.resize(inum + 1);
  first_pair_[0] = 0;
  for (int ii = 0; ii < inum; ++ii) first_pair_[ii + 1] = first_pair_[ii] + numneigh[ilist[ii]];
  record_of_.assign(first_pair_[inum], -1);

  std::vector<int> first_record(nlocal + 1, 0);
  for (int i = 0; i < nlocal; ++i)
    first_record[i + 1] = first_record[i] + static_cast<int>(tables[i].size());
  std::vector<char> keep(first_record[nlocal], 0);
  for (int ii = 0; ii < inum; ++ii) {
    const int i = ilist[ii];
    const int *jlist = firstneigh[i];
    for (int jj = 0; jj < numneigh[i]; ++jj) {
      const int j = jlist[jj] & NEIGHMASK;
      const int si = FixGeocontactHistory::find(tables[i], tag[j]);
      if (si >= 0) keep[first_record[i] + si] = 1;
      if (j < nlocal) {
        const int sj = FixGeocontactHistory::find(tables[j], tag[i]);
        if (sj >= 0) keep[first_record[j] + sj] = 1;
      }
    }
  }
  // A dropped record takes its pair's dissipation with it: each pair has one record per grain
  // (newton off: a pair across ranks keeps one on each), so each dropped record carries half.
  // the law's, the ledger's channels, then the memory resets' change of stored energy
  double departed[2 + kLedgerSlots] = {};
  for (int i = 0; i < nlocal; ++i) {
    auto &table = tables[i];
    size_t kept = 0;
    for (size_t k = 0; k < table.size(); ++k) {
      if (keep[first_record[i] + k]) {
        table[kept++] = table[k];
      } else {
        const ContactRecord &gone = table[k];
        if (gone.energy_scale > 0.0)
          departed[0] += 0.5 * gone.energy_scale *
                         stiffness_constants_[gone.law_index].energy_to_run *
                         geocontact::dissipated_energy(laws_[gone.law_index], gone.law);
        departed[0] += 0.5 * gone.forgotten;
        for (int c = 0; c < kLedgerSlots; ++c) departed[1 + c] += 0.5 * gone.dissipated[c];
        departed[1 + kLedgerSlots] += 0.5 * gone.reset_stored;
      }
    }
    table.resize(kept);
  }
  double departed_all[2 + kLedgerSlots] = {};
  MPI_Allreduce(departed, departed_all, 2 + kLedgerSlots, MPI_DOUBLE, MPI_SUM, world);
  departed_reset_ += departed_all[1 + kLedgerSlots];
  departed_dissipation_ += departed_all[0];
  for (int c = 0; c < kLedgerSlots; ++c) departed_ledger_[c] += departed_all[1 + c];
  pair_records_.clear();
  for (int ii = 0; ii < inum; ++ii) {
    const int i = ilist[ii];
    const int *jlist = firstneigh[i];
    for (int jj = 0; jj < numneigh[i]; ++jj) {
      const int j = jlist[jj] & NEIGHMASK;
      const int si = FixGeocontactHistory::find(tables[i], tag[j]);
      if (si >= 0) {
        record_of_[first_pair_[ii] + jj] = static_cast<int>(pair_records_.size());
        pair_records_.push_back(tables[i][si]);
      }
    }
  }
  // room for the contacts the next steps make without moving the records each time
  pair_records_.reserve(pair_records_.size() + pair_records_.size() / 4 + 16);
}

// Write the records of the neighbor-list pairs back to the tables of both grains (mirrored on
// the partner: its tangential force is the opposite).
void PairGeocontact::sync_mirrors()
{
  if (!list || first_pair_.empty()) return;
  auto &tables = history_->tables;
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  const int inum = std::min(list->inum, static_cast<int>(first_pair_.size()) - 1);
  auto store = [&](int owner, const ContactRecord &rec) {
    auto &table = tables[owner];
    const int s = FixGeocontactHistory::find(table, rec.partner);
    if (s >= 0) {
      table[s] = rec;
    } else {
      table.push_back(rec);
      history_->note_table_size(table.size());
    }
  };
  for (int ii = 0; ii < inum; ++ii) {
    const int i = list->ilist[ii];
    const int *jlist = list->firstneigh[i];
    const int jnum = first_pair_[ii + 1] - first_pair_[ii];
    for (int jj = 0; jj < jnum; ++jj) {
      const int r = record_of_[first_pair_[ii] + jj];
      if (r < 0) continue;
      const int j = jlist[jj] & NEIGHMASK;
      store(i, pair_records_[r]);
      if (j < nlocal) {
        ContactRecord mirror = pair_records_[r];
        mirror.partner = tag[i];
        for (int c = 0; c < 3; ++c) mirror.tangential[c] = -mirror.tangential[c];
        std::swap(mirror.travel[0], mirror.travel[1]);
        store(j, mirror);
      }
    }
  }
}

// --- one contact, in the manner of LAMMPS's granular sub-models: geometry, normal force,
// damping, tangential force (contact_forces.h), energy tallies, forces on the grains ---------

// The contact's share of the global energy tallies (compute pair geocontact): each contact
// once, whole if both grains are owned here, half if shared with another rank (both ranks then
// hold the same record).
void PairGeocontact::tally_contact(const geocontact::LawParams &law,
                                   const StiffnessConstants &constants, const ContactRecord &rec,
                                   const ContactRecord *springs_from,
                                   const geocontact::Similarity &sim,
                                   const RollingCoeffs &resistance, bool owned_pair)
{
  const geocontact::ContactState &state = rec.law;
  const double w = owned_pair ? 1.0 : 0.5;
  const double energy_scale = sim.energy * constants.energy_to_run;
  const double stored = energy_scale * geocontact::elastic_energy(law, state);
  pvector[GV_DISSIPATED] += w * (energy_scale * state.work - stored + rec.forgotten);
  pvector[GV_MEMORY_RESET] += w * rec.reset_stored;
  pvector[GV_ELASTIC] += w * stored;
  if (state.force > 0.0) pvector[GV_CONTACTS] += w;
  if (state.max_approach > law.yield_approach) pvector[GV_PLASTIC_CONTACTS] += w;
  const double depth = state.max_approach / law.yield_approach;
  if (depth > law.calibrated_depth) {  // calibrated_range.max_depth (infinite: not recorded)
    beyond_range_ += w;
    deepest_beyond_ = std::max(deepest_beyond_, depth);
  }
  if (!springs_from) return;
  for (int c = 0; c < kLedgerSlots; ++c)
    pvector[GV_SLIDING + c] += w * springs_from->dissipated[c];
  const SpringEnergy springs = spring_energy(*springs_from, constants, sim, resistance);
  pvector[GV_STORED_TANGENTIAL] += w * springs.tangential;
  pvector[GV_STORED_ROLLING] += w * springs.rolling;
  pvector[GV_STORED_TWISTING] += w * springs.twisting;
}

// pair_style geocontact range error: the first contact loaded beyond its law file's calibrated
// range stops the run (on the rank that has it: one line).
void PairGeocontact::stop_beyond_range(const geocontact::LawParams &law,
                                       const geocontact::ContactState &state, tagint i, tagint j)
{
  const double depth = depth_beyond_range(law, state);
  if (depth > 0.0)
    error->one(FLERR, "Pair geocontact: the contact of atoms {} and {} is loaded to "
                      "delta_max/delta_y {:.6g}, beyond the law file's calibrated range "
                      "(calibrated_range.max_depth {:.6g}); range error stops the run there "
                      "(pair_style geocontact range warn extrapolates and says so once)",
               i, j, depth, law.calibrated_depth);
}

// The stiffest contact of this step (energy steps only, as the other global outputs).
void PairGeocontact::note_stiffness(double normal_stiffness)
{
  if (normal_stiffness > max_stiffness_) max_stiffness_ = normal_stiffness;
}

// The largest normal stiffness k_max over all ranks and the critical time step it implies for
// the lightest grain: velocity Verlet on one contact of stiffness k between grains of reduced
// mass m_eff is stable for omega dt < 2, omega = sqrt(k / m_eff) (sqrt(k ftm2v / m_eff) in the
// run's units), and two of the lightest grains, mass m_min, have m_eff = m_min / 2:
// dt_crit = 2 sqrt(m_min / (2 k_max)). Rank 0 carries both (compute pair sums over ranks);
// 0 while no contact carries force.
void PairGeocontact::finish_stiffness_outputs()
{
  double lightest = INFINITY;
  const double *rmass = atom->rmass;
  for (int i = 0; i < atom->nlocal; ++i) lightest = std::min(lightest, rmass[i]);
  double local[3] = {max_stiffness_, -lightest, deepest_beyond_}, all[3] = {0.0, 0.0, 0.0};
  MPI_Allreduce(local, all, 3, MPI_DOUBLE, MPI_MAX, world);
  double beyond = 0.0;
  MPI_Allreduce(&beyond_range_, &beyond, 1, MPI_DOUBLE, MPI_SUM, world);
  max_stiffness_ = beyond_range_ = deepest_beyond_ = 0.0;
  // issue 37: no silent extrapolation; told once per run (every rank knows the sum: the flag
  // stays the same on all), the count kept in [16]
  if (beyond > 0.0 && !range_warned_) {
    range_warned_ = true;
    if (comm->me == 0)
      error->warning(FLERR, "Pair geocontact: {:.0f} contact(s) loaded beyond the calibrated range "
                            "of their law file (largest delta_max/delta_y {:.4g}; "
                            "calibrated_range.max_depth): the law extrapolates there (compute "
                            "pair geocontact [16] counts them, [17] the deepest; said once)",
                     beyond, all[2]);
  }
  if (comm->me != 0) return;
  pvector[GV_BEYOND_RANGE] = beyond;
  pvector[GV_DEEPEST_BEYOND] = all[2];
  const double k = all[0], m = -all[1];
  pvector[GV_MAX_STIFFNESS] = k;
  pvector[GV_CRITICAL_DT] =
      k > 0.0 && std::isfinite(m) ? 2.0 * std::sqrt(0.5 * m / (k * force->ftm2v)) : 0.0;
}

// Normal and tangential force on grain i (and the opposite on j if owned here), with the
// torques of the tangential force about each centre, -(r - delta/2) (n x Ft) (contact_frame),
// and the rolling and twisting torque on i (the opposite on j). Inlined into compute(), its one
// caller: as a call (nine arguments, atom->f and atom->torque reloaded) it cost 11 M of its 37 M
// instructions on the poly sample (docs/benchmarks.md, the plugin's speed work).
GEOCONTACT_ALWAYS_INLINE void PairGeocontact::apply_contact_force(
    int i, int j, double fn, const double *ft, const double *n, const double *del, double energy,
    const double *extra_torque, double half_overlap)
{
  double **f = atom->f;
  double **torque = atom->torque;
  const double *radius = atom->radius;
  const int nlocal = atom->nlocal;
  const double armi = radius[i] - half_overlap, armj = radius[j] - half_overlap;
  const double fx = fn * n[0] + ft[0], fy = fn * n[1] + ft[1], fz = fn * n[2] + ft[2];
  const double tor[3] = {n[1] * ft[2] - n[2] * ft[1], n[2] * ft[0] - n[0] * ft[2],
                         n[0] * ft[1] - n[1] * ft[0]};
  f[i][0] += fx;
  f[i][1] += fy;
  f[i][2] += fz;
  for (int k = 0; k < 3; ++k) torque[i][k] += extra_torque[k] - armi * tor[k];
  if (j < nlocal) {
    f[j][0] -= fx;
    f[j][1] -= fy;
    f[j][2] -= fz;
    for (int k = 0; k < 3; ++k) torque[j][k] -= extra_torque[k] + armj * tor[k];
  }
  if (evflag) ev_tally_xyz(i, j, nlocal, 0, energy, 0.0, fx, fy, fz, del[0], del[1], del[2]);
}

// One pair of grains that touch or have a record (compute's loop): the record, the contact step
// (contact_forces.h, inlined here), the tallies and the forces. Kept out of compute's loop (never
// inlined into it): the loop over the neighbor list, most of whose pairs are apart, then keeps
// its own registers instead of sharing them with the contact step's (docs/benchmarks.md, "The
// contact step outside the law, counted").
GEOCONTACT_NOINLINE void PairGeocontact::touch_pair(int i, int j, int k, const double *del,
                                                    double rsq, double radsum, bool commit,
                                                    double dt, int eflag)
{
  double **v = atom->v;
  double **omega = atom->omega;
  const double *radius = atom->radius;
  const double *rmass = atom->rmass;
  const int *type = atom->type;
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  const double radi = radius[i];
  int slot = record_of_[k];
  const bool known = slot >= 0;
  const TypePairLaw &tp = coeffs_[type[i]][type[j]];
  const geocontact::LawParams &law = laws_[tp.law];
  const StiffnessConstants &constants = stiffness_constants_[tp.law];
  const geocontact::Similarity sim =
      geocontact::pair_similarity(radi, radius[j], constants.calibrated_radius);

  // the record itself when the step commits (most calls), a copy in setup (setup_record_)
  if (commit && !known) {  // a new contact: a record of its own from this step on
    slot = record_of_[k] = static_cast<int>(pair_records_.size());
    pair_records_.emplace_back();
  }
  ContactRecord &rec = commit ? pair_records_[slot]
                              : (setup_record_ = known ? pair_records_[slot] : ContactRecord());
  if (!known) {
    rec.partner = tag[j];
    rec.law = geocontact::ContactState();
    clear_springs(rec);
    clear_ledger(rec);
    rec.travel[0] = rec.travel[1] = rec.forgotten = rec.reset_stored = 0.0;
    rec.due = 0;
  } else if (rec.contact_radius < 0.0) {  // an older restart's record: a before this step
    rec.contact_radius = contact_stiffness(law, constants, rec.law, sim).radius;
  }
  const double r = std::sqrt(rsq);
  const double overlap = radsum - r;
  const double rinv = 1.0 / r;
  const double n[3] = {del[0] * rinv, del[1] * rinv, del[2] * rinv};
  const double half = 0.5 * overlap;  // the contact plane halves the overlap
  const ContactGeometry geometry{overlap,     sim,         n,        v[i],
                                 v[j],        omega[i],    omega[j], radi - half,
                                 radius[j] - half, radi, radius[j], rmass[i],
                                 rmass[j],    false};
  const ContactCoeffs cc{tp.friction, tp.damping, &tp.resistance};
  if (commit && known && place_memory_) {
    double rate_i = 0.0, rate_j = 0.0;
    travel_rates(n, v[i], v[j], omega[i], omega[j], r, geometry.armi, geometry.armj, rate_i,
                 rate_j);
    track_place(law, constants, sim, rec, rate_i, rate_j, dt);
  }
  const double envelope = rec.law.max_approach;
  const ContactResult res = contact_step(law, constants, cc, rec, geometry, dt, commit);
  envelope_moved(rec, envelope);  // virgin loading: the dent is where the contact is now
  rec.energy_scale = sim.energy;
  rec.law_index = tp.law;
  if (range_error_ && commit) stop_beyond_range(law, rec.law, tag[i], tag[j]);
  if (eflag_global && res.stiffness > 0.0) note_stiffness(res.stiffness);
  const double fn = res.fn;
  const double *ft = res.ft;

  // setup: the springs the next step starts from are the record's, not the scratch copy's
  // (whose Coulomb reset at dt = 0 may differ); a contact not yet recorded has none
  if (eflag_global)
    tally_contact(law, constants, rec, commit || known ? &pair_records_[slot] : nullptr, sim,
                  tp.resistance, j < nlocal);
  if (fn <= 0.0 && ft[0] == 0.0 && ft[1] == 0.0 && ft[2] == 0.0) return;
  const double energy =
      eflag ? sim.energy * constants.energy_to_run * geocontact::elastic_energy(law, rec.law)
            : 0.0;
  apply_contact_force(i, j, fn, ft, n, del, energy, res.torque, half);
}

void PairGeocontact::compute(int eflag, int vflag)
{
  ev_init(eflag, vflag);
  if (history_->neighbors_rebuilt) {
    index_contacts();
    history_->neighbors_rebuilt = false;
  }
  // During setup forces are evaluated but the history is not advanced (as pair granular):
  // the first step of the run then moves from the stored state.
  const bool commit = !update->setupflag;
  const double dt = update->dt;
  if (eflag_global) {
    for (int k = 0; k < GV_COUNT; ++k) pvector[k] = 0.0;
    if (comm->me == 0) {  // summed over ranks
      pvector[GV_DISSIPATED] = departed_dissipation_;
      for (int c = 0; c < kLedgerSlots; ++c) pvector[GV_SLIDING + c] = departed_ledger_[c];
      pvector[GV_MEMORY_RESET] = departed_reset_;
    }
  }

  double **x = atom->x;
  const double *radius = atom->radius;
  const int inum = list->inum;
  const int *ilist = list->ilist;
  const int *numneigh = list->numneigh;
  int **firstneigh = list->firstneigh;

  bool touched = false;
  for (int ii = 0; ii < inum; ++ii) {
    const int i = ilist[ii];
    const double xi[3] = {x[i][0], x[i][1], x[i][2]};
    const double radi = radius[i];
    const int *jlist = firstneigh[i];
    const int jnum = numneigh[i];
    const int first = first_pair_[ii];

    for (int jj = 0; jj < jnum; ++jj) {
      const int j = jlist[jj] & NEIGHMASK;
      const int k = first + jj;
      const double del[3] = {xi[0] - x[j][0], xi[1] - x[j][1], xi[2] - x[j][2]};
      const double rsq = dot3(del, del);
      const double radsum = radi + radius[j];
      if (rsq >= radsum * radsum && record_of_[k] < 0) continue;  // apart, never touched
      touch_pair(i, j, k, del, rsq, radsum, commit, dt, eflag);
      touched = true;
    }
  }
  // a committed step changed records: the per-atom tables are written by sync_mirrors()
  if (commit && touched) history_->mirrors_stale = true;
  if (eflag_global) finish_stiffness_outputs();
}

double PairGeocontact::single(int i, int j, int itype, int jtype, double rsq,
                              double /*factor_coul*/, double /*factor_lj*/, double &fforce)
{
  for (int k = 0; k < SV_COUNT; ++k) svector[k] = 0.0;
  fforce = 0.0;
  if (!history_ || i >= atom->nlocal) return 0.0;
  history_->sync();
  const int slot = FixGeocontactHistory::find(history_->tables[i], atom->tag[j]);
  if (slot < 0) return 0.0;
  const ContactRecord &rec = history_->tables[i][slot];
  const int law_index = coeffs_[itype][jtype].law;
  const geocontact::LawParams &law = laws_[law_index];
  const StiffnessConstants &c = stiffness_constants_[law_index];
  const geocontact::ContactState &st = rec.law;
  // the state is in the calibrated spheres' SI units: approaches s, forces s^2, energies s^3,
  // then in the run's units
  const geocontact::Similarity sim =
      geocontact::pair_similarity(atom->radius[i], atom->radius[j], c.calibrated_radius);
  const double length = sim.scale * c.length_to_run, force = sim.force * c.force_to_run;
  const double energy = sim.energy * c.energy_to_run;
  const double r = std::sqrt(rsq);
  fforce = r > 0.0 ? force * st.force / r : 0.0;
  svector[SV_APPROACH] = length * st.approach;
  svector[SV_NORMAL_FORCE] = force * st.force;
  svector[SV_TANGENTIAL_FORCE] = std::sqrt(dot3(rec.tangential, rec.tangential));
  svector[SV_MAX_APPROACH] = length * (st.max_approach + st.ratchet_shift);
  svector[SV_RESIDUAL_APPROACH] = length * (st.residual_approach + st.ratchet_shift);
  svector[SV_BRANCH] = st.branch;
  svector[SV_CYCLES] = st.cycles;
  svector[SV_WORK] = energy * st.work;
  svector[SV_DISSIPATED] = energy * geocontact::dissipated_energy(law, st) + rec.forgotten;
  svector[SV_CONTACT_RADIUS] = length * geocontact::contact_radius(law, st);
  return energy * geocontact::elastic_energy(law, st);
}

// Restart: the layout tag and version, the parameter documents themselves (not their paths), so
// a restart is self-contained, then per type pair the law index, friction and damping, and
// (version 2) the rolling flag, k_roll, gamma_roll, mu_roll and the twisting flag, (version 3)
// the law's dissipation of the contacts already dropped, (version 4) their ledger channels and
// (version 5) the memory keyword and their memory resets' change of stored energy, (version 6)
// the range keyword.
void PairGeocontact::write_restart(FILE *fp)
{
  if (comm->me != 0) return;
  fwrite(&kRestartTag, sizeof(int), 1, fp);
  fwrite(&kRestartLayoutVersion, sizeof(int), 1, fp);
  const int nlaws = static_cast<int>(law_texts_.size());
  fwrite(&nlaws, sizeof(int), 1, fp);
  for (const std::string &text : law_texts_) {
    const int length = static_cast<int>(text.size());
    fwrite(&length, sizeof(int), 1, fp);
    fwrite(text.data(), 1, length, fp);
  }
  for (int i = 1; i <= atom->ntypes; ++i)
    for (int j = i; j <= atom->ntypes; ++j) {
      fwrite(&setflag[i][j], sizeof(int), 1, fp);
      if (setflag[i][j]) {
        fwrite(&coeffs_[i][j].law, sizeof(int), 1, fp);
        fwrite(&coeffs_[i][j].friction, sizeof(double), 1, fp);
        fwrite(&coeffs_[i][j].damping, sizeof(double), 1, fp);
        const RollingCoeffs &rc = coeffs_[i][j].resistance;
        const double resistance[5] = {rc.rolling ? 1.0 : 0.0, rc.stiffness, rc.damping,
                                      rc.friction, rc.twisting ? 1.0 : 0.0};
        fwrite(resistance, sizeof(double), 5, fp);
      }
    }
  fwrite(&departed_dissipation_, sizeof(double), 1, fp);  // version 3
  fwrite(departed_ledger_, sizeof(double), kLedgerSlots, fp);  // version 4
  const int memory = place_memory_ ? 1 : 0;  // version 5
  fwrite(&memory, sizeof(int), 1, fp);
  fwrite(&departed_reset_, sizeof(double), 1, fp);
  const int range = range_error_ ? 1 : 0;  // version 6
  fwrite(&range, sizeof(int), 1, fp);
}

void PairGeocontact::read_restart(FILE *fp)
{
  allocate();
  const int me = comm->me;
  // An older plugin's file starts with the number of parameter documents where the tag is now.
  int layout[2] = {0, 0};
  if (me == 0) utils::sfread(FLERR, layout, sizeof(int), 2, fp, nullptr, error);
  MPI_Bcast(layout, 2, MPI_INT, 0, world);
  if (layout[0] != kRestartTag)
    error->all(FLERR, "Pair geocontact: the restart file's pair section has no geocontact layout "
                      "tag (0x{:08x} where the tag 0x{:08x} belongs: an older plugin's or a "
                      "foreign layout); this plugin reads pair layout versions 1 to {} only "
                      "(re-create the restart with this plugin)",
               static_cast<unsigned>(layout[0]), static_cast<unsigned>(kRestartTag),
               kRestartLayoutVersion);
  if (layout[1] < 1 || layout[1] > kRestartLayoutVersion)
    error->all(FLERR, "Pair geocontact: the restart file's pair section has layout version {}; "
                      "this plugin reads pair layout versions 1 to {} only (re-create the "
                      "restart with this plugin)",
               layout[1], kRestartLayoutVersion);
  const bool with_resistance = layout[1] >= 2;
  int nlaws = 0;
  if (me == 0) utils::sfread(FLERR, &nlaws, sizeof(int), 1, fp, nullptr, error);
  MPI_Bcast(&nlaws, 1, MPI_INT, 0, world);
  for (int k = 0; k < nlaws; ++k) {
    int length = 0;
    if (me == 0) utils::sfread(FLERR, &length, sizeof(int), 1, fp, nullptr, error);
    MPI_Bcast(&length, 1, MPI_INT, 0, world);
    std::string text(length, '\0');
    if (me == 0) utils::sfread(FLERR, &text[0], 1, length, fp, nullptr, error);
    MPI_Bcast(&text[0], length, MPI_CHAR, 0, world);
    add_law(text, "restart file");
  }
  for (int i = 1; i <= atom->ntypes; ++i)
    for (int j = i; j <= atom->ntypes; ++j) {
      if (me == 0) utils::sfread(FLERR, &setflag[i][j], sizeof(int), 1, fp, nullptr, error);
      MPI_Bcast(&setflag[i][j], 1, MPI_INT, 0, world);
      if (setflag[i][j]) {
        TypePairLaw &c = coeffs_[i][j];
        if (me == 0) {
          utils::sfread(FLERR, &c.law, sizeof(int), 1, fp, nullptr, error);
          utils::sfread(FLERR, &c.friction, sizeof(double), 1, fp, nullptr, error);
          utils::sfread(FLERR, &c.damping, sizeof(double), 1, fp, nullptr, error);
        }
        MPI_Bcast(&c.law, 1, MPI_INT, 0, world);
        MPI_Bcast(&c.friction, 1, MPI_DOUBLE, 0, world);
        MPI_Bcast(&c.damping, 1, MPI_DOUBLE, 0, world);
        double resistance[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
        if (with_resistance && me == 0)
          utils::sfread(FLERR, resistance, sizeof(double), 5, fp, nullptr, error);
        MPI_Bcast(resistance, 5, MPI_DOUBLE, 0, world);
        c.resistance = {resistance[1], resistance[2], resistance[3], resistance[0] != 0.0,
                        resistance[4] != 0.0};
      }
    }
  departed_dissipation_ = 0.0;  // versions 1-2: not recorded (contacts dropped before are lost)
  if (layout[1] >= 3 && me == 0)
    utils::sfread(FLERR, &departed_dissipation_, sizeof(double), 1, fp, nullptr, error);
  MPI_Bcast(&departed_dissipation_, 1, MPI_DOUBLE, 0, world);
  for (double &d : departed_ledger_) d = 0.0;  // versions 1-3: not recorded
  if (layout[1] >= 4 && me == 0)
    utils::sfread(FLERR, departed_ledger_, sizeof(double), kLedgerSlots, fp, nullptr, error);
  MPI_Bcast(departed_ledger_, kLedgerSlots, MPI_DOUBLE, 0, world);
  int memory = 0;  // versions 1-4: not recorded, the behaviour they had (pair)
  if (layout[1] >= 5 && me == 0)
    utils::sfread(FLERR, &memory, sizeof(int), 1, fp, nullptr, error);
  MPI_Bcast(&memory, 1, MPI_INT, 0, world);
  place_memory_ = memory != 0;
  departed_reset_ = 0.0;  // versions 1-4: no resets
  if (layout[1] >= 5 && me == 0)
    utils::sfread(FLERR, &departed_reset_, sizeof(double), 1, fp, nullptr, error);
  MPI_Bcast(&departed_reset_, 1, MPI_DOUBLE, 0, world);
  int range = 0;  // versions 1-5: not recorded, the behaviour they had (warn)
  if (layout[1] >= 6 && me == 0) utils::sfread(FLERR, &range, sizeof(int), 1, fp, nullptr, error);
  MPI_Bcast(&range, 1, MPI_INT, 0, world);
  range_error_ = range != 0;
}

double PairGeocontact::memory_usage()
{
  double bytes = Pair::memory_usage();
  bytes += static_cast<double>(pair_records_.capacity()) * sizeof(ContactRecord);
  bytes += static_cast<double>((record_of_.capacity() + first_pair_.capacity()) * sizeof(int));
  return bytes;
}
