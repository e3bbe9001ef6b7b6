/* The NOAA IMS ASCII file (NSIDC G02156) as the tests write it
 * (tests/test_raster_ims.c, test_raster_ims_cycle.c): 30 lines of header
 * text, then one character per cell, the first row the grid's bottom. */
#ifndef SPHICE_TESTS_IMS_FILE_H
#define SPHICE_TESTS_IMS_FILE_H

#include <stdio.h>
#include <stdlib.h>

#include "raster_provider.h"

static const double IA = 6378137.0, IB = 6356257.0;

typedef struct { int n; double xll, yll, cell; } ims_grid;
static const ims_grid G24 = {1024, -12126597.0, -12126480.0, 23684.977};
static const ims_grid G4 = {6144, -12288000.0, -12288000.0, 4000.0};

static inline double cx(const ims_grid *g, int i) { return g->xll + (i + 0.5) * g->cell; }
static inline double cy(const ims_grid *g, int j) { return g->yll + (j + 0.5) * g->cell; }

/* rows of g's classes cls(x, y, ctx) from the bottom (fewer than g->n: a
 * truncated file) */
static inline void ims_write_ascii(const char *path, const ims_grid *g, int rows,
                                   int (*cls)(double x, double y, const void *ctx), const void *ctx)
{
    FILE *f = fopen(path, "w");
    CHECK(f != NULL, "create %s", path);
    if (!f)
        return;
    /* 30 lines of header text (its wording is not specified further) */
    fprintf(f, "Interactive Multisensor Snow and Ice Mapping System (IMS) Daily Northern "
               "Hemisphere Snow and Ice Analysis\n");
    fprintf(f, "%d x %d polar stereographic grid, true at 60 N, oriented 80 W\n", g->n, g->n);
    fprintf(f, "Values: 0 outside Northern Hemisphere, 1 sea, 2 land, 3 sea ice, 4 snow\n");
    for (int l = 3; l < 30; l++)
        fprintf(f, "header line %d\n", l + 1);
    char *row = malloc((size_t)g->n + 2);
    for (int j = 0; j < rows; j++) { /* from the bottom row up */
        for (int i = 0; i < g->n; i++)
            row[i] = (char)('0' + cls(cx(g, i), cy(g, j), ctx));
        row[g->n] = '\n';
        fwrite(row, 1, (size_t)g->n + 1, f);
    }
    free(row);
    fclose(f);
}

#endif
