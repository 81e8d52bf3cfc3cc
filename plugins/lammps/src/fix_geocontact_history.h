// Per-contact history of pair_style geocontact, attached to atoms.
//
// The wheel's headers do not ship fix_neigh_history.h, so the pair keeps its own history: each
// owned atom carries a small table with one record per contact partner (the law's state and the
// accumulated tangential force). A contact between atoms a and b is recorded on both, mirrored
// (tangential force negated), so each atom's table is complete on whichever rank owns it.
// The tables travel with atoms that migrate between ranks (pack/unpack_exchange), follow atom
// sorting and deletion (copy_arrays) and are written to and read from restart files
// (pack/unpack_restart). The pair style creates this fix; users do not.
#ifdef FIX_CLASS
// clang-format off
FixStyle(geocontact/history,FixGeocontactHistory);
// clang-format on
#else

#ifndef LMP_FIX_GEOCONTACT_HISTORY_H
#define LMP_FIX_GEOCONTACT_HISTORY_H

#include "fix.h"
#include "geocontact/law.hpp"

#include <functional>
#include <vector>

namespace LAMMPS_NS {

struct ContactRecord {
  tagint partner;                // atom ID of the other grain
  geocontact::ContactState law;  // normal law state (docs/law.md)
  double tangential[3];          // accumulated tangential force on this atom (N)
};

class FixGeocontactHistory : public Fix {
 public:
  // doubles per record when packed: partner ID, 13 law slots, 3 tangential components
  static constexpr int kRecordSize = 17;

  FixGeocontactHistory(class LAMMPS *, int, char **);
  ~FixGeocontactHistory() override;
  int setmask() override;
  void setup_pre_exchange() override;
  void pre_exchange() override;
  void min_pre_exchange() override;
  void setup_post_neighbor() override;
  void post_neighbor() override;
  void min_post_neighbor() override;
  void post_run() override;

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

  // One table per owned atom (index = local atom index), read and written by the pair style.
  std::vector<std::vector<ContactRecord>> tables;
  // During a run the pair updates only the record of the neighbor-list atom i of each contact;
  // the mirror on atom j is brought up to date by sync() before anything reads or moves the
  // tables (exchange, restart, end of run): it saves a scattered write per contact and step.
  std::function<void()> sync_mirrors;
  bool mirrors_stale = false;
  void sync()
  {
    if (mirrors_stale && sync_mirrors) sync_mirrors();
    mirrors_stale = false;
  }

  // Set whenever neighbor lists were rebuilt (atoms may have moved between slots or ranks);
  // the pair re-indexes its contacts before the next force computation.
  bool neighbors_rebuilt = true;

  // A table grew to n records: make sure Comm::exchange reserves room for it.
  void note_table_size(size_t n)
  {
    const int need = 2 + static_cast<int>(n) * kRecordSize;
    if (need > maxexchange) maxexchange = need;
  }

  static int find(const std::vector<ContactRecord> &table, tagint partner)
  {
    const int n = static_cast<int>(table.size());
    for (int k = 0; k < n; ++k)
      if (table[k].partner == partner) return k;
    return -1;
  }

 private:
  void update_maxexchange();
  static int pack_table(const std::vector<ContactRecord> &table, double *buf);
  static int unpack_table(std::vector<ContactRecord> &table, const double *buf);
};

}  // namespace LAMMPS_NS

#endif
#endif
