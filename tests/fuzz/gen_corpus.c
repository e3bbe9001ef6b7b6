/* Writes the binary seed inputs of the fuzz harnesses into DIR/NAME/
 * (the text seeds are committed in tests/fuzz/corpus/NAME/):
 *   raster   small ice rasters as NetCDF classic and netCDF-4 (CF names)
 *   forcing  the engine case's atmosphere and ocean (tests/engine_case.h),
 *            NetCDF classic and netCDF-4
 *   restart  a restart file written by restart_write
 * The first byte of a raster or forcing seed is the harness's selector
 * (see fuzz_raster.c, fuzz_forcing.c). Usage: gen_corpus DIR */
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "io/restart.h"

#include "../engine_case.h"

static void prefix(const char *src, const char *dst, unsigned char first)
{
    FILE *in = fopen(src, "rb"), *out = fopen(dst, "wb");
    if (!in || !out) {
        fprintf(stderr, "gen_corpus: %s or %s\n", src, dst);
        exit(1);
    }
    fputc(first, out);
    int c;
    while ((c = fgetc(in)) != EOF)
        fputc(c, out);
    fclose(in);
    fclose(out);
    remove(src);
}

static void raster_nc(const char *path, int fmt)
{
    enum { NX = 6, NY = 5 };
    int nc, d[3], vt, vx, vy, vc, vh;
    NCW(nc_create(path, NC_CLOBBER | fmt, &nc));
    NCW(nc_def_dim(nc, "time", 1, &d[0]));
    NCW(nc_def_dim(nc, "lat", NY, &d[1]));
    NCW(nc_def_dim(nc, "lon", NX, &d[2]));
    NCW(nc_def_var(nc, "time", NC_DOUBLE, 1, &d[0], &vt));
    NCW(nc_put_att_text(nc, vt, "units", 31, "hours since 1999-02-08 00:00:00"));
    NCW(nc_def_var(nc, "lat", NC_DOUBLE, 1, &d[1], &vy));
    NCW(nc_put_att_text(nc, vy, "units", 13, "degrees_north"));
    NCW(nc_def_var(nc, "lon", NC_DOUBLE, 1, &d[2], &vx));
    NCW(nc_put_att_text(nc, vx, "units", 12, "degrees_east"));
    NCW(nc_def_var(nc, "siconc", NC_FLOAT, 3, d, &vc));
    NCW(nc_put_att_text(nc, vc, "standard_name", 21, "sea_ice_area_fraction"));
    NCW(nc_put_att_text(nc, vc, "units", 1, "1"));
    float fill = -999.f;
    NCW(nc_put_att_float(nc, vc, "_FillValue", NC_FLOAT, 1, &fill));
    NCW(nc_def_var(nc, "sithick", NC_FLOAT, 3, d, &vh));
    NCW(nc_put_att_text(nc, vh, "standard_name", 17, "sea_ice_thickness"));
    NCW(nc_put_att_text(nc, vh, "units", 2, "cm"));
    NCW(nc_enddef(nc));
    double t = 6, lat[NY], lon[NX];
    float c[NY * NX], h[NY * NX];
    for (int j = 0; j < NY; j++)
        lat[j] = 40.0 + 0.1 * j;
    for (int i = 0; i < NX; i++)
        lon[i] = 121.0 + 0.1 * i;
    for (int k = 0; k < NX * NY; k++) {
        c[k] = k == 7 ? fill : (float)(k % 10) / 10.f;
        h[k] = (float)(10 + k);
    }
    NCW(nc_put_var_double(nc, vt, &t));
    NCW(nc_put_var_double(nc, vy, lat));
    NCW(nc_put_var_double(nc, vx, lon));
    NCW(nc_put_var_float(nc, vc, c));
    NCW(nc_put_var_float(nc, vh, h));
    NCW(nc_close(nc));
}

static void restart_file(const char *path)
{
    enum { N = 5, NL = 2 };
    sph_particles *P = sph_particles_create(N, NL);
    if (!P)
        exit(1);
    P->n = N;
    for (size_t k = 0; k < N; k++) {
        P->x[k] = 1000.0 * (double)k;
        P->y[k] = -500.0 * (double)k;
        P->u[k] = 0.1;
        P->mass[k] = 1e6;
        P->thick[k] = 0.3;
        P->conc[k] = 0.8;
        P->sml[k] = P->sml0[k] = 2000;
        P->dens[k] = P->dens0[k] = 270;
        P->id[k] = (long)k + 1;
        for (int l = 0; l < NL; l++)
            P->enth[k * NL + (size_t)l] = -3e8;
    }
    restart_header h = {.time = EC_CYCLE, .cycle_time = EC_CYCLE - 21600.0, .projection = "+proj=test"};
    sph_error err = {0};
    if (restart_write(path, P, &h, &err) != SPH_OK) {
        fprintf(stderr, "gen_corpus: %s\n", err.msg);
        exit(1);
    }
    sph_particles_free(P);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: gen_corpus DIR\n");
        return 2;
    }
    char p[4096], q[4096];
    const char *sub[] = {"raster", "forcing", "restart"};
    mkdir(argv[1], 0755);
    for (int i = 0; i < 3; i++) {
        snprintf(p, sizeof p, "%s/%s", argv[1], sub[i]);
        mkdir(p, 0755);
    }
    snprintf(p, sizeof p, "%s/tmp.nc", argv[1]);
    raster_nc(p, 0);
    snprintf(q, sizeof q, "%s/raster/nc-classic", argv[1]);
    prefix(p, q, 0);
    raster_nc(p, NC_NETCDF4);
    snprintf(q, sizeof q, "%s/raster/nc4", argv[1]);
    prefix(p, q, 0);
    /* hourly from cycle - 3 h: covers the harness's cycle .. cycle + 1 h */
    ec_write_atm_axis(p, "hours since 1999-02-08 00:00:00", 3.0, 8, 0);
    snprintf(q, sizeof q, "%s/forcing/atmosphere-classic", argv[1]);
    prefix(p, q, 0);
    ec_write_atm(p, 2.0);
    snprintf(q, sizeof q, "%s/forcing/atmosphere-nc4", argv[1]);
    prefix(p, q, 0);
    ec_ocean_format = 0;
    ec_write_ocean(p);
    snprintf(q, sizeof q, "%s/forcing/ocean-classic", argv[1]);
    prefix(p, q, 1);
    snprintf(q, sizeof q, "%s/restart/restart.nc", argv[1]);
    restart_file(q);
    return 0;
}
