/* Harmonic tide grids ("harmonic-1" format, docs/forcing.md): amplitudes and
 * Greenwich phase lags of the constituents on a lon/lat grid. The forcing
 * reader synthesises the elevation and current fields on the grid nodes at
 * the sample time and then interpolates them like any other slice, so
 * missing (land) nodes, SSH gradients and point location are shared code. */
#include "forcing_impl.h"

#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEG (M_PI / 180.0)

static const struct {
    fv_slot w;
    const char *amp, *phase, *target;
    const char *std;
} tide_vars[] = {
    {FV_SSH, "h_amp", "h_phase", "m", "sea_surface_height"},
    {FV_UCUR, "u_amp", "u_phase", "m s-1", "eastward_sea_water_velocity"},
    {FV_VCUR, "v_amp", "v_phase", "m s-1", "northward_sea_water_velocity"},
};

/* Reads a (constituent, y, x) variable into [k][j*nx+i], fill -> NaN, with
 * a linear unit conversion. */
static int read_cube(fsource *s, const char *path, int ncid, int varid, const fvfile *vf,
                     size_t nc, size_t ny, size_t nx, double a, double b, double *out,
                     sph_error *err)
{
    char name[NC_MAX_NAME + 1] = "?";
    nc_inq_varname(ncid, varid, name);
    size_t n = nc * nx * ny;
    double *raw = malloc(n * sizeof *raw);
    if (!raw)
        return forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
    int rc = nc_get_var_double(ncid, varid, raw);
    if (rc != NC_NOERR) {
        free(raw);
        return forcing_fail(err, s, path, SPH_ERR_NETCDF, "cannot read '%s': %s", name,
                            nc_strerror(rc));
    }
    double fill = NC_FILL_FLOAT;
    nc_get_att_double(ncid, varid, "_FillValue", &fill);
    for (size_t k = 0; k < nc; k++)
        for (size_t j = 0; j < ny; j++)
            for (size_t i = 0; i < nx; i++) {
                double x = vf->transpose ? raw[(k * nx + i) * ny + j] : raw[(k * ny + j) * nx + i];
                if (x == fill || isnan(x)) {
                    if (isnan(x) && !isnan(fill)) {
                        free(raw);
                        return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                                            "NaN in '%s' that is not the declared _FillValue",
                                            name);
                    }
                    x = NAN;
                } else {
                    x = a * x + b;
                }
                out[(k * ny + j) * nx + i] = x;
            }
    free(raw);
    return 0;
}

