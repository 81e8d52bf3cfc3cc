// Per-contact history of pair_style geocontact (see fix_geocontact_history.h).
#include "fix_geocontact_history.h"

#include "contact_forces.h"
#include "contact_setup.h"
#include "contact_state.h"

#include "atom.h"
#include "comm.h"
#include "error.h"

#include <algorithm>
#include <string>

using namespace LAMMPS_NS;
using namespace FixConst;

FixGeocontactHistory::FixGeocontactHistory(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg)
{
  if (narg != 3) error->all(FLERR, "Illegal fix geocontact/history command: takes no arguments");
  if (!atom->tag_enable) error->all(FLERR, "Fix geocontact/history requires atom IDs");
  restart_peratom = 1;
  create_attribute = 1;
  maxexchange_dynamic = 1;
  maxexchange = 2;
  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
  atom->add_callback(Atom::RESTART);
}

FixGeocontactHistory::~FixGeocontactHistory()
{
  atom->delete_callback(id, Atom::GROW);
  atom->delete_callback(id, Atom::RESTART);
}

int FixGeocontactHistory::setmask()
{
  return PRE_EXCHANGE | POST_NEIGHBOR | MIN_PRE_EXCHANGE | MIN_POST_NEIGHBOR | POST_RUN;
}

// Comm::exchange sizes its buffers from maxexchange: the largest table this rank may send.
void FixGeocontactHistory::update_maxexchange()
{
  size_t most = 0;
  for (int i = 0; i < atom->nlocal; ++i) most = std::max(most, tables[i].size());
  maxexchange = 2 + static_cast<int>(most) * kRecordSize;
}

void FixGeocontactHistory::setup_pre_exchange()
{
  sync();
  update_maxexchange();
}
void FixGeocontactHistory::pre_exchange()
{
  sync();
  update_maxexchange();
}
void FixGeocontactHistory::min_pre_exchange()
{
  sync();
  update_maxexchange();
}
void FixGeocontactHistory::post_run() { sync(); }
void FixGeocontactHistory::setup_post_neighbor() { neighbors_rebuilt = true; }
void FixGeocontactHistory::post_neighbor() { neighbors_rebuilt = true; }
void FixGeocontactHistory::min_post_neighbor() { neighbors_rebuilt = true; }

void FixGeocontactHistory::grow_arrays(int nmax)
{
  if (static_cast<size_t>(nmax) > tables.size()) tables.resize(nmax);
}

void FixGeocontactHistory::copy_arrays(int i, int j, int /*delflag*/)
{
  tables[j] = tables[i];
}

void FixGeocontactHistory::set_arrays(int i)
{
  tables[i].clear();
}

// Layout: [count, (partner, 13 law slots, 3 tangential, 3 rolling, twist, energy scale, law
// index, contact radius, ledger channels, 2 travelled distances, forgotten work, its change of
// stored energy, due) x count]
int FixGeocontactHistory::pack_table(const std::vector<ContactRecord> &table, double *buf)
{
  int m = 0;
  buf[m++] = static_cast<double>(table.size());
  for (const ContactRecord &r : table) {
    buf[m++] = ubuf(r.partner).d;
    m += geocontact_forces::pack_state(r.law, buf + m);
    buf[m++] = r.tangential[0];
    buf[m++] = r.tangential[1];
    buf[m++] = r.tangential[2];
    for (int k = 0; k < 3; ++k) buf[m++] = r.rolling[k];
    buf[m++] = r.twist;
    buf[m++] = r.energy_scale;
    buf[m++] = static_cast<double>(r.law_index);
    buf[m++] = r.contact_radius;
    for (double d : r.dissipated) buf[m++] = d;
    buf[m++] = r.travel[0];
    buf[m++] = r.travel[1];
    buf[m++] = r.forgotten;
    buf[m++] = r.reset_stored;
    buf[m++] = r.due;
  }
  return m;
}

int FixGeocontactHistory::unpack_table(std::vector<ContactRecord> &table, const double *buf,
                                       int layout_version)
{
  const bool with_rolling = layout_version >= 2, with_scale = layout_version >= 3;
  const bool with_radius = layout_version >= 4, with_ledger = layout_version >= 5;
  const bool with_travel = layout_version >= 6, with_due = layout_version >= 7;
  int m = 0;
  const int n = static_cast<int>(buf[m++]);
  table.resize(n);
  for (ContactRecord &r : table) {
    r.partner = static_cast<tagint>(ubuf(buf[m++]).i);
    m += geocontact_forces::unpack_state(r.law, buf + m);
    r.tangential[0] = buf[m++];
    r.tangential[1] = buf[m++];
    r.tangential[2] = buf[m++];
    for (int k = 0; k < 3; ++k) r.rolling[k] = with_rolling ? buf[m++] : 0.0;
    r.twist = with_rolling ? buf[m++] : 0.0;
    r.energy_scale = with_scale ? buf[m++] : 0.0;
    r.law_index = with_scale ? static_cast<int>(buf[m++]) : 0;
    r.contact_radius = with_radius ? buf[m++] : -1.0;
    for (double &d : r.dissipated) d = with_ledger ? buf[m++] : 0.0;
    for (double &t : r.travel) t = with_travel ? buf[m++] : 0.0;
    r.forgotten = with_travel ? buf[m++] : 0.0;
    r.reset_stored = with_travel ? buf[m++] : 0.0;
    r.due = with_due ? static_cast<int>(buf[m++]) : 0;
  }
  return m;
}

