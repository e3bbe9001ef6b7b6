/* Particle state in structure-of-arrays form (PHYSICS.md section 1).
 *
 * A particle is a parcel of ice, not a floe. Every array has `cap` entries;
 * the first `n` are live. Positions are metres on the model's projected
 * plane; vectors (velocity, wind, current, slope) are in the plane's x/y
 * components: the driver rotates east/north forcing into x/y.
 *
 * Invariants (checked by sph_particles_validate):
 *   mass > 0, thick > 0, 0 < conc <= 1, sml > 0, all finite.
 *   mass = rho_i * conc * thick * area, with `area` the particle's
 *   footprint; the dynamics never changes mass (exact conservation); only
 *   thermodynamics (growth, melt, new ice) and open boundaries do, and both
 *   are accounted in sph_budget.
 */
#ifndef SPHICE_CORE_PARTICLES_H
#define SPHICE_CORE_PARTICLES_H

#include <stddef.h>

#define SPH_MAX_LAYERS 16

/* Regime flags per particle (`regime` array), chosen by `auto` physics. */
enum {
    SPH_REGIME_FREE_DRIFT = 1u << 0,  /* internal stress negligible */
    SPH_REGIME_RHEOLOGY = 1u << 1,    /* full viscous-plastic stress */
    SPH_REGIME_ZERO_LAYER = 1u << 2,  /* Semtner zero-layer column */
    SPH_REGIME_MULTI_LAYER = 1u << 3, /* Bitz-Lipscomb multi-layer column */
    SPH_REGIME_NEAR_COAST = 1u << 4   /* has mirror (ghost) neighbours */
};

/* Every per-particle array, in one list that the struct's members, their
 * allocation, removal, permutation and copy (particles.c), the restart
 * files (io restart) and (later) MPI packing all iterate:
 *
 *   X(name, C type, count, tag, restart, units, long name)
 *
 * count    ONE entry per particle, or LAYERS (nlayers entries, top first)
 * tag      STATE (prognostic), DIAGNOSTIC (diagnosed by the step), FORCING
 *          (filled by the driver before a step)
 * restart  YES: a variable of the restart file, named `name`, required on
 *          reading; OPT: the same, but a file written before it existed
 *          reads it as zero; NZ: as OPT, written only when not zero on
 *          every particle; NO: not in the restart file (diagnosed fields
 *          that are not are zeroed when reading one, forcing is left alone)
 * units    UDUNITS, as written to files; NULL: none (ids, flags)
 *
 * The order is the restart file's variable order: append new fields at the
 * end. Long names are written as they stand; restart ones never change.
 * Positions and vectors are on the model plane (x/y components). */
