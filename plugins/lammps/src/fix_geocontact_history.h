// Per-contact history of pair_style geocontact, attached to atoms.
//
// The wheel's headers do not ship fix_neigh_history.h, so the pair keeps its own history: each
// owned atom carries a small table with one record per contact partner (the law's state and the
// accumulated tangential force). A contact between atoms a and b is recorded on both, mirrored
// (tangential force negated), so each atom's table is complete on whichever rank owns it.
// The tables travel with atoms that migrate between ranks (pack/unpack_exchange), follow atom
// sorting and deletion (copy_arrays) and are written to and read from restart files
// (pack/unpack_restart). The pair style creates this fix; users do not.
//
// Restart layout of one atom: [length, layout tag, count, record x count]. The tag (the bytes
// "GCHS" and a layout version) lets a file of another layout be refused instead of misread
// (version 1, before rolling and twisting, is read with both at zero); the fix writes no
// global restart data (everything it keeps is per atom).
#ifdef FIX_CLASS
// clang-format off
FixStyle(geocontact/history,FixGeocontactHistory);
// clang-format on
#else

#ifndef LMP_FIX_GEOCONTACT_HISTORY_H
#define LMP_FIX_GEOCONTACT_HISTORY_H

#include "contact_forces.h"
#include "fix.h"
#include "geocontact/law.hpp"

#include <cstdint>
#include <functional>
#include <vector>

namespace LAMMPS_NS {

struct ContactRecord {
  tagint partner;                // atom ID of the other grain
  geocontact::ContactState law;  // normal law state (docs/law.md)
  double tangential[3];          // accumulated tangential force on this atom (N)
  double rolling[3];             // rolling displacement (m), the same on both atoms
  double twist;                  // twist angle (rad), the same on both atoms
  // s^3 of the pair's similarity scale (energies of the law's state are s^3 times) and the
  // index of its law, set at every step: what the pair's dissipation in J needs once the record
  // is dropped (the partner may be gone by then); 0 = not known yet (an older restart's record)
  double energy_scale = 0.0;
  int law_index = 0;
  // the contact radius a of the last step (run lengths): the springs that follow a are rescaled
  // when it changes (contact_forces.h radius_change); < 0 = not known (an older restart's
  // record: taken from its law state at its next step)
  double contact_radius = -1.0;
  // the energy ledger of the contact (contact_forces.h LedgerChannel, run energy units): what
  // its dashpots, sliding, rolling and twisting dissipated since it formed; the same on both
  // atoms
  double dissipated[geocontact_forces::kLedgerSlots] = {};
  // memory with a place (contact_forces.h track_place): how far the contact point has moved on
  // this atom's surface [0] and on the partner's [1] since the law's envelope was last set (run
  // lengths; swapped in the partner's mirror), and the law's work carried over the dents the
  // contact has forgotten (run energy units, the same on both atoms): the old work less the
  // fresh state's at the same approach, so the law's tally loses nothing at a reset
  double travel[2] = {0.0, 0.0};
  double forgotten = 0.0;
  // of which: the stored normal energy the resets changed, old less fresh (negative: the fresh
  // virgin state holds more than the dent did at the same approach, energy the reset created)
  double reset_stored = 0.0;
  // the point has travelled past the dent (2 a_max) but forgetting it would have stored more
  // normal energy than the dent holds: forgotten at the first step where it does not
  // (contact_forces.h forget_if_safe)
  int due = 0;
};

class FixGeocontactHistory : public Fix {
 public:
  // doubles per record when packed: partner ID, 13 law slots, 3 tangential components, 3
  // rolling components, the twist angle, the energy scale, the law index, the contact radius
  // and the ledger's channels, the two travelled distances, the forgotten law work and its
  // change of stored energy, the due flag
  static constexpr int kRecordSize = 29 + geocontact_forces::kLedgerSlots;
  // Per-atom restart layout: bumped whenever the packed record changes. Versions 1 (records
  // without rolling and twist, kRecordSizeV1 doubles), 2 (without the energy scale and law
  // index, kRecordSizeV2), 3 (without the contact radius, kRecordSizeV3) and 4 (without the
  // energy ledger, kRecordSizeV4), 5 (without the travelled distances and the forgotten law
  // work, kRecordSizeV5) and 6 (without the due flag, kRecordSizeV6) are still read: contacts
  // that have not rolled or twisted yet, whose energy scale the next step sets, whose contact
  // radius is taken from their law state, whose ledger starts at zero (what they dissipated
  // before is not known), whose contact point has not travelled yet (travel 0, nothing
  // forgotten) and that are not due (layout 6 forgot a dent at once: none was due; one that has
  // travelled past its dent becomes due at its next step).
  static constexpr int kRestartLayoutVersion = 7;
  static constexpr int kRecordSizeV1 = 17;
  static constexpr int kRecordSizeV2 = 21;
  static constexpr int kRecordSizeV3 = 23;
  static constexpr int kRecordSizeV4 = 24;
  static constexpr int kRecordSizeV5 = 24 + geocontact_forces::kLedgerSlots;
  static constexpr int kRecordSizeV6 = 28 + geocontact_forces::kLedgerSlots;
  // The layout tag as 64 bits: "GCHS" in the high half, the layout version in the low half
  // (in the file, little-endian: the version, then the bytes G C H S). Stored with ubuf, so
  // it travels as the bit pattern of a (normal, finite) double.
  static constexpr int64_t kRestartTagBase = static_cast<int64_t>(0x53484347) << 32;
  static constexpr int64_t kRestartTag = kRestartTagBase | kRestartLayoutVersion;
  // Doubles per atom in a restart file besides the records: length, layout tag, count.
  static constexpr int kRestartHeader = 3;

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
  void init() override;

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
  // The first per-atom restart record this rank could not read (another layout tag, or a
  // record length that does not match its count): unpack_restart leaves such an atom without
  // history and init() stops the run.
  bool unreadable_restart_ = false;
  int64_t unreadable_tag_ = 0;
  void update_maxexchange();
  static int pack_table(const std::vector<ContactRecord> &table, double *buf);
  static int unpack_table(std::vector<ContactRecord> &table, const double *buf,
                          int layout_version = kRestartLayoutVersion);
};

}  // namespace LAMMPS_NS

#endif
#endif
