/* Ensemble products (issue 24): the members' gridded fields -> mean,
 * spread, probability of ice, probability contours and the ensemble's
 * scores against an observation.
 *
 * Every member writes its own fields file (io/products.h) on the same
 * output grid and times; ens_products_write reads them back in member
 * order (member 0, the unperturbed control, first) and writes
 *   PREFIX_ensemble.nc        siconc_mean, siconc_spread, sivol_mean,
 *                             sivol_spread, siconc_prob (time, lat, lon)
 *   PREFIX_ensemble_edge.geojson  the contours of siconc_prob at the
 *                             probability levels, per output time
 * atomically into the stage directory.
 *
 * Definitions (docs/ensemble.md): over the N members, mean = sum / N in
 * member order; spread = the population standard deviation (divisor N),
 * by Welford's recurrence, so identical members give exactly 0; the
 * probability is the fraction of members whose concentration is at least
 * the edge threshold (count / N). Land cells are _FillValue.
 *
 * Scores (when an observation is given, at the output time nearest to it):
 * the spatial probability score of Goessling & Jung (2018, QJRMS 144, 735)
 *   SPS = sum over sea cells of (P_f - O)^2 dA,   O = 1 where obs >= threshold
 * (km^2; for one member it is the IIEE), and the IIEE of the ensemble
 * median's concentration (io/verify.h). */
#ifndef SPHICE_IO_ENSEMBLE_H
#define SPHICE_IO_ENSEMBLE_H

#include "util/err.h"

#define ENS_MAX_LEVELS 9

typedef struct ens_options {
    const char *stage;                /* directory the products go to */
    const char *prefix;               /* file prefix, e.g. "sphice" */
    const char *const *member_fields; /* each member's fields file, member 0 first */
    int nmembers;
    double threshold;                 /* edge threshold (fraction) */
    const double *levels;             /* probability levels of the contours, 0 < p <= 1 */
    int nlevels;
    const double *obs;                /* observed concentration on the grid (nlat*nlon), or NULL */
    double t_obs;                     /* its valid time, s since 1970 */
    unsigned long long seed;          /* recorded in the file */
    double cycle_time;                /* s since 1970 */
} ens_options;

typedef struct ens_summary {
    int ntimes, nlat, nlon;
    int has_scores;
    double score_time;                /* output time the scores are for */
    double sps_km2, iiee_median_km2;
    double mean_spread_conc;          /* mean over sea cells and times of siconc_spread */
    int nproducts;
    char products[2][128];            /* file names relative to the stage */
} ens_summary;

/* Reads the members' fields files, writes the ensemble products. The
 * members must share grid and times exactly; a file that differs is
 * refused naming it. */
int ens_products_write(const ens_options *o, ens_summary *s, sph_error *err);

/* The output grid of a fields file (its lat/lon coordinates). */
struct prod_grid;
int ens_fields_grid(const char *path, struct prod_grid *g, sph_error *err);

/* The spatial probability score of prob against the binary obs >= thr,
 * km^2 (sea cells: land == 0 and obs finite; land may be NULL). Rows are
 * lat0 + j dlat, cells of dlon x dlat degrees. */
double ens_sps_km2(int nlon, int nlat, double lat0, double dlon, double dlat, const double *prob,
                   const double *obs, const unsigned char *land, double thr);

#endif
