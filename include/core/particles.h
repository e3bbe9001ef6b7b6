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

typedef struct sph_particles {
    size_t n;    /* live particles */
    size_t cap;  /* capacity of every array */
    int nlayers; /* thermodynamic layers (stride of `enth`), 1..SPH_MAX_LAYERS */

    /* --- prognostic state --- */
    double *x, *y;   /* position, m */
    double *u, *v;   /* velocity, m/s */
    double *mass;    /* kg */
    double *thick;   /* h_i: thickness of the ice itself, m */
    double *conc;    /* A: concentration 0..1 */
    double *sml;     /* h: smoothing length, m */
    double *snow;    /* snow depth, m */
    double *tsurf;   /* surface temperature, deg C */
    double *enth;    /* layer enthalpy q (J/m^3, negative), nlayers per particle */
    double *s11, *s22, *s12; /* vertically integrated stress, N/m (EVP memory) */
    long *id;        /* stable identity (trajectories, replay) */
    double *sml0;    /* h0: reference smoothing length (seed eq. 10) */
    double *dens0;   /* M0: reference density for the variable smoothing length */
    double *coastc;  /* log M gained by convergence against a coast, not yet released */

    /* --- diagnosed by the step --- */
    double *dens;    /* M = sum_j m_j W_kj: mass per unit area, kg/m^2 */
    double *e11, *e22, *e12; /* strain rates, 1/s */
    double *pres;    /* vertically integrated ice strength P_int, N/m */
    double *ax, *ay; /* internal-stress acceleration, m/s^2 */
    unsigned char *regime; /* SPH_REGIME_* flags */

    /* --- forcing at the particle, filled by the driver before a step --- */
    double *lat;      /* latitude, degrees north (Coriolis per particle) */
    double *ua, *va;  /* 10 m wind, m/s */
    double *uw, *vw;  /* ocean surface current including tide, m/s */
    double *sshx, *sshy; /* sea-surface slope d(xi)/dx, d(xi)/dy, m/m */
    double *tair;     /* 2 m air temperature, deg C */
    double *qair;     /* 2 m specific humidity, kg/kg */
    double *swdn;     /* downwelling shortwave, W/m^2 */
    double *lwdn;     /* downwelling longwave, W/m^2 */
    double *sst;      /* sea surface temperature, deg C */
    double *fw;       /* ocean heat flux into the ice base, W/m^2 */
    double *fsens, *flat; /* prescribed sensible/latent flux into the surface,
                             W/m^2; NaN = compute from bulk formulae */
} sph_particles;

/* Allocates every array for `cap` particles and `nlayers` layers (zeroed,
 * forcing NaN-free defaults: fsens/flat NaN). Returns NULL on failure. */
sph_particles *sph_particles_create(size_t cap, int nlayers);
void sph_particles_free(sph_particles *p); /* NULL does nothing */
/* Removes particle k by moving the last one into its slot (O(1)). */
void sph_particles_remove(sph_particles *p, size_t k);
/* Reorders the live particles: new slot i takes old particle order[i].
 * scratch must hold n doubles (and n * nlayers for the enthalpy). */
void sph_particles_permute(sph_particles *p, const int *order, double *scratch);
/* Copies every array entry of particle src to dst (same or other set). */
void sph_particles_copy_one(sph_particles *dst, size_t d, const sph_particles *src, size_t s);

#endif
