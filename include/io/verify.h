/* Forecast verification against an observed concentration field on the
 * output grid (the engine regrids observations first).
 *
 * Ice-edge scores after Goessling et al. (2016, GRL 43, 1642): with the
 * binary field c = 1 where concentration >= threshold (15 %), else 0,
 *   O    = sum over sea cells of max(c_f - c_o, 0) dA   (overestimate)
 *   U    = sum over sea cells of max(c_o - c_f, 0) dA   (underestimate)
 *   IIEE = O + U,  AEE = |O - U|,  ME = 2 min(O, U)  (so AEE + ME = IIEE)
 * dA is the cell area on the sphere (R = 6371 km). Land cells and cells
 * where either field is NaN are left out. The displacement is IIEE divided
 * by the length of the OBSERVED ice edge (Melsom et al. 2019); both edge
 * lengths are reported. Concentration bias (forecast - observed) and RMSE
 * are means over the same sea cells, as fractions (0..1). Persistence is
 * the forecast's initial field: skill = 1 - IIEE_f / IIEE_persistence
 * (NaN when the persistence IIEE is 0 or no persistence field was given).
 */
#ifndef SPHICE_IO_VERIFY_H
#define SPHICE_IO_VERIFY_H

#include "io/edge.h"
#include "util/err.h"

typedef struct verify_scores {
    double valid_time;        /* seconds since 1970 (set by the caller) */
    double threshold;         /* concentration threshold, fraction */
    double over_km2, under_km2, iiee_km2, aee_km2, me_km2;
    double edge_length_fc_km, edge_length_obs_km;
    double displacement_km;   /* IIEE / observed edge length; NaN if no edge */
    double conc_bias, conc_rmse;
    long ncells;              /* sea cells compared */
    double iiee_persistence_km2, skill_persistence;
} verify_scores;

/* fc, obs, persistence (may be NULL): nlat*nlon concentration fractions;
 * land may be NULL. Fills *s (valid_time left 0). */
int verify_compute(const prod_grid *g, const double *fc, const double *obs,
                   const double *persistence, const unsigned char *land, double threshold,
                   verify_scores *s, sph_error *err);

/* Writes the scores as a JSON object (non-finite numbers as null),
 * atomically. `extra_name`/`extra_value` (may be NULL) adds one string
 * member such as the cycle time. */
int verify_write_json(const char *path, const verify_scores *s, const char *extra_name,
                      const char *extra_value, sph_error *err);

#endif
