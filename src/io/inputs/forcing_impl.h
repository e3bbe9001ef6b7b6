/* Private structures of the forcing reader (io/forcing.h), shared by
 * forcing.c (sources, variables, time axes, slice cache, sampling),
 * forcing_grid.c (grids, point location, interpolation, gradients) and
 * forcing_tide.c (harmonic tide grids). */
#ifndef SPHICE_IO_FORCING_IMPL_H
#define SPHICE_IO_FORCING_IMPL_H

#include <stddef.h>
#include "io/cf.h"
#include "io/forcing.h"
#include "io/tide.h"
#include "util/err.h"

#define FORCING_EARTH_RADIUS 6371000.0 /* m, spherical earth */
#define FORCING_MAX_DIMS 8

/* One physical field a source can supply. */
typedef enum {
    FV_UWIND = 0, FV_VWIND, FV_TAIR, FV_DEW, FV_QAIR, FV_PSURF, FV_SW, FV_LW,
    FV_UCUR, FV_VCUR, FV_SSH, FV_SST, FV_FW, FV_RH, FV_COUNT
} fv_slot;

/* A grid in canonical layout: node (i, j) is element j * nx + i, i along
 * the x (longitude-like) dimension, j along y. */
typedef struct fgrid {
    int curvilinear;
    size_t nx, ny;
    double *lon1, *lat1;   /* regular: lon1[nx] increasing (unwrapped), lat1[ny] monotonic */
    int lon_wrap;          /* regular and global: a cell joins column nx-1 to column 0 */
    double *lon2, *lat2;   /* node coordinates [ny*nx] for both kinds (lon in [-180,180)) */
    double *cosang, *sinang; /* curvilinear: angle from east to the x axis, per node */
    char key[600];         /* coordinate variable names + sizes: grids with equal keys are shared */
    char desc[96];
    /* Per-call point stencils (filled once per forcing_sample_at call). */
    size_t *idx;           /* 4 per point */
    double *w;             /* 4 per point */
    int *ok;               /* 1 if the point lies in the grid */
    size_t *hint;          /* curvilinear: last cell per point (j*nx+i), or (size_t)-1 */
    size_t npoints;
    unsigned long stamp;   /* call number the stencils belong to */
    struct fgrid *next;
} fgrid;

/* Per-file description of a variable (packing can differ per file). */
typedef struct fvfile {
    int file;              /* index into source paths */
    int varid;
    int ndims;
    int tdim, ydim, xdim;  /* positions in the variable's dimensions; tdim -1 if none */
    int transpose;         /* x dimension comes before y in the file */
    size_t level[FORCING_MAX_DIMS]; /* start index along the other dimensions: the
                                       level nearest the surface (fgrid_level) */
    int merge_dim;         /* ERA5's expver: the first valid value along it; -1 none */
    size_t merge_n;
    double scale, offset;  /* unpacking */
    int has_fill;
    double fill;
    int nmiss;
    double miss[4];
    int valid_raw;         /* valid range compared to packed values */
    double vmin, vmax;
    double a, b;           /* unit conversion after unpacking */
    char units[64];
} fvfile;

typedef struct ftime {
    double t;              /* model time */
    int vf;                /* index into the variable's fvfile list */
    size_t k;              /* index along the file's time dimension */
    double period;         /* accumulation period (s) for accumulated fields */
} ftime;

struct fsource;

typedef struct fharm {
    /* Harmonic constants at the nodes: value(t) = sum_k f_k (c_k cos(phi_k) + s_k sin(phi_k))
     * where c = A cos G, s = A sin G; NaN over land. */
    int present[TIDE_NCONST];
    double *c[TIDE_NCONST], *s[TIDE_NCONST];
} fharm;

typedef struct fvar {
    struct fsource *src;
    fv_slot which;
    char standard_name[96];  /* the one found (or the canonical one for mapped names) */
    char varname[64];
    char units[64];
    char file0[512];         /* file of the first time */
    int accumulated;         /* J m-2: divided by the accumulation period */
    int grid_relative;       /* vector component along the grid axes */
    fgrid *grid;
    fvfile *vfiles;
    size_t nvfiles;
    ftime *times;
    size_t ntimes;           /* 0: static field (no time dimension) */
    /* Two-slot slice cache. slot_k == (size_t)-1 when empty. */
    size_t slot_k[2];
    double *slot[2];
    double *slot_gx[2], *slot_gy[2]; /* SSH gradient per slice */
    double fill_fraction;
    fharm *harm;             /* harmonic tide: slices are synthesised at the sample time */
    double harm_t;           /* time of the synthesised slot 0 */
} fvar;

typedef struct fsource {
    char name[64];
    forcing_kind kind;
    char **paths;
    size_t npaths;
    fvar *vars[FV_COUNT];
    fgrid *grids;
    int harmonic;
    tide_args targs;
    int open_file;           /* cached open file: index into paths, -1 none */
    int open_ncid;
} fsource;

struct forcing {
    fsource *src;
    size_t nsrc;
    size_t reads;            /* slices read from disk (debug counter) */
    unsigned long stamp;
    double *tmp[6];          /* per-call work arrays of npoints */
    size_t tmp_n;
};

/* forcing_grid.c */
int fgrid_read(fsource *s, const char *path, int ncid, int varid, fvfile *vf, fgrid **out,
               sph_error *err);
void fgrid_free(fgrid *g);
/* For every dimension of the variable other than time, latitude and
 * longitude: the index to read. Length 1: 0. Longer: the dimension must
 * have a vertical coordinate variable (axis "Z", a "positive" attribute, a
 * length or pressure unit, or a vertical standard_name), and the level
 * nearest the surface is taken: the largest air pressure, otherwise the
 * value nearest 0 (depth positive down, height, ROMS s_rho, FVCOM
 * siglay). A dimension named expver (ERA5 mixed with ERA5T) is merged:
 * the first valid value along it. Sets vf->level and vf->merge_dim; *what
 * describes the choice ("" if none). */
int fgrid_level(fsource *s, const char *path, int ncid, int varid, fvfile *vf, char *what,
                size_t len, sph_error *err);
/* Locates n points; sets g->ok[p]. Returns the number of points outside. */
size_t fgrid_stencils(fgrid *g, unsigned long stamp, size_t n, const double *lon,
                      const double *lat);
/* Interpolates one slice (NaN = missing) at point p using its stencil; falls
 * back to the nearest valid node within one cell. Returns 0, or -1 when no
 * valid value is near. */
int fgrid_interp(const fgrid *g, const double *slice, size_t p, double lon, double lat,
                 double *value);
/* Centred-difference gradient (d/d east, d/d north in units per metre). */
void fgrid_gradient(const fgrid *g, const double *h, double *gx, double *gy);
/* 1 when the point lies in the grid. */
int fgrid_covers(fgrid *g, double lon, double lat);

/* forcing_tide.c */
int ftide_open(fsource *s, int ncid, cf_units *units, double t_ref, int nodal, unsigned want,
               sph_error *err);
void ftide_synth(fvar *v, const tide_args *a, double t, double *out);

/* forcing.c helpers shared with the others */
/* Sets "forcing '<source>': <path>: <message>" in err; returns code. */
int forcing_fail(sph_error *err, const fsource *s, const char *path, int code, const char *fmt,
                 ...) __attribute__((format(printf, 5, 6)));
int fnc_text_att(int ncid, int varid, const char *name, char *buf, size_t len);
int fnc_is_lat(int ncid, int varid);
int fnc_is_lon(int ncid, int varid);

#endif