int FixGeocontactHistory::pack_exchange(int i, double *buf)
{
  sync();
  return pack_table(tables[i], buf);
}

int FixGeocontactHistory::unpack_exchange(int nlocal, double *buf)
{
  grow_arrays(nlocal + 1);
  return unpack_table(tables[nlocal], buf);
}

// Restart: [length, layout tag, count, records]; buf[0] is the length of this fix's data for
// the atom, including buf[0] itself.
int FixGeocontactHistory::pack_restart(int i, double *buf)
{
  sync();
  buf[1] = ubuf(kRestartTag).d;
  const int m = 2 + pack_table(tables[i], buf + 2);
  buf[0] = m;
  return m;
}

// A record of another layout (an older plugin's file has the count where the tag is now) is
// never unpacked: the atom is left without history, and init() refuses the run on every rank.
// Layout version 1 (no rolling and twist slots) is read with both at zero, version 2 (no
// energy scale) with the scale unknown until the record's next step, version 3 (no contact
// radius) with the radius taken from the law state at the record's next step, version 4 (no
// ledger) with the ledger at zero, version 5 (no travelled distances) with travel 0 and nothing
// forgotten, version 6 (no due flag) not due.
void FixGeocontactHistory::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;
  for (int k = 0; k < nth; ++k) m += static_cast<int>(extra[nlocal][m]);
  grow_arrays(nlocal + 1);
  const double *record = &extra[nlocal][m];
  const int64_t tag = ubuf(record[1]).i;
  const int length = static_cast<int>(record[0]);
  const int version = (tag & ~int64_t(0xffffffff)) == kRestartTagBase
                          ? static_cast<int>(tag & 0xffffffff) : 0;
  const int size = version == 1   ? kRecordSizeV1
                   : version == 2 ? kRecordSizeV2
                   : version == 3 ? kRecordSizeV3
                   : version == 4 ? kRecordSizeV4
                   : version == 5 ? kRecordSizeV5
                   : version == 6 ? kRecordSizeV6
                                  : kRecordSize;
  const int count =
      version >= 1 && version <= kRestartLayoutVersion ? static_cast<int>(record[2]) : -1;
  if (count < 0 || length != kRestartHeader + count * size) {
    if (!unreadable_restart_) unreadable_tag_ = tag;
    unreadable_restart_ = true;
    tables[nlocal].clear();
    return;
  }
  unpack_table(tables[nlocal], record + 2, version);
}

// What a restart record's tag says, for the error message.
static std::string describe_tag(int64_t tag)
{
  const int64_t version = tag & 0xffffffff;
  if ((tag & ~int64_t(0xffffffff)) == FixGeocontactHistory::kRestartTagBase && version >= 1 &&
      version <= FixGeocontactHistory::kRestartLayoutVersion)
    return "the right layout tag but a record length that does not match its contact count";
  if ((tag & ~int64_t(0xffffffff)) == FixGeocontactHistory::kRestartTagBase)
    return fmt::format("contact-history layout version {}", tag & 0xffffffff);
  return fmt::format("no geocontact layout tag (0x{:016x} where the tag belongs: an older "
                     "plugin's or a foreign layout)", static_cast<uint64_t>(tag));
}

void FixGeocontactHistory::init()
{
  // Collective: the lowest rank that met an unreadable record names it.
  const int mine = unreadable_restart_ ? comm->me : comm->nprocs;
  int first = comm->nprocs;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, world);
  if (first == comm->nprocs) return;
  int64_t tag = unreadable_tag_;
  MPI_Bcast(&tag, 1, MPI_INT64_T, first, world);
  error->all(FLERR, "Fix geocontact/history: the restart file's per-atom contact history has {}; "
                    "this plugin reads contact-history layout versions 1 to {} only (re-create the "
                    "restart with this plugin)",
             describe_tag(tag), kRestartLayoutVersion);
}

int FixGeocontactHistory::size_restart(int i)
{
  sync();
  return kRestartHeader + static_cast<int>(tables[i].size()) * kRecordSize;
}

int FixGeocontactHistory::maxsize_restart()
{
  sync();
  size_t most = 0;
  for (int i = 0; i < atom->nlocal; ++i) most = std::max(most, tables[i].size());
  return kRestartHeader + static_cast<int>(most) * kRecordSize;
}

double FixGeocontactHistory::memory_usage()
{
  double bytes = static_cast<double>(tables.capacity()) * sizeof(std::vector<ContactRecord>);
  for (const auto &t : tables) bytes += static_cast<double>(t.capacity()) * sizeof(ContactRecord);
  return bytes;
}