#define SPH_PARTICLE_FIELDS(X)                                                                   \
    X(x, double, ONE, STATE, YES, "m", "position on the model plane, x")                         \
    X(y, double, ONE, STATE, YES, "m", "position on the model plane, y")                         \
    X(u, double, ONE, STATE, YES, "m s-1", "velocity, plane x component")                        \
    X(v, double, ONE, STATE, YES, "m s-1", "velocity, plane y component")                        \
    X(mass, double, ONE, STATE, YES, "kg", "particle ice mass")                                  \
    X(thick, double, ONE, STATE, YES, "m", "ice thickness h_i") /* of the ice itself */         \
    X(conc, double, ONE, STATE, YES, "1", "ice concentration")  /* A, 0..1 */                    \
    X(sml, double, ONE, STATE, YES, "m", "smoothing length")    /* h */                          \
    X(sml0, double, ONE, STATE, YES, "m", "reference smoothing length") /* h0, seed eq. 10 */    \
    X(dens, double, ONE, DIAGNOSTIC, YES, "kg m-2", "SPH mass per unit area") /* M = sum m W */ \
    X(dens0, double, ONE, STATE, YES, "kg m-2", "reference mass per unit area") /* M0 */         \
    X(snow, double, ONE, STATE, YES, "m", "snow depth")                                          \
    X(tsurf, double, ONE, STATE, YES, "degC", "surface temperature")                             \
    X(s11, double, ONE, STATE, YES, "N m-1", "vertically integrated stress, xx") /* EVP memory */ \
    X(s22, double, ONE, STATE, YES, "N m-1", "vertically integrated stress, yy")                 \
    X(s12, double, ONE, STATE, YES, "N m-1", "vertically integrated stress, xy")                 \
    X(coastc, double, ONE, STATE, OPT, "1",                                                      \
      "compression against a coast not yet released (log mass per area)")                       \
    X(enth, double, LAYERS, STATE, YES, "J m-3", "layer enthalpy, top layer first") /* < 0 */    \
    X(id, long, ONE, STATE, YES, NULL, "particle id") /* stable: trajectories, replay */         \
    X(regime, unsigned char, ONE, DIAGNOSTIC, YES, NULL,                                         \
      "regime flags (core/particles.h SPH_REGIME_*)")                                            \
    X(e11, double, ONE, DIAGNOSTIC, NO, "s-1", "strain rate, xx")                                \
    X(e22, double, ONE, DIAGNOSTIC, NO, "s-1", "strain rate, yy")                                \
    X(e12, double, ONE, DIAGNOSTIC, NO, "s-1", "strain rate, xy")                                \
    X(pres, double, ONE, DIAGNOSTIC, NO, "N m-1", "vertically integrated ice strength P_int")    \
    X(ax, double, ONE, DIAGNOSTIC, NO, "m s-2", "internal-stress acceleration, plane x")         \
    X(ay, double, ONE, DIAGNOSTIC, NO, "m s-2", "internal-stress acceleration, plane y")         \
    X(lat, double, ONE, FORCING, NO, "degrees_north", "latitude (Coriolis per particle)")        \
    X(ua, double, ONE, FORCING, NO, "m s-1", "10 m wind, plane x")                               \
    X(va, double, ONE, FORCING, NO, "m s-1", "10 m wind, plane y")                               \
    X(uw, double, ONE, FORCING, NO, "m s-1", "ocean surface current including tide, plane x")    \
    X(vw, double, ONE, FORCING, NO, "m s-1", "ocean surface current including tide, plane y")    \
    X(sshx, double, ONE, FORCING, NO, "1", "sea-surface slope d(xi)/dx")                         \
    X(sshy, double, ONE, FORCING, NO, "1", "sea-surface slope d(xi)/dy")                         \
    X(tair, double, ONE, FORCING, NO, "degC", "2 m air temperature")                             \
    X(qair, double, ONE, FORCING, NO, "kg kg-1", "2 m specific humidity")                        \
    X(swdn, double, ONE, FORCING, NO, "W m-2", "downwelling shortwave radiation")                \
    X(lwdn, double, ONE, FORCING, NO, "W m-2", "downwelling longwave radiation")                 \
    X(sst, double, ONE, FORCING, NO, "degC", "sea surface temperature")                          \
    X(fw, double, ONE, FORCING, NO, "W m-2", "ocean heat flux into the ice base")                \
    X(fsens, double, ONE, FORCING, NO, "W m-2",                                                  \
      "prescribed sensible heat flux into the surface (NaN: bulk formula)")                      \
    X(flat, double, ONE, FORCING, NO, "W m-2",                                                   \
      "prescribed latent heat flux into the surface (NaN: bulk formula)")                         \
    X(snowfall, double, ONE, FORCING, NO, "kg m-2 s-1", "snowfall rate, water equivalent")      \
    /* Fluxes into the ocean through the particle's footprint, summed over  \
     * the output interval while thermo.ocean_fluxes is on (core/thermo.h); \
     * extensive (flux x footprint area x time), zeroed by the driver after \
     * each record of the ocean-fluxes file (docs/ocean-coupling.md). */     \
    X(ofx_heat_ice, double, ONE, DIAGNOSTIC, OPT, "J",                                           \
      "heat into the ocean under the ice, summed over the output interval")                     \
    X(ofx_heat_lead, double, ONE, DIAGNOSTIC, OPT, "J",                                          \
      "heat into the ocean through the leads, summed over the output interval")                 \
    X(ofx_water, double, ONE, DIAGNOSTIC, OPT, "kg",                                             \
      "fresh water into the ocean from ice and snow, summed over the output interval")          \
    X(ofx_salt, double, ONE, DIAGNOSTIC, OPT, "kg",                                              \
      "salt into the ocean from the ice, summed over the output interval")                      \
    X(ofx_taux, double, ONE, DIAGNOSTIC, OPT, "N s",                                             \
      "stress of the ice on the ocean x area x time, plane x, summed over the output interval") \
    X(ofx_tauy, double, ONE, DIAGNOSTIC, OPT, "N s",                                             \
      "stress of the ice on the ocean x area x time, plane y, summed over the output interval") \
    X(ofx_swbase, double, ONE, DIAGNOSTIC, OPT, "J",                                             \
      "shortwave reaching the ice base, summed over the output interval")                      \
    X(tsnow, double, ONE, STATE, NZ, "degC",                                                     \
      "snow layer temperature (thermo.snow_heat_capacity)") /* 0 without it */

/* The particle trajectory product's data variables after its coordinates
 * time, lon, lat, in file order (io products_particles.c):
 *   X(field, member, name, standard name or NULL, long name, units)
 * `member` names the array of prod_particles_view and prod_particles
 * (io/products.h) that carries the field: the engine turns the plane's
 * x/y velocity into east/north. */
#define SPH_PARTICLE_PRODUCT_FIELDS(X)                                                           \
    X(u, u_east, "u", "eastward_sea_ice_velocity", "eastward particle velocity", "m s-1")        \
    X(v, v_north, "v", "northward_sea_ice_velocity", "northward particle velocity", "m s-1")     \
    X(thick, thick, "thickness", "sea_ice_thickness", "particle ice thickness h_i", "m")         \
    X(conc, conc, "concentration", "sea_ice_area_fraction", "particle ice concentration", "1")   \
    X(mass, mass, "mass", NULL, "particle ice mass", "kg")                                       \
    X(snow, snow, "sisnthick", "surface_snow_thickness", "particle snow depth h_s", "m")

