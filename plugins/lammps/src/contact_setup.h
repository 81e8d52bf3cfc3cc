// What a pair_coeff or wall fix of the plugin reads from the LAMMPS run before any contact: the
// law file (read on rank 0, parsed on every rank with the Python reader's rules and messages),
// the run's unit style, and the keywords shared by the pair and the walls (rolling, twisting,
// damping or restitution). Errors are one line, collective, opened by `who`.
#ifndef LMP_GEOCONTACT_CONTACT_SETUP_H
#define LMP_GEOCONTACT_CONTACT_SETUP_H

#include "contact_forces.h"
#include "restitution.h"

#include "geocontact/params.hpp"

#include "comm.h"
#include "error.h"
#include "force.h"
#include "lammps.h"
#include "update.h"
#include "utils.h"

#include <cstring>
#include <mpi.h>
#include <string>

namespace LAMMPS_NS {
namespace geocontact_forces {

// --- the run's units -------------------------------------------------------------------------

// The run's units, or a one-line error naming the unit style (who opens it).
inline RunUnits run_units(LAMMPS *lmp, const std::string &who)
{
  RunUnits u{};
  const std::string style = lmp->update->unit_style ? lmp->update->unit_style : "";
  if (!physical_units(style, u))
    lmp->error->all(FLERR, "{}: units {} have no physical size, and the law file is SI; use "
                           "units si, cgs, micro, nano, metal, real or electron", who, style);
  u.ftm2v = lmp->force->ftm2v;
  return u;
}

// --- keywords ---------------------------------------------------------------------------------

// The keywords `rolling sds k_roll gamma_roll mu_roll` and `twisting marshall` at arg[iarg]
// (the pair_coeff and fix wall/geocontact syntax of LAMMPS's granular models): false if
// arg[iarg] is neither, else the coefficients set and iarg moved past them. Bad values stop
// with a one-line error naming the argument; `who` opens it.
inline bool parse_resistance(LAMMPS *lmp, int &iarg, int narg, char **arg, RollingCoeffs &c,
                             const std::string &who)
{
  const std::string key = arg[iarg];
  if (key == "rolling") {
    if (iarg + 1 >= narg || strcmp(arg[iarg + 1], "sds") != 0)
      lmp->error->all(FLERR, "{}: rolling takes the model sds (rolling sds k_roll gamma_roll "
                             "mu_roll), got '{}'", who, iarg + 1 < narg ? arg[iarg + 1] : "");
    const char *names[3] = {"k_roll", "gamma_roll", "mu_roll"};
    double values[3];
    for (int k = 0; k < 3; ++k) {
      if (iarg + 2 + k >= narg)
        lmp->error->all(FLERR, "{}: rolling sds needs k_roll gamma_roll mu_roll; {} is missing",
                        who, names[k]);
      const char *text = arg[iarg + 2 + k];
      if (!utils::is_double(text))
        lmp->error->all(FLERR, "{}: rolling sds {} must be a number, got '{}'", who, names[k],
                        text);
      values[k] = utils::numeric(FLERR, text, false, lmp);
    }
    if (!(values[0] > 0.0))
      lmp->error->all(FLERR, "{}: rolling sds k_roll must be > 0, got {}", who, values[0]);
    for (int k = 1; k < 3; ++k)
      if (!(values[k] >= 0.0))
        lmp->error->all(FLERR, "{}: rolling sds {} must be >= 0, got {}", who, names[k],
                        values[k]);
    c.stiffness = values[0];
    c.damping = values[1];
    c.friction = values[2];
    c.rolling = true;
    iarg += 5;
    return true;
  }
  if (key == "twisting") {
    if (iarg + 1 >= narg || strcmp(arg[iarg + 1], "marshall") != 0)
      lmp->error->all(FLERR, "{}: twisting takes the model marshall (twisting marshall), got "
                             "'{}'", who, iarg + 1 < narg ? arg[iarg + 1] : "");
    c.twisting = true;
    iarg += 2;
    return true;
  }
  return false;
}

// --- parameter files --------------------------------------------------------------------------

// Rank 0 reads the file and sends its text to every rank, so errors are collective. `who`
// opens the error messages ("pair_coeff geocontact", "Fix wall/geocontact").
inline std::string read_text_collective(LAMMPS *lmp, const std::string &path,
                                        const std::string &who)
{
  std::string text;
  int status = 0;
  if (lmp->comm->me == 0) {
    try {
      text = geocontact::read_text_file(path);
    } catch (const geocontact::InputError &) {
      status = 1;
    }
  }
  MPI_Bcast(&status, 1, MPI_INT, 0, lmp->world);
  if (status)
    lmp->error->all(FLERR, "{}: parameter file not found or unreadable: {}", who, path);
  int length = static_cast<int>(text.size());
  MPI_Bcast(&length, 1, MPI_INT, 0, lmp->world);
  text.resize(length);
  MPI_Bcast(&text[0], length, MPI_CHAR, 0, lmp->world);
  return text;
}

// Every rank parses the same text with the Python load_params rules and messages.
inline geocontact::LawParams parse_law(LAMMPS *lmp, const std::string &text,
                                       const std::string &source, const std::string &who)
{
  geocontact::LawParams params;
  try {
    params = geocontact::parse_params(text, source);
  } catch (const geocontact::InputError &e) {
    lmp->error->all(FLERR, "{}: {}", who, e.what());
  }
  return params;
}

// The normal damping of a pair_coeff or wall fix: `damping beta` (fraction of critical) or
// `restitution e` (its beta), not both. Returns false when arg[iarg] is neither; else reads the
// value into beta and moves iarg past it. `given` records which was met first ('d' or 'r').
inline bool parse_damping(LAMMPS *lmp, int &iarg, int narg, char **arg, double &beta,
                          char &given, const char *who)
{
  const bool damping = std::strcmp(arg[iarg], "damping") == 0;
  if (!damping && std::strcmp(arg[iarg], "restitution") != 0) return false;
  if (iarg + 1 >= narg) lmp->error->all(FLERR, "{}: keyword '{}' needs a value", who, arg[iarg]);
  if (given && given != (damping ? 'd' : 'r'))
    lmp->error->all(FLERR, "{}: give damping or restitution, not both", who);
  given = damping ? 'd' : 'r';
  const double value = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
  if (damping) {
    if (!(value >= 0.0)) lmp->error->all(FLERR, "{}: damping must be >= 0, got {}", who, value);
    beta = value;
  } else {
    if (!(value >= kMinRestitution && value <= 1.0))
      lmp->error->all(FLERR, "{}: restitution must be in [{}, 1], got {}", who, kMinRestitution,
                      value);
    beta = damping_of_restitution(value);
  }
  iarg += 2;
  return true;
}

// A keyword that takes one of two words, `keyword first|second`: -1 when arg[iarg] is another
// keyword; else the index (0 or 1) of the word given, with iarg moved past both. A missing or
// other word is a one-line error naming the keyword and the two words.
inline int parse_either(LAMMPS *lmp, int &iarg, int narg, char **arg, const char *keyword,
                        const char *first, const char *second, const char *who)
{
  if (std::strcmp(arg[iarg], keyword) != 0) return -1;
  if (iarg + 1 >= narg)
    lmp->error->all(FLERR, "{}: keyword '{}' needs a value ({} or {})", who, keyword, first,
                    second);
  const char *word = arg[iarg + 1];
  const int which = std::strcmp(word, first) == 0 ? 0 : std::strcmp(word, second) == 0 ? 1 : -1;
  if (which < 0)
    lmp->error->all(FLERR, "{}: {} must be {} or {}, got '{}'", who, keyword, first, second,
                    word);
  iarg += 2;
  return which;
}

// `range warn|error` (issue 37): what a contact loaded beyond the law file's calibrated range
// (delta_max / delta_y > calibrated_range.max_depth, where the law extrapolates) does: `warn`
// (the default) counts it and says so once; `error` stops the run there (range_error below).
// Returns true (and moves iarg past it) when arg[iarg] is the keyword.
inline bool parse_range(LAMMPS *lmp, int &iarg, int narg, char **arg, bool &stop,
                        const char *who)
{
  const int word = parse_either(lmp, iarg, narg, arg, "range", "warn", "error", who);
  if (word >= 0) stop = word == 1;
  return word >= 0;
}

// `memory place|pair` (pair_style geocontact and the wall fixes; docs/dem.md "Memory with a
// place"): place forgets a contact's dent once its point has travelled past it (energy-safe,
// contact_forces.h track_place), pair keeps it while the contact record lives. Returns false
// when arg[iarg] is another keyword; else sets `place` and moves iarg past the keyword.
inline bool parse_memory(LAMMPS *lmp, int &iarg, int narg, char **arg, bool &place,
                         const char *who)
{
  const int word = parse_either(lmp, iarg, narg, arg, "memory", "place", "pair", who);
  if (word >= 0) place = word == 0;
  return word >= 0;
}

// The depth delta_max / delta_y of a contact state when it is beyond the law file's calibrated
// range, else 0 (the same test as the count of compute pair geocontact [16] and the walls' [19]).
inline double depth_beyond_range(const geocontact::LawParams &law,
                                 const geocontact::ContactState &state)
{
  const double depth = state.max_approach / law.yield_approach;
  return depth > law.calibrated_depth ? depth : 0.0;
}

}  // namespace geocontact_forces
}  // namespace LAMMPS_NS

#endif
