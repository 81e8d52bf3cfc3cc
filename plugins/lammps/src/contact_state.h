// A law state as doubles: the records of the contact history fix, the wall fixes' per-atom
// arrays, exchange and restart buffers (the order of geocontact::ContactState).
#ifndef LMP_GEOCONTACT_CONTACT_STATE_H
#define LMP_GEOCONTACT_CONTACT_STATE_H

#include "geocontact/law.hpp"

namespace LAMMPS_NS {
namespace geocontact_forces {

constexpr int kStateSlots = 13;

inline int pack_state(const geocontact::ContactState &s, double *buf)
{
  int m = 0;
  buf[m++] = s.approach;
  buf[m++] = s.force;
  buf[m++] = s.max_approach;
  buf[m++] = s.max_force;
  buf[m++] = s.residual_approach;
  buf[m++] = s.unloading_exponent;
  buf[m++] = s.reloading_exponent;
  buf[m++] = s.branch_value;
  buf[m++] = s.ratchet_shift;
  buf[m++] = s.pending_ratchet;
  buf[m++] = s.cycles;
  buf[m++] = s.work;
  buf[m++] = static_cast<double>(s.branch);
  return m;
}

inline int unpack_state(geocontact::ContactState &s, const double *buf)
{
  int m = 0;
  s.approach = buf[m++];
  s.force = buf[m++];
  s.max_approach = buf[m++];
  s.max_force = buf[m++];
  s.residual_approach = buf[m++];
  s.unloading_exponent = buf[m++];
  s.reloading_exponent = buf[m++];
  s.branch_value = buf[m++];
  s.ratchet_shift = buf[m++];
  s.pending_ratchet = buf[m++];
  s.cycles = buf[m++];
  s.work = buf[m++];
  s.branch = static_cast<int>(buf[m++]);
  return m;
}

}  // namespace geocontact_forces
}  // namespace LAMMPS_NS

#endif