/* Field numbers: SPH_PF_x, SPH_PF_y ... in list order. */
#define SPH_PF_ENUM_(name, ...) SPH_PF_##name,
enum { SPH_PARTICLE_FIELDS(SPH_PF_ENUM_) SPH_PARTICLE_NFIELDS };
#undef SPH_PF_ENUM_
#define SPH_PF_ONE_(...) +1
enum { SPH_PARTICLE_NPRODUCT_FIELDS = 0 SPH_PARTICLE_PRODUCT_FIELDS(SPH_PF_ONE_) };
#undef SPH_PF_ONE_

enum { SPH_FIELD_STATE, SPH_FIELD_DIAGNOSTIC, SPH_FIELD_FORCING };     /* tag */
/* NZ: optional like OPT, and written only when some particle's value is
 * non-zero (a state that stays zero unless a model option is on). */
enum { SPH_RESTART_NO, SPH_RESTART_YES, SPH_RESTART_OPT, SPH_RESTART_NZ }; /* restart */
enum { SPH_FIELD_DOUBLE, SPH_FIELD_LONG, SPH_FIELD_UCHAR };            /* C type */
/* Entries per particle of a list entry's count, for a particle set p. */
#define SPH_FIELD_COUNT(p, count) (SPH_FIELD_LAYERED_##count ? (size_t)(p)->nlayers : (size_t)1)
#define SPH_FIELD_LAYERED_ONE 0
#define SPH_FIELD_LAYERED_LAYERS 1

/* The list as a table, for code that loops at run time (files, packing). */
typedef struct sph_particle_field {
    const char *name, *units, *long_name;
    int tag;      /* SPH_FIELD_STATE ... */
    int restart;  /* SPH_RESTART_NO ... */
    int type;     /* SPH_FIELD_DOUBLE ... */
    size_t size;  /* bytes per entry */
    int layered;  /* 1: nlayers entries per particle */
} sph_particle_field;
extern const sph_particle_field sph_particle_fields[SPH_PARTICLE_NFIELDS];

typedef struct sph_particles {
    size_t n;    /* live particles */
    size_t cap;  /* capacity of every array */
    int nlayers; /* thermodynamic layers (stride of `enth`), 1..SPH_MAX_LAYERS */
#define SPH_PF_MEMBER_(name, type, ...) type *name;
    SPH_PARTICLE_FIELDS(SPH_PF_MEMBER_)
#undef SPH_PF_MEMBER_
} sph_particles;

/* Allocates every array for `cap` particles and `nlayers` layers (zeroed,
 * forcing NaN-free defaults: fsens/flat NaN). Returns NULL on failure. */
sph_particles *sph_particles_create(size_t cap, int nlayers);
/* The same with the fluxes' "not given" (fsens, flat NaN) written for the
 * first `live` slots only (at most cap): the slots beyond are a model's coast
 * ghosts, whose fluxes nothing reads, and their pages stay untouched. */
sph_particles *sph_particles_create_live(size_t cap, size_t live, int nlayers);
void sph_particles_free(sph_particles *p); /* NULL does nothing */
/* Gives back the memory of the thermal forcing (tair qair swdn lwdn sst fw
 * fsens flat snowfall: 72 bytes per slot, resident once a fill wrote them)
 * for a run that reads it no more (no thermodynamics, mixed layer or new
 * ice; the cold start's profile has read tair): each array is replaced by
 * a fresh zeroed one of the same size, whose pages are not resident until
 * written. Their values are zero from then on. Not inside a step (it
 * allocates). Returns 0, or -1 out of memory (the arrays left as they were). */
int sph_particles_release_thermal_forcing(sph_particles *p);
/* Removes particle k by moving the last one into its slot (O(1)). */
void sph_particles_remove(sph_particles *p, size_t k);
/* Reorders the live particles: new slot i takes old particle order[i].
 * scratch must hold n doubles (layered fields go layer by layer). */
void sph_particles_permute(sph_particles *p, const int *order, double *scratch);
/* Zeroes every array entry of slot k (a new particle starts from there:
 * a field added to the list later is never left with another's value). */
void sph_particles_clear_one(sph_particles *p, size_t k);
/* Copies every array entry of particle src to dst (same or other set). */
void sph_particles_copy_one(sph_particles *dst, size_t d, const sph_particles *src, size_t s);
/* The array of field k (SPH_PF_*): sph_particle_fields[k].size bytes per
 * entry, nlayers entries per particle when .layered. NULL for no field. */
void *sph_particles_field(const sph_particles *p, int k);
/* Entries per particle of field k (1 or nlayers). */
size_t sph_particles_field_count(const sph_particles *p, int k);

#endif
