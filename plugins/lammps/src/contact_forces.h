// One contact's forces besides the normal law, shared by pair_style geocontact (grain-grain)
// and the wall fixes (grain-wall), in the manner of LAMMPS's granular sub-models: the contact
// frame, the stiffnesses from the law's state, viscous damping, the incremental Mindlin-Coulomb
// tangential force, rolling and twisting resistance, the energy ledger and the one contact step.
// Physics only: reading law files, the run's unit style and the keywords are contact_setup.h;
// a law state as doubles (histories, exchange and restart buffers) is contact_state.h.
#ifndef LMP_GEOCONTACT_CONTACT_FORCES_H
#define LMP_GEOCONTACT_CONTACT_FORCES_H

#include "geocontact/law.hpp"

#include <algorithm>
#include <cmath>
#include <string>

// A function kept out of line where inlining it into a loop would make the loop share its
// registers (pair_geocontact.cpp touch_pair).
#if defined(__GNUC__) || defined(__clang__)
#define GEOCONTACT_NOINLINE __attribute__((noinline))
#else
#define GEOCONTACT_NOINLINE
#endif

namespace LAMMPS_NS {
namespace geocontact_forces {

inline double dot3(const double *a, const double *b)
{
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

inline void cross3(const double *a, const double *b, double *c)
{
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

// Where the bodies touch and how the contact point moves: the unit normal n (towards body i),
// the normal relative speed (positive when separating) and the tangential relative velocity of
// the contact point of i with respect to that of j. The contact point is armi from the centre
// of i and armj from that of j: r - delta/2 for two grains at overlap delta (their contact
// plane halves the overlap), r - w for a grain at interference w with a wall (the contact is on
// the wall's surface); the torques of the tangential force use the same arms, so the power of
// the contact forces is that of the springs. A wall is body j with its velocity, no spin and
// arm 0.
struct ContactFrame {
  double n[3];
  double vn;
  double vt[3];
};

inline ContactFrame contact_frame(const double *n, const double *vi, const double *vj,
                                  const double *wi, const double *wj, double armi, double armj)
{
  ContactFrame c;
  for (int k = 0; k < 3; ++k) c.n[k] = n[k];
  const double vr[3] = {vi[0] - vj[0], vi[1] - vj[1], vi[2] - vj[2]};
  c.vn = dot3(vr, c.n);
  const double wr[3] = {armi * wi[0] + armj * wj[0], armi * wi[1] + armj * wj[1],
                        armi * wi[2] + armj * wj[2]};
  c.vt[0] = vr[0] - c.vn * c.n[0] - (wr[1] * c.n[2] - wr[2] * c.n[1]);
  c.vt[1] = vr[1] - c.vn * c.n[1] - (wr[2] * c.n[0] - wr[0] * c.n[2]);
  c.vt[2] = vr[2] - c.vn * c.n[2] - (wr[0] * c.n[1] - wr[1] * c.n[0]);
  return c;
}

// --- the run's units -------------------------------------------------------------------------
//
// The law file is SI (docs/law.md); a LAMMPS run counts lengths, forces and energies in the units
// of its unit style. The SI size of each style's units, from LAMMPS's `units` documentation
// (CODATA 2018 for eV, the Bohr radius and the Hartree; the thermochemical kcal, 4184 J). `lj`
// has no physical size: the law cannot be placed in it.
struct RunUnits {
  double length;       // m per length unit of the run
  double force;        // N per force unit
  double energy;       // J per energy unit
  double ftm2v = 1.0;  // LAMMPS's force->ftm2v: 1 where mass, length and time are coherent
};

inline bool physical_units(const std::string &style, RunUnits &u)
{
  constexpr double eV = 1.602176634e-19, kcal_per_mol = 4184.0 / 6.02214076e23;
  constexpr double bohr = 5.29177210903e-11, hartree = 4.3597447222071e-18;
  if (style == "si") u = {1.0, 1.0, 1.0};
  else if (style == "cgs") u = {1e-2, 1e-5, 1e-7};            // cm, dyne, erg
  else if (style == "micro") u = {1e-6, 1e-9, 1e-15};         // um, pg um/us^2, pg um^2/us^2
  else if (style == "nano") u = {1e-9, 1e-12, 1e-21};         // nm, ag nm/ns^2, ag nm^2/ns^2
  else if (style == "metal") u = {1e-10, eV / 1e-10, eV};     // Angstrom, eV/Angstrom, eV
  else if (style == "real") u = {1e-10, kcal_per_mol / 1e-10, kcal_per_mol};
  else if (style == "electron") u = {bohr, hartree / bohr, hartree};
  else return false;
  return true;
}

// Stiffnesses of the contact for damping and friction, in the run's units: the unloading
// stiffness S of the law's current branch, the contact radius a (S = 2 E* a, Sneddon, or the
// law file's fit to the FE) and Mindlin's k_t = 8 G* a.
struct ContactStiffness {
  double normal;      // S, force / length
  double tangential;  // k_t, force / length
  double radius;      // contact radius a, length
};

// The law file's numbers in the run's units, computed once per law and run (off the force
// loop): the calibrated radius R, the law's approach per run length, and the factors that take
// the law's SI stiffness S (N/m) to S, a and k_t in the run's units; forces, energies.
struct StiffnessConstants {
  double calibrated_radius;     // R in run lengths
  double approach_to_law;       // m per run length: the law's approach is L d / s
  double force_to_run;          // 1 / (N per force unit)
  double energy_to_run;         // 1 / (J per energy unit)
  double length_to_run;         // 1 / (m per run length)
  double stiffness_to_run;      // (m per length) / (N per force): N/m to the run's
  double radius_per_stiffness;  // 1 / (2 E* L): a in run lengths per N/m of S
  double mindlin_modulus;       // 8 G* L^2 / F: k_t in the run's units per run length of a
  // 1 / ftm2v: sqrt(m k / ftm2v) is a damping coefficient in force per velocity also where the
  // run's mass, length, time and force units are not coherent (metal, real, electron)
  double damping_mass;
};

inline StiffnessConstants stiffness_constants(const geocontact::LawParams &law,
                                              const RunUnits &u)
{
  StiffnessConstants c;
  c.calibrated_radius = law.material.radius / u.length;
  c.approach_to_law = u.length;
  c.force_to_run = 1.0 / u.force;
  c.energy_to_run = 1.0 / u.energy;
  c.length_to_run = 1.0 / u.length;
  c.stiffness_to_run = u.length / u.force;
  c.radius_per_stiffness = 1.0 / (2.0 * law.material.effective_modulus() * u.length);
  c.mindlin_modulus = 8.0 * law.material.effective_shear_modulus() * u.length * u.length /
                      u.force;
  c.damping_mass = 1.0 / u.ftm2v;
  return c;
}

// The contact's stiffnesses by the similarity rule (geocontact::Similarity, docs/model.md §10):
// the calibrated unloading stiffness S_R scaled to the contact (s for two grains; 2 s for a
// grain on a rigid wall, the FE half model: dF/dw = 2 S, which is 2 E*_wall a with the
// sphere-flat modulus E*_wall = E / (1 - nu^2) = 2 E*, and Mindlin 8 G*_wall a with
// G*_wall = G / (2 - nu) = 2 G*, a rigid wall adding no compliance), the contact radius s a_R of
// the pair in both.
inline ContactStiffness contact_stiffness(const geocontact::LawParams &law,
                                          const StiffnessConstants &constants,
                                          const geocontact::ContactState &state,
                                          const geocontact::Similarity &sim)
{
  const double calibrated = geocontact::unloading_stiffness(law, state);
  // the calibrated spheres' a: S_R / 2 E* (Sneddon), or the law file's fit to the FE's
  // (`contact_radius`, docs/law.md "The contact radius")
  const double radius = law.radius_table.empty()
                            ? calibrated * constants.radius_per_stiffness
                            : geocontact::contact_radius(law, state) * constants.length_to_run;
  // k_t = 8 G* a for two grains, twice that on a wall: sim.stiffness / s times 8 G* a
  const double kt = sim.stiffness * radius * constants.mindlin_modulus;
  return {sim.stiffness * calibrated * constants.stiffness_to_run, kt, sim.scale * radius};
}

inline double reduced_mass(double mi, double mj)
{
  return mi * mj / (mi + mj);
}

// Viscous damping at a fraction beta of critical, 2 beta sqrt(m_eff k), per direction (a
// grain on a wall: m_eff its mass); meff here is m_eff times StiffnessConstants::damping_mass.
struct Damping {
  double normal;
  double tangential;
};

inline Damping damping_coefficients(double beta, double meff, const ContactStiffness &k)
{
  if (beta <= 0.0) return {0.0, 0.0};
  return {2.0 * beta * std::sqrt(meff * k.normal), 2.0 * beta * std::sqrt(meff * k.tangential)};
}

// The normal force: the law's force less the damping force against the approach rate (-vn);
// never tensile.
inline double damped_normal_force(double law_force, double damping, double vn)
{
  const double fn = law_force - damping * vn;
  return fn > 0.0 ? fn : 0.0;
}

// How the springs whose stiffness follows the contact radius a respond when a changes from
// a_prev (the last step's) to a, so that no spring gains energy from a change of stiffness
// (Walton 1993; Thornton et al. 2013; LAMMPS's `mindlin_rescale/force`). The tangential spring
// keeps a force f_s with k_t = 8 G* a, energy f_s^2 / (2 k_t): when a falls f_s is scaled by
// a / a_prev (its energy by a / a_prev), when a rises f_s is kept (its energy falls). The twist
// spring keeps an angle phi with k_tw = k_t a^2 / 2, proportional to a^3, energy k_tw phi^2 / 2:
// when a falls phi is kept (its energy falls as (a / a_prev)^3), when a rises phi is scaled by
// (a_prev / a)^3, which keeps its torque (its energy falls). a_prev <= 0: a new contact.
//
// The factor on the stored tangential force (a / a_prev when a falls, else 1).
inline double tangential_rescale(double a_prev, double a)
{
  return a < a_prev ? a / a_prev : 1.0;
}

// The factor on the stored twist angle ((a_prev / a)^3 when a rises on a contact that had a
// radius, else 1): asked only where twisting is on, so a rising a costs no division otherwise.
inline double twist_rescale(double a_prev, double a)
{
  if (a > a_prev && a_prev > 0.0) {
    const double r = a_prev / a;
    return r * r * r;
  }
  return 1.0;
}

// Incremental Mindlin-Coulomb tangential force. The stored force fs (not a displacement) is
// first rotated into the current tangent plane keeping its magnitude and scaled by `rescale`
// (radius_change), then incremented by -k_t v_t dt. The spring carries a Coulomb slider in
// series: its force never exceeds mu fn (beyond it the contact slips and the spring keeps mu fn
// along its own direction). The tangential dashpot acts beside it, and the total force on the
// grains, fs - gamma_t v_t, is capped at mu fn as well (the dashpot gives up its excess).
//
// Why not LAMMPS's reset (the spring set to the capped total less the dashpot's part): when the
// dashpot's force alone exceeds the cap, that reset stores the spring *along* the sliding
// velocity, so the spring gains energy no work put there and the ledger books a negative
// sliding dissipation against an inflated dashpot one (-545 % and +621 % of the walls' work in
// the oedometer test at beta = 0.5). Here the spring only gains energy by its elastic increment,
// the slider only removes it, and the dashpot's share is the projection of fs - gamma_t v_t onto
// the Coulomb disc, whose power -(ft - fs) . v_t is >= 0 for any fs inside the disc (a property
// of the projection onto a convex set). Without damping the two rules are the same.
//
// The energy terms of the step (ledger, run energy units): the spring energy fs^2 / (2 k_t)
// released by the change of stiffness (k_t_prev the last step's; the micro-slip of the annulus
// leaving or entering contact, Mindlin & Deresiewicz 1953), the dashpot's work
// -(ft - fs) . v_t dt, and at the slider the slip's: the work the spring's force takes from the
// step's displacement, -fs . v_t dt, less what the spring gained, so that the three with the
// spring's energy are the work of the force on the grains over the step.
struct TangentialEnergy {
  double radius_change = 0.0;
  double sliding = 0.0;
  double damping = 0.0;
};

inline TangentialEnergy tangential_force(double *fs, double *ft, const ContactFrame &c,
                                         double kt, double kt_prev, double damping,
                                         double friction, double fn, double dt, double rescale)
{
  TangentialEnergy e;
  const double fsn = dot3(fs, c.n);
  if (fsn != 0.0) {  // already in the plane (a flat wall's contact): the rotation is exactly 1
    const double before = std::sqrt(dot3(fs, fs));
    for (int k = 0; k < 3; ++k) fs[k] -= fsn * c.n[k];
    const double after = std::sqrt(dot3(fs, fs));
    if (after > 0.0) {
      const double scale = before / after;
      for (int k = 0; k < 3; ++k) fs[k] *= scale;
    }
  }
  const double held = dot3(fs, fs);
  double rescaled = held;  // fs unchanged unless rescaled
  if (rescale != 1.0) {
    for (int k = 0; k < 3; ++k) fs[k] *= rescale;
    rescaled = dot3(fs, fs);
  }
  if (kt_prev > 0.0 && kt > 0.0) e.radius_change = 0.5 * (held / kt_prev - rescaled / kt);
  for (int k = 0; k < 3; ++k) fs[k] -= kt * c.vt[k] * dt;
  const double limit = friction * fn;
  const double spring = std::sqrt(dot3(fs, fs));
  if (spring > limit) {  // the slider: the spring keeps mu fn
    const double scale = spring > 0.0 ? limit / spring : 0.0;
    for (int k = 0; k < 3; ++k) fs[k] *= scale;
    if (kt > 0.0) e.sliding = -dot3(fs, c.vt) * dt - 0.5 * (dot3(fs, fs) - rescaled) / kt;
  }
  for (int k = 0; k < 3; ++k) ft[k] = fs[k] - damping * c.vt[k];
  const double mag = std::sqrt(dot3(ft, ft));
  if (mag > limit) {  // the total capped: the dashpot gives up its excess
    const double scale = mag > 0.0 ? limit / mag : 0.0;
    for (int k = 0; k < 3; ++k) ft[k] *= scale;
  }
  double dashpot = 0.0;
  for (int k = 0; k < 3; ++k) dashpot -= (ft[k] - fs[k]) * c.vt[k];
  e.damping = dashpot * dt;
  return e;
}

// --- rolling and twisting resistance --------------------------------------------------------
//
// The models of LAMMPS's pair granular `rolling sds` and `twisting marshall`, with our normal
// force as the Coulomb reference. Unlike the tangential force, both keep a displacement
// (rolling: a vector in the tangent plane; twisting: an angle), and the stored value is the same
// from either grain's side of the contact: swapping i and j reverses both n and w_i - w_j, so the
// rolling velocity R* (w_i - w_j) x n and the twist rate (w_i - w_j) . n are unchanged.

struct RollingCoeffs {
  double stiffness;  // k_roll, N/m
  double damping;    // gamma_roll, N s/m
  double friction;   // mu_roll: the rolling force is capped by mu_roll F_n
  bool rolling;      // rolling sds given
  bool twisting;     // twisting marshall given
};

// Rolling resistance, spring-dashpot-slider (LAMMPS's `rolling sds`): the rolling displacement
// xi (history) is first rotated into the current tangent plane keeping its magnitude, then
// advanced by v_roll dt, v_roll = R* (w_i - w_j) x n (Wang et al. 2015, eq. 31); the rolling
// force -k xi - gamma v_roll is capped by mu_roll fn, where sliding makes xi the spring length
// of the capped force. The torque on i is R* n x F_roll. `advance` false (setup): xi neither
// rotated nor advanced nor stored, as LAMMPS's history_update. Returns the energy dissipated
// in the step (run energy units; 0 unless advanced): the dashpot's work, and at the cap the
// slip's, the work the spring's force takes from the step's rolling, k xi . v_roll dt, less
// what the spring (energy k |xi|^2 / 2) gained (as tangential_force); the torque's power on the
// grains is F_roll . v_roll.
inline double rolling_torque(double *xi, double *torque, const RollingCoeffs &c, const double *n,
                           const double *wi, const double *wj, double reff, double fn,
                           double dt, bool advance)
{
  const double relrot[3] = {wi[0] - wj[0], wi[1] - wj[1], wi[2] - wj[2]};
  double vroll[3];
  cross3(relrot, n, vroll);
  for (int k = 0; k < 3; ++k) vroll[k] *= reff;
  const double limit = c.friction * fn;
  double h[3] = {xi[0], xi[1], xi[2]};
  if (advance) {
    const double hn = dot3(h, n);
    // LAMMPS's threshold: a rotation whose force change is below 1e-10 of the limit is skipped
    if (std::fabs(hn) * c.stiffness > 1e-10 * limit) {
      const double before = std::sqrt(dot3(h, h));
      for (int k = 0; k < 3; ++k) h[k] -= hn * n[k];
      const double after = std::sqrt(dot3(h, h));
      const double scale = after > 0.0 ? before / after : 0.0;
      for (int k = 0; k < 3; ++k) h[k] *= scale;
    }
  }
  const double held = dot3(h, h);  // after the rotation, which keeps the spring's energy
  if (advance)
    for (int k = 0; k < 3; ++k) h[k] += vroll[k] * dt;
  double fr[3];
  for (int k = 0; k < 3; ++k) fr[k] = -c.stiffness * h[k] - c.damping * vroll[k];
  const double mag = std::sqrt(dot3(fr, fr));
  const bool capped = mag > limit;
  if (capped) {
    if (dot3(h, h) > 0.0) {
      const double scale = limit / mag;
      for (int k = 0; k < 3; ++k) {
        fr[k] *= scale;
        h[k] = -(fr[k] + c.damping * vroll[k]) / c.stiffness;
      }
    } else {
      fr[0] = fr[1] = fr[2] = 0.0;
    }
  }
  if (advance)
    for (int k = 0; k < 3; ++k) xi[k] = h[k];
  cross3(n, fr, torque);
  for (int k = 0; k < 3; ++k) torque[k] *= reff;
  if (!advance) return 0.0;
  double dashpot = 0.0;  // the part of F_roll that is not the spring's, against v_roll
  for (int k = 0; k < 3; ++k) dashpot -= (fr[k] + c.stiffness * h[k]) * vroll[k];
  const double slip =
      capped ? c.stiffness * (dot3(h, vroll) * dt - 0.5 * (dot3(h, h) - held)) : 0.0;
  return slip + dashpot * dt;
}

// Twisting resistance (LAMMPS's `twisting marshall`, Marshall 2009): the twist angle phi
// (history) advances by the twist rate (w_i - w_j) . n; the torque -k_tw phi - g_tw rate along
// n, capped by mu_tw fn, with the coefficients of the tangential model spread over the contact
// disc of radius a: k_tw = k_t a^2 / 2, g_tw = g_t a^2 / 2 and mu_tw = 2/3 mu a (here k_t is
// the Mindlin stiffness 8 G* a; LAMMPS's mindlin passes 8 G* instead). `rescale` scales the
// stored angle first (radius_change). Returns the energy dissipated in the step (run energy
// units; 0 unless advanced): the spring energy k_tw phi^2 / 2 released by the change of k_tw
// (k_prev the last step's; its part `radius_change` also reported alone), the dashpot's work,
// and at the cap the slip's (as tangential_force).
inline double twisting_torque(double &phi, double *torque, const double *n, const double *wi,
                              const double *wj, double kt, double damping_t, double friction,
                              double a, double fn, double dt, bool advance, double rescale,
                              double k_prev, double &radius_change)
{
  const double rate = (wi[0] - wj[0]) * n[0] + (wi[1] - wj[1]) * n[1] + (wi[2] - wj[2]) * n[2];
  const double k = 0.5 * kt * a * a;
  radius_change = 0.0;
  if (advance) {
    const double held = phi * phi;
    phi *= rescale;  // radius_change: the spring's stiffness follows a^3
    if (k_prev > 0.0) radius_change = 0.5 * (k_prev * held - k * phi * phi);
  }
  const double g = 0.5 * damping_t * a * a;
  const double limit = (2.0 / 3.0) * friction * a * fn;
  const double held = phi;
  double angle = advance ? phi + rate * dt : phi;
  double mt = -k * angle - g * rate;
  const bool capped = std::fabs(mt) > limit;
  if (capped) {
    const double sign = (rate > 0.0) - (rate < 0.0);
    mt = -limit * sign;
    angle = k > 0.0 ? (limit * sign - g * rate) / k : 0.0;
  }
  if (advance) phi = angle;
  for (int k3 = 0; k3 < 3; ++k3) torque[k3] = mt * n[k3];
  if (!advance) return 0.0;
  const double slip = capped ? k * (angle * rate * dt - 0.5 * (angle * angle - held * held)) : 0.0;
  return radius_change + slip - (mt + k * angle) * rate * dt;
}

// --- one contact step, shared by the pair and the walls ---------------------------------------
//
// In the manner of LAMMPS's GranularModel (one object a pair and a wall both call): given where
// and how the bodies touch, the law's step, the stiffnesses, damping, the tangential force and
// the rolling and twisting torques, with the record's springs kept and rescaled. The pair and
// the walls differ only in their geometry (ContactGeometry), the wall's similarity being the FE
// half model's (geocontact::wall_similarity).

// The model's coefficients of a type pair or a wall.
struct ContactCoeffs {
  double friction;             // Coulomb mu
  double damping;              // fraction of critical beta
  const RollingCoeffs *resistance;
};

// Where and how body i touches body j (a wall: no spin, arm 0).
struct ContactGeometry {
  double overlap;      // delta of two grains, or the interference w with a wall (run lengths)
  geocontact::Similarity sim;  // pair_similarity or wall_similarity (law.hpp, docs/model.md §10)
  const double *n;     // unit normal towards i (read only when touching)
  const double *vi, *vj, *wi, *wj;
  double armi, armj;   // centre to contact point (contact_frame)
  // the radii and masses of the bodies: the rolling radius R* = ri rj / (ri + rj) and the
  // reduced mass, computed only where rolling and damping ask for them (a division each); on a
  // wall (on_wall) R* = ri, the grain's radius or its effective one, and the mass is mi
  double ri, rj;
  double mi, mj;
  bool on_wall;
};

// R* and m_eff of the geometry (ContactGeometry).
inline double rolling_radius(const ContactGeometry &g)
{
  return g.on_wall ? g.ri : g.ri * g.rj / (g.ri + g.rj);
}

inline double effective_mass(const ContactGeometry &g)
{
  return g.on_wall ? g.mi : reduced_mass(g.mi, g.mj);
}

struct ContactResult {
  double law_force;    // the law's normal force (run units), before damping
  double fn;           // normal force with damping, never tensile
  double ft[3];        // tangential force on i
  double torque[3];    // rolling and twisting torque on i (the tangential force's: the caller's)
  double stiffness;    // normal stiffness (0 apart)
};

// --- the energy ledger -----------------------------------------------------------------------
//
// Each contact keeps, besides the law's own work (its state), the energy its other parts have
// dissipated since it formed (run energy units), in `Record::dissipated`. Over a step the work
// the bodies do on the contact is the change of the energy its springs store plus what it
// dissipates: the law (state.work less the law's elastic energy), the normal dashpot
// -(fn - F_law) vn dt, the tangential spring's energy removed at the Coulomb cap (sliding) and
// its dashpot, the rolling and twisting springs' energy removed at their caps and their
// dashpots. A spring whose stiffness follows the contact radius a (tangential k_t = 8 G* a,
// twisting k_tw = k_t a^2 / 2) loses stored energy without work when a changes (radius_change:
// the force or angle is rescaled so that none is created): that energy is the micro-slip of the
// ring of the contact area that leaves (or enters) stick (Mindlin & Deresiewicz 1953), counted
// as friction, in sliding (tangential) and twisting; LEDGER_RADIUS_CHANGE reports that part
// again on its own (it is included in the two, not added to them). A contact that separates
// releases what its springs still hold (little: the springs are capped by mu fn, which falls to
// 0) into the same channels.
enum LedgerChannel {
  LEDGER_SLIDING,
  LEDGER_NORMAL_DAMPING,
  LEDGER_TANGENTIAL_DAMPING,
  LEDGER_ROLLING,
  LEDGER_TWISTING,
  LEDGER_RADIUS_CHANGE,  // of which (in sliding and twisting): the change of the contact radius
  kLedgerSlots
};

// The energy stored in the springs besides the law's (run energy units).
struct SpringEnergy {
  double tangential = 0.0;
  double rolling = 0.0;
  double twisting = 0.0;
};

// Mindlin's k_t = 8 G* a of the contact (twice on a wall), for a contact radius a.
// sim.stiffness / sim.scale is exactly 1 for two grains (s / s) and 2 on a wall (2 s / s; law.hpp
// pair_similarity, wall_similarity): a compare gives the quotient's bits without the division.
inline double mindlin_stiffness(const StiffnessConstants &c, const geocontact::Similarity &sim,
                                double a)
{
  const double per_scale = sim.stiffness == sim.scale ? 1.0 : 2.0;
  return per_scale * c.mindlin_modulus * a;
}

// What the record's springs hold at the end of its last step: fs^2 / (2 k_t), k_roll xi^2 / 2
// and k_tw phi^2 / 2, the stiffnesses of its contact radius.
template <class Record>
inline SpringEnergy spring_energy(const Record &rec, const StiffnessConstants &c,
                                  const geocontact::Similarity &sim, const RollingCoeffs &rc)
{
  SpringEnergy e;
  const double a = rec.contact_radius;
  if (!(a > 0.0)) return e;
  const double kt = mindlin_stiffness(c, sim, a);
  e.tangential = 0.5 * dot3(rec.tangential, rec.tangential) / kt;
  if (rc.rolling) e.rolling = 0.5 * rc.stiffness * dot3(rec.rolling, rec.rolling);
  if (rc.twisting) e.twisting = 0.25 * kt * a * a * rec.twist * rec.twist;
  return e;
}

// No tangential, rolling or twist spring, and no contact radius (a contact not touching). `Record`:
// the law state `law`, the springs `tangential`, `rolling`, `twist` and `contact_radius`, and
// the ledger `dissipated` (pair and wall records alike).
template <class Record> inline void clear_springs(Record &rec)
{
  rec.tangential[0] = rec.tangential[1] = rec.tangential[2] = 0.0;
  rec.rolling[0] = rec.rolling[1] = rec.rolling[2] = 0.0;
  rec.twist = 0.0;
  rec.contact_radius = 0.0;
}

// A new contact: nothing dissipated yet.
template <class Record> inline void clear_ledger(Record &rec)
{
  for (int k = 0; k < kLedgerSlots; ++k) rec.dissipated[k] = 0.0;
}

// The contact separates: what its springs hold is released (dissipated) into their channels.
template <class Record>
inline void release_springs(Record &rec, const StiffnessConstants &c,
                            const geocontact::Similarity &sim, const RollingCoeffs &rc)
{
  const SpringEnergy e = spring_energy(rec, c, sim, rc);
  rec.dissipated[LEDGER_SLIDING] += e.tangential;
  rec.dissipated[LEDGER_ROLLING] += e.rolling;
  rec.dissipated[LEDGER_TWISTING] += e.twisting;
  clear_springs(rec);
}

// One step of a contact (`Record` as for clear_springs). `commit` false (setup): the springs are
// not advanced (LAMMPS's history update off), so the force is the one the last step ended with,
// and the ledger is not touched.
// Always inlined into its callers (the pair's touch_pair, the wall's touch_wall): as a call it
// took its geometry and gave its result through memory (docs/benchmarks.md, "The contact step
// outside the law, counted").
template <class Record>
GEOCONTACT_ALWAYS_INLINE ContactResult contact_step(const geocontact::LawParams &law,
                                                    const StiffnessConstants &c,
                                                    const ContactCoeffs &coeffs, Record &rec,
                                                    const ContactGeometry &g, double dt,
                                                    bool commit)
{
  ContactResult out;
  out.fn = out.stiffness = 0.0;
  for (int k = 0; k < 3; ++k) out.ft[k] = out.torque[k] = 0.0;
  const RollingCoeffs &rc = *coeffs.resistance;
  // n_r computed when the contact leaves the virgin curve (law.hpp step, LazyReloading): the
  // record's n_r of a contact on the curve is not read before then
  const geocontact::StepResult res = geocontact::step<false, true>(
      law, rec.law, g.overlap * (g.sim.approach * c.approach_to_law));
  out.law_force = g.sim.force * res.force * c.force_to_run;
  if (!(out.law_force > 0.0)) {
    if (commit) release_springs(rec, c, g.sim, rc);
    clear_springs(rec);
    return out;
  }
  const ContactFrame frame = contact_frame(g.n, g.vi, g.vj, g.wi, g.wj, g.armi, g.armj);
  const ContactStiffness k = contact_stiffness(law, c, rec.law, g.sim);
  out.stiffness = k.normal;
  const double a_prev = rec.contact_radius;
  const double kt_prev = a_prev > 0.0 ? mindlin_stiffness(c, g.sim, a_prev) : 0.0;
  rec.contact_radius = k.radius;
  const Damping damping =
      coeffs.damping > 0.0
          ? damping_coefficients(coeffs.damping, c.damping_mass * effective_mass(g), k)
          : Damping{0.0, 0.0};
  out.fn = damped_normal_force(out.law_force, damping.normal, frame.vn);
  const double step = commit ? dt : 0.0;
  double *ledger = rec.dissipated;
  if (commit) ledger[LEDGER_NORMAL_DAMPING] -= (out.fn - out.law_force) * frame.vn * dt;
  if (coeffs.friction > 0.0) {
    const TangentialEnergy e = tangential_force(
        rec.tangential, out.ft, frame, k.tangential, kt_prev, damping.tangential,
        coeffs.friction, out.fn, step, tangential_rescale(a_prev, k.radius));
    if (commit) {
      ledger[LEDGER_SLIDING] += e.sliding + e.radius_change;
      ledger[LEDGER_TANGENTIAL_DAMPING] += e.damping;
      ledger[LEDGER_RADIUS_CHANGE] += e.radius_change;
    }
  }
  if (rc.rolling)
    ledger[LEDGER_ROLLING] += rolling_torque(rec.rolling, out.torque, rc, g.n, g.wi, g.wj,
                                             rolling_radius(g), out.fn, dt, commit);
  if (rc.twisting) {
    double twist[3], radius_part = 0.0;
    const double k_prev = 0.5 * kt_prev * a_prev * a_prev;
    ledger[LEDGER_TWISTING] += twisting_torque(
        rec.twist, twist, g.n, g.wi, g.wj, k.tangential, damping.tangential, coeffs.friction,
        k.radius, out.fn, dt, commit, twist_rescale(a_prev, k.radius), k_prev, radius_part);
    ledger[LEDGER_RADIUS_CHANGE] += radius_part;
    for (int m = 0; m < 3; ++m) out.torque[m] += twist[m];
  }
  return out;
}

// --- memory with a place (docs/dem.md "Memory with a place") ----------------------------------
//
// The law's state (delta_max, delta_res, the branch) is a dent in the material of the grains at
// the spot where they touch. When the grains slide or roll, the contact point moves over their
// surfaces; once it has moved by more than the dent's diameter 2 a_max on either grain, the
// contact presses material that was never loaded, and the law starts again from untouched.
//
// How far the contact point moves on grain i's surface. Body i's centre is x_i, the unit normal
// n = (x_i - x_j) / r points towards i, and the contact point is c = x_i - b_i n with the arm
// b_i = r_i - delta/2 (contact_frame). The material point of i at c moves with
// v_i + w_i x (c - x_i) = v_i - b_i w_i x n; the contact point with dc/dt = v_i - b_i dn/dt
// - (db_i/dt) n. Their difference, dc/dt - v_mat = -b_i (dn/dt - w_i x n) - (db_i/dt) n, has the
// tangential part -b_i (dn/dt - w_i x n) (dn/dt and w_i x n are both normal to n, as |n| = 1);
// the normal part is the indentation, not a move along the surface. On j, c = x_j + b_j n and the
// same steps give b_j (dn/dt - w_j x n). With dn/dt = (v_r - (v_r . n) n) / r, v_r = v_i - v_j:
// one grain sliding round a fixed, non-spinning other one at tangential speed u moves the point
// by b_i u / r on i and b_j u / r on j (together u, the slip); rolling without slip moves it by
// the same arc on both. Each step adds |.| dt to the distance travelled on each grain.
inline void travel_rates(const double *n, const double *vi, const double *vj, const double *wi,
                         const double *wj, double r, double armi, double armj, double &rate_i,
                         double &rate_j)
{
  const double vr[3] = {vi[0] - vj[0], vi[1] - vj[1], vi[2] - vj[2]};
  const double vn = dot3(vr, n);
  double ndot[3], wn_i[3], wn_j[3];
  for (int k = 0; k < 3; ++k) ndot[k] = (vr[k] - vn * n[k]) / r;
  cross3(wi, n, wn_i);
  cross3(wj, n, wn_j);
  const double di[3] = {ndot[0] - wn_i[0], ndot[1] - wn_i[1], ndot[2] - wn_i[2]};
  const double dj[3] = {ndot[0] - wn_j[0], ndot[1] - wn_j[1], ndot[2] - wn_j[2]};
  rate_i = armi * std::sqrt(dot3(di, di));
  rate_j = armj * std::sqrt(dot3(dj, dj));
}

// How far, in dent radii a_max, the contact point must travel over a grain before its dent is
// behind it: a new contact circle of radius a_max centred that far from the old one starts at
// a_max from the dent's centre, where the FE's residual hollow ends (docs/dem.md "FE check of
// the 2 a_max rule": the hollow ends at 0.9-1.0 a_max from F = 10 to 1e4 Fy; the rim beyond it
// stands proud of the sphere, which no dent of the law represents).
constexpr double kDentTravelRadii = 2.0;

// The dent's radius a_max: the contact radius at the top of its envelope (F = F_max at
// delta_max), in the law's SI units; 0 for a contact never loaded.
inline double dent_radius(const geocontact::LawParams &law, const geocontact::ContactState &s)
{
  if (!s.touched() || !(s.max_force > 0.0)) return 0.0;
  geocontact::ContactState top = s;
  top.approach = s.max_approach + s.ratchet_shift;
  top.force = s.max_force;
  return geocontact::contact_radius(law, top);
}

// Forget the dent of a contact that is due (its point has travelled past the dent): the law
// restarts untouched at the approach of its last step, but only where the fresh state stores no
// more normal elastic energy than the dent at that approach, so that forgetting never creates
// energy (a contact law must create none); at the latest when the grains part (approach <= 0),
// where neither stores any. Until then the contact keeps its dent and stays due. `forgotten`
// takes the old state's work less the fresh state's at the same approach, so the law's tally
// (work - elastic energy) rises by what the reset released, old elastic energy less fresh,
// which is >= 0 and also kept in `reset_stored` (compute pair geocontact [18]): physically the
// sliding or rolling that carried the contact onto fresh material pays for it (ploughing, which
// the model does not resolve). The tangential, rolling and twisting springs are kept: they are
// the elastic shear and bending of the grains round the contact, which the contact carries with
// it as it moves (a steadily sliding contact keeps its Coulomb force), not a property of the
// material under it; the change of the contact radius at the reset rescales the tangential and
// twisting springs as any change of a does (radius_change), so none is created. Returns true
// when the dent was forgotten.
template <class Record>
inline bool forget_if_safe(const geocontact::LawParams &law, const StiffnessConstants &c,
                           const geocontact::Similarity &sim, Record &rec)
{
  geocontact::ContactState fresh;
  if (rec.law.approach > 0.0) geocontact::step(law, fresh, rec.law.approach);
  const double held = geocontact::elastic_energy(law, rec.law);
  const double fresh_stored = geocontact::elastic_energy(law, fresh);
  if (fresh_stored > held) return false;
  const double energy = sim.energy * c.energy_to_run;
  rec.forgotten += energy * (rec.law.work - fresh.work);
  rec.reset_stored += energy * (held - fresh_stored);
  rec.law = fresh;
  rec.travel[0] = rec.travel[1] = 0.0;
  rec.due = 0;
  return true;
}

// Advance the distances the contact point travelled on each grain over the step (`Record`: the
// pair's or a wall's, with travel[2], due, forgotten and reset_stored; a wall's travel[1] stays
// 0, the wall being rigid) and, once either passes kDentTravelRadii a_max, mark the contact due
// and forget its dent as soon as that creates no energy (forget_if_safe). Only a contact that
// yielded has a dent; an elastic one has nothing to forget. The envelope set anew (virgin
// loading) puts the dent where the contact is: the caller then zeroes the distances and the due
// flag (envelope_moved). Returns true when the dent was forgotten. Call before the step's law
// update, with commit only.
template <class Record>
inline bool track_place(const geocontact::LawParams &law, const StiffnessConstants &c,
                        const geocontact::Similarity &sim, Record &rec, double rate_i,
                        double rate_j, double dt)
{
  rec.travel[0] += rate_i * dt;
  rec.travel[1] += rate_j * dt;
  if (!rec.due) {
    if (!(rec.law.max_approach > law.yield_approach)) return false;
    const double a_max = sim.scale * c.length_to_run * dent_radius(law, rec.law);
    if (!(a_max > 0.0) || std::max(rec.travel[0], rec.travel[1]) <= kDentTravelRadii * a_max)
      return false;
    rec.due = 1;
  }
  return forget_if_safe(law, c, sim, rec);
}

// The law's envelope was set anew over the step (virgin loading beyond `envelope`, the
// max_approach before it): the dent is where the contact is now, nothing travelled, nothing due.
template <class Record> inline void envelope_moved(Record &rec, double envelope)
{
  if (rec.law.max_approach > envelope) {
    rec.travel[0] = rec.travel[1] = 0.0;
    rec.due = 0;
  }
}

}  // namespace geocontact_forces
}  // namespace LAMMPS_NS

#endif
