/* Forcing to particles: the forecast engine's coupling of its forcing
 * sources (io/forcing.h) to the model's particles (core/particles.h).
 *
 * coupling_open opens one forcing object per configured source that has
 * files for the cycle; coupling_fill samples every source at the
 * particles' positions at time t, merges them (currents and sea-surface
 * height summed over sources, every other quantity from the first source
 * that provides it), fills the defaults of quantities no source provides
 * (core/atmos.h, docs/engine.md) and rotates east/north vectors into the
 * model plane's x/y (io/geo.h: geo_grid_angle). */
#ifndef SPHICE_SERVICE_COUPLING_H
#define SPHICE_SERVICE_COUPLING_H

#include <stddef.h>

#include "core/particles.h"
#include "core/thermo.h"
#include "io/forcing.h"
#include "io/geo.h"
#include "service/forecast.h"
#include "util/err.h"

struct sph_config;

#define COUPLING_MAX_SOURCES SPHICE_MAX_SOURCES
enum { CPL_Q_UE, CPL_Q_VN, CPL_Q_TAIR, CPL_Q_QAIR, CPL_Q_SWDN, CPL_Q_LWDN, CPL_Q_UWE, CPL_Q_VWN,
       CPL_Q_SSH, CPL_Q_GXE, CPL_Q_GYN, CPL_Q_SST, CPL_Q_FW, CPL_Q_SNOW, CPL_Q_PRECIP, CPL_Q_MLD,
       CPL_Q_BATHY, CPL_NQ };

typedef struct fc_coupling {
    const char *cname;          /* cycle name, for messages */
    forcing *forc[COUPLING_MAX_SOURCES]; /* one per source: a source that cannot serve a point is known */
    int forc_kind[COUPLING_MAX_SOURCES];
    const char *forc_name[COUPLING_MAX_SOURCES];
    size_t nforc;
    long coast_fallbacks;       /* particle-fills with no ocean/tide data (unresolved coast) */
    unsigned provided;          /* forcing quantities found at the last fill */
    /* per-particle work arrays [cap]: positions (degrees), grid angle,
     * merged east/north forcing. ue vn uwe vwn gxe gyn are not the coupling's own:
     * each fill points them at its particles' ua va uw vw sshx sshy, where
     * the sources are summed and then turned to plane x/y; ssh is NULL (the
     * merged sea-surface height is read by nothing) */
    double *lon, *lat, *angle, *ue, *vn, *uwe, *vwn, *gxe, *gyn, *ssh;
    double *tair, *qair, *swdn, *lwdn, *sst, *fw;
    double *snowfall, *precip;  /* kg m-2 s-1 */
    double *mld, *bathy;        /* mixed-layer depth, sea-floor depth (NaN: none), m */
    /* one source's sample of one chunk of particles: [wcap], the particles
     * k0 .. k0 + wcap - 1 of a fill's chunk k0 (the forcing's per-point work
     * arrays hold one chunk too: forcing_set_point_base) */
    double *q[CPL_NQ];
    unsigned char *bad;         /* the source could not serve this particle */
    size_t chunk;               /* particles per chunk (0 at coupling_alloc: 65536) */
    size_t wcap;                /* min(cap, chunk) */
    long *ids_before;           /* ids at the last fill, positions lon, lat (error messages) */
    size_t n_before;
    geo_plane_table *plane;     /* domain.plane_tables (NULL: PROJ per particle); owned */
    double *cs, *sn;            /* [cap] cos and sin of the grid angle from plane */
    /* 1: a fill samples only what the dynamics reads (wind, current, sea-surface
     * height and slope) and leaves the thermal forcing of P (tair qair swdn lwdn
     * sst fw snowfall) as the last full fill set it. The engine sets it after
     * the first fill of a run without thermodynamics and mixed layer (the first
     * fill gives the initial temperature profile): coupling_set_dynamics_only. */
    int dynamics_only;
} fc_coupling;

/* Opens the forcing of the cycle [t0, t_end] over the configured domain
 * box: one forcing object per source of cfg with files in req (an
 * optional source without files is left out with a warning). cname names
 * the cycle in messages and must outlive c. */
int coupling_open(fc_coupling *c, const struct sph_config *cfg, const forecast_request *req, double t0,
                  double t_end, const char *cname, sph_error *err);

/* The work arrays for up to cap particles. */
int coupling_alloc(fc_coupling *c, size_t cap, sph_error *err);

/* Fills every live particle's forcing in P (ua va uw vw sshx sshy lat tair
 * qair swdn lwdn sst fw snowfall; fsens and flat NaN) at time t. Snowfall:
 * a source's snowfall, else its precipitation times sph_snow_fraction of
 * the air temperature, else 0. Particles at
 * plane x/y of projection proj; th gives the freezing point (the air
 * temperature where none is given) and the air pressure (humidity
 * default). thermo_on: a missing air temperature is an error. */
int coupling_fill(fc_coupling *c, const geo_proj *proj, const sph_thermo_params *th, int thermo_on,
                  sph_particles *P, double t, sph_error *err);

/* From now on a fill samples only the dynamics' forcing (dynamics_only)
 * and the thermal work arrays are freed. */
void coupling_set_dynamics_only(fc_coupling *c);

/* "121.80E 40.61N" (or "an unknown position"), for messages. */
void coupling_format_lonlat(double lon, double lat, char *buf, size_t len);

/* Closes the sources and frees the arrays; c may be all zeros. */
void coupling_free(fc_coupling *c);

#endif
