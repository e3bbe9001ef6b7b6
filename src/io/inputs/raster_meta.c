/* Metadata conventions shared by the initial raster's drivers
 * (raster_impl.h): the usual variable (band) names, flag meanings and the
 * thickness kind, decided from text the driver read (a NetCDF attribute,
 * a GDAL band's metadata item) so that every format decides alike. */
#include "raster_impl.h"

#include <ctype.h>
#include <stdio.h>
#include <string.h>

const char *const raster_conc_names[] = {"siconc", "ice_conc", "sic", "aice", "SIC", "conc",
                                         "cdr_seaice_conc", "fice", NULL};
const char *const raster_thick_names[] = {"sithick", "hi", "sit", "ice_thickness", "thick", "hice",
                                          NULL};

int raster_flag_meanings(const char *path, const char *label, const char *att, size_t n,
                         char *meanings, int *kind, sph_error *err)
{
    size_t k = 0;
    char *save = NULL;
    for (char *tok = strtok_r(meanings, " \t", &save); tok; tok = strtok_r(NULL, " \t", &save), k++) {
        for (char *c = tok; *c; c++)
            *c = (char)tolower((unsigned char)*c);
        if (k < n)
            kind[k] = strstr(tok, "land") || strstr(tok, "coast") || strstr(tok, "lake") ? 1 : 2;
    }
    if (k != n)
        return sph_err_set(err, SPH_ERR_BAD_DATA,
                           "ice raster %s: %s has %zu %s but %zu flag_meanings", path, label, n,
                           att, k), -1;
    return (int)n;
}

int raster_thickness_kind(const char *path, const char *label, const char *name,
                          const char *cell_methods, const char *long_name,
                          const char *standard_name, int want, int *kind, char *why, size_t wlen,
                          sph_error *err)
{
    if (want != ICE_THICK_AUTO) {
        *kind = want;
        snprintf(why, wlen, "initial.thickness_kind");
        return SPH_OK;
    }
    if (cell_methods) {
        const char *a = strstr(cell_methods, "area:");
        if (a) {
            a += 5;
            a += strspn(a, " ");
            if (strncmp(a, "mean where sea_ice", 18) == 0) {
                *kind = ICE_THICK_ICE;
                snprintf(why, wlen, "%.64s cell_methods \"area: mean where sea_ice\"", name);
                return SPH_OK;
            }
            /* "area: mean" over the cell, or over its sea part */
            int plain = strncmp(a, "mean", 4) == 0 && strncmp(a + 4, " where", 6) != 0;
            int sea = strncmp(a, "mean where sea", 14) == 0 && a[14] != '_';
            if (plain || sea) {
                *kind = ICE_THICK_CELL_MEAN;
                snprintf(why, wlen, "%.64s cell_methods \"area: mean\" (over the cell)", name);
                return SPH_OK;
            }
        }
    }
    if (long_name) {
        char buf[512];
        snprintf(buf, sizeof buf, "%s", long_name);
        for (char *c = buf; *c; c++)
            *c = (char)tolower((unsigned char)*c);
        static const char *const mean_words[] = {"in cell", "cell mean", "grid cell mean",
                                                 "grid-cell mean", "per unit area", "volume per",
                                                 "per grid cell area", NULL};
        static const char *const ice_words[] = {"ice-covered", "ice covered", "floe", "actual",
                                                "over the ice", NULL};
        for (const char *const *w = mean_words; *w; w++)
            if (strstr(buf, *w)) {
                *kind = ICE_THICK_CELL_MEAN;
                snprintf(why, wlen, "%.64s long_name (\"%.32s\")", name, *w);
                return SPH_OK;
            }
        for (const char *const *w = ice_words; *w; w++)
            if (strstr(buf, *w)) {
                *kind = ICE_THICK_ICE;
                snprintf(why, wlen, "%.64s long_name (\"%.32s\")", name, *w);
                return SPH_OK;
            }
    }
    if (strcmp(name, "sivol") == 0 || strcmp(name, "vice") == 0) {
        *kind = ICE_THICK_CELL_MEAN;
        snprintf(why, wlen, "variable name %.64s (volume per cell area)", name);
        return SPH_OK;
    }
    if (strcmp(name, "sithick") == 0) {
        *kind = ICE_THICK_ICE;
        snprintf(why, wlen, "variable name sithick (per ice area)");
        return SPH_OK;
    }
    if (standard_name && strcmp(standard_name, "sea_ice_thickness") == 0) {
        *kind = ICE_THICK_ICE;
        snprintf(why, wlen, "%.64s standard_name sea_ice_thickness", name);
        return SPH_OK;
    }
    return sph_err_set(err, SPH_ERR_CONFIG,
                       "ice raster %s: %s: no cell_methods, long_name or "
                       "standard_name says whether it is per ice area or a cell mean: set "
                       "initial.thickness_kind to \"ice\" or \"cell_mean\"", path, label);
}