int ftide_open(fsource *s, int ncid, cf_units *units, double t_ref, int nodal, unsigned required,
               sph_error *err)
{
    const char *path = s->paths[0];
    int dim, cvar;
    size_t nc, slen;
    if (nc_inq_dimid(ncid, "constituent", &dim) != NC_NOERR || nc_inq_dimlen(ncid, dim, &nc) ||
        nc_inq_varid(ncid, "constituent", &cvar) != NC_NOERR ||
        nc_inq_dimid(ncid, "name_strlen", &dim) != NC_NOERR || nc_inq_dimlen(ncid, dim, &slen))
        return forcing_fail(err, s, path, SPH_ERR_BAD_DATA,
                            "harmonic tide file lacks the 'constituent' variable or dimensions");
    char *names = calloc(nc * slen + 1, 1);
    int *index = malloc((nc ? nc : 1) * sizeof *index);
    double *cube = NULL, *phase = NULL;
    int rc = 0;
    if (!names || !index) {
        rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
        goto done;
    }
    if (nc_get_var_text(ncid, cvar, names) != NC_NOERR) {
        rc = forcing_fail(err, s, path, SPH_ERR_NETCDF, "cannot read constituent names");
        goto done;
    }
    for (size_t k = 0; k < nc; k++) {
        char nm[16] = "";
        size_t l = slen < sizeof nm - 1 ? slen : sizeof nm - 1;
        memcpy(nm, names + k * slen, l);
        nm[l] = '\0';
        for (size_t c = strlen(nm); c > 0 && (nm[c - 1] == ' '); c--)
            nm[c - 1] = '\0';
        index[k] = tide_constituent_index(nm);
        if (index[k] < 0) {
            rc = forcing_fail(err, s, path, SPH_ERR_BAD_DATA, "unknown tidal constituent '%s'", nm);
            goto done;
        }
    }
    tide_args_init(&s->targs, t_ref, nodal);
    for (size_t q = 0; q < sizeof tide_vars / sizeof tide_vars[0]; q++) {
        int av, pv;
        if (nc_inq_varid(ncid, tide_vars[q].amp, &av) != NC_NOERR ||
            nc_inq_varid(ncid, tide_vars[q].phase, &pv) != NC_NOERR) {
            unsigned fl = tide_vars[q].w == FV_SSH ? FQ_SSH : FQ_CURRENT;
            if (required & fl) {
                rc = forcing_fail(err, s, path, SPH_ERR_MISSING_VAR,
                                  "harmonic tide variables '%s'/'%s' not found",
                                  tide_vars[q].amp, tide_vars[q].phase);
                goto done;
            }
            continue;
        }
        fvar *v = calloc(1, sizeof *v);
        if (!v || !(v->vfiles = calloc(1, sizeof *v->vfiles)) ||
            !(v->harm = calloc(1, sizeof *v->harm))) {
            if (v)
                free(v->vfiles);
            free(v);
            rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
            goto done;
        }
        s->vars[tide_vars[q].w] = v;
        v->src = s;
        v->which = tide_vars[q].w;
        v->nvfiles = 1;
        v->vfiles[0].merge_dim = -1;
        v->slot_k[0] = v->slot_k[1] = (size_t)-1;
        snprintf(v->standard_name, sizeof v->standard_name, "%s", tide_vars[q].std);
        snprintf(v->varname, sizeof v->varname, "%s", tide_vars[q].amp);
        snprintf(v->file0, sizeof v->file0, "%s", path);
        if ((rc = fgrid_read(s, path, ncid, av, &v->vfiles[0], &v->grid, err)))
            goto done;
        if (v->grid->curvilinear && v->which == FV_UCUR)
            v->grid_relative = 0; /* the format stores eastward/northward components */
        char un[64] = "", pun[64] = "degree";
        double a = 1, b = 0, pa = 1, pb = 0;
        if (fnc_text_att(ncid, av, "units", un, sizeof un) != 0 ||
            cf_units_linear(units, un, tide_vars[q].target, &a, &b) != 0) {
            rc = forcing_fail(err, s, path, SPH_ERR_UNITS,
                              "units '%s' of '%s' missing or not convertible to '%s'", un,
                              tide_vars[q].amp, tide_vars[q].target);
            goto done;
        }
        snprintf(v->units, sizeof v->units, "%s", un);
        fnc_text_att(ncid, pv, "units", pun, sizeof pun);
        if (cf_units_linear(units, pun, "degree", &pa, &pb) != 0) {
            rc = forcing_fail(err, s, path, SPH_ERR_UNITS, "units '%s' of '%s' are not an angle",
                              pun, tide_vars[q].phase);
            goto done;
        }
        size_t nx = v->grid->nx, ny = v->grid->ny, nn = nx * ny;
        free(cube);
        free(phase);
        cube = malloc(nc * nn * sizeof *cube);
        phase = malloc(nc * nn * sizeof *phase);
        if (!cube || !phase) {
            rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
            goto done;
        }
        if ((rc = read_cube(s, path, ncid, av, &v->vfiles[0], nc, ny, nx, a, b, cube, err)) ||
            (rc = read_cube(s, path, ncid, pv, &v->vfiles[0], nc, ny, nx, pa, pb, phase, err)))
            goto done;
        size_t nmiss = 0;
        for (size_t k = 0; k < nc; k++) {
            int c = index[k];
            if (v->harm->present[c])
                continue; /* a repeated constituent: the first wins */
            v->harm->present[c] = 1;
            v->harm->c[c] = malloc(nn * sizeof(double));
            v->harm->s[c] = malloc(nn * sizeof(double));
            if (!v->harm->c[c] || !v->harm->s[c]) {
                rc = forcing_fail(err, s, path, SPH_ERR_NOMEM, "out of memory");
                goto done;
            }
            for (size_t p = 0; p < nn; p++) {
                double A = cube[k * nn + p], G = phase[k * nn + p] * DEG;
                if (isnan(A) || isnan(G)) {
                    v->harm->c[c][p] = v->harm->s[c][p] = NAN;
                    nmiss += k == 0;
                } else {
                    v->harm->c[c][p] = A * cos(G);
                    v->harm->s[c][p] = A * sin(G);
                }
            }
        }
        v->fill_fraction = (double)nmiss / (double)nn;
    }
    if (s->vars[FV_UCUR] && !s->vars[FV_VCUR]) {
        rc = forcing_fail(err, s, path, SPH_ERR_MISSING_VAR, "u_amp found but not v_amp");
        goto done;
    }
done:
    free(names);
    free(index);
    free(cube);
    free(phase);
    return rc;
}

void ftide_synth(fvar *v, const tide_args *a, double t, double *out)
{
    size_t nn = v->grid->nx * v->grid->ny;
    for (size_t p = 0; p < nn; p++)
        out[p] = 0.0;
    for (int k = 0; k < TIDE_NCONST; k++) {
        if (!v->harm->present[k])
            continue;
        /* f A cos(phi - G) = f (A cos G cos phi + A sin G sin phi) */
        double phi = tide_phase_rad(a, k, t);
        double fc = a->f[k] * cos(phi), fs = a->f[k] * sin(phi);
        const double *c = v->harm->c[k], *s = v->harm->s[k];
        for (size_t p = 0; p < nn; p++)
            out[p] += fc * c[p] + fs * s[p];
    }
}
