/* Checks the committed Liaodong Bay 1999 demo scene (forcing/liaodong-1999)
 * against the properties the seed paper documents (PHYSICS.md section 6)
 * and against geography, reading the files with the netCDF API only.
 *
 * Expected values come from outside the generator: the seed's patch
 * (35 cm, about 100 km^2, inside the box 121.75-121.89 E, 40.55-40.69 N,
 * surrounded by ice under 10 cm), the winter monsoon of the scene (from N
 * to NNE, the patch drifting south-west), a thaw at the end (melt is
 * reported), the M2 speed 28.9841042 deg/h (a reversing tide: about 15.5
 * reversals in 96 h), and places known to be land or sea. Cell areas are
 * recomputed here on the sphere (R = 6371 km).
 *
 * SPHICE_DEMO_DIR overrides the folder (default: forcing/liaodong-1999,
 * relative to the repository root where `make check` runs). */
#include <cjson/cJSON.h>
#include <math.h>
#include <netcdf.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "io/landmask.h"
#include "util/fileio.h"
#include "util/timeutil.h"

#define R_EARTH_KM 6371.0
#define D2R (M_PI / 180.0)

static char dir[1024];

static int open_nc(const char *name, int *ncid)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    int st = nc_open(path, NC_NOWRITE, ncid);
    CHECK(st == NC_NOERR, "open %s: %s", path, nc_strerror(st));
    return st == NC_NOERR ? 0 : -1;
}

/* Text attribute into buf ("" if absent). */
static void att_text(int ncid, int varid, const char *name, char *buf, size_t len)
{
    size_t n = 0;
    buf[0] = '\0';
    nc_type t;
    if (nc_inq_att(ncid, varid, name, &t, &n) != NC_NOERR || t != NC_CHAR || n + 1 > len)
        return;
    if (nc_get_att_text(ncid, varid, name, buf) == NC_NOERR)
        buf[n] = '\0';
    else
        buf[0] = '\0';
}

/* Variables for which CF has no standard name (tidal phases and current
 * amplitudes of the "harmonic-1" format): they need long_name instead. */
static int cf_has_no_name(const char *var)
{
    static const char *const exempt[] = {"h_phase", "u_amp", "u_phase", "v_amp", "v_phase"};
    for (size_t i = 0; i < sizeof exempt / sizeof *exempt; i++)
        if (strcmp(var, exempt[i]) == 0)
            return 1;
    return 0;
}

/* Global attributes and per-variable units/standard_name. */
static void check_metadata(const char *file, int ncid)
{
    char buf[4096];
    att_text(ncid, NC_GLOBAL, "source", buf, sizeof buf);
    CHECK(strstr(buf, "synthetic") != NULL, "%s: global source \"%s\" does not say synthetic",
          file, buf);
    att_text(ncid, NC_GLOBAL, "Conventions", buf, sizeof buf);
    CHECK(strcmp(buf, "CF-1.8") == 0, "%s: Conventions \"%s\"", file, buf);
    static const char *const globals[] = {"title", "comment", "history", "references",
                                          "sphice_generator"};
    for (size_t i = 0; i < sizeof globals / sizeof *globals; i++) {
        att_text(ncid, NC_GLOBAL, globals[i], buf, sizeof buf);
        CHECK(buf[0] != '\0', "%s: global attribute %s missing", file, globals[i]);
    }
    att_text(ncid, NC_GLOBAL, "references", buf, sizeof buf);
    CHECK(strstr(buf, "Liaodong") != NULL, "%s: references do not cite the seed paper", file);

    int nvars;
    nc_inq_nvars(ncid, &nvars);
    for (int v = 0; v < nvars; v++) {
        char name[NC_MAX_NAME + 1];
        nc_type t;
        nc_inq_varname(ncid, v, name);
        nc_inq_vartype(ncid, v, &t);
        if (t == NC_CHAR)
            continue; /* constituent names: not a quantity */
        att_text(ncid, v, "units", buf, sizeof buf);
        CHECK(buf[0] != '\0', "%s: %s has no units", file, name);
        att_text(ncid, v, "standard_name", buf, sizeof buf);
        if (cf_has_no_name(name)) {
            att_text(ncid, v, "long_name", buf, sizeof buf);
            CHECK(buf[0] != '\0', "%s: %s has neither standard_name nor long_name", file, name);
        } else {
            CHECK(buf[0] != '\0', "%s: %s has no standard_name", file, name);
        }
    }
}

/* A 1-D double coordinate; returns its length (0 on failure). */
static size_t read_coord(int ncid, const char *name, double **out)
{
    int varid, dimid;
    size_t n = 0;
    *out = NULL;
    if (nc_inq_varid(ncid, name, &varid) != NC_NOERR || nc_inq_vardimid(ncid, varid, &dimid) ||
        nc_inq_dimlen(ncid, dimid, &n) || n == 0)
        return 0;
    *out = malloc(n * sizeof **out);
    if (!*out || nc_get_var_double(ncid, varid, *out) != NC_NOERR) {
        free(*out);
        *out = NULL;
        return 0;
    }
    return n;
}

static float *read_float(int ncid, const char *name, size_t n, float *fill)
{
    int varid;
    if (nc_inq_varid(ncid, name, &varid) != NC_NOERR)
        return NULL;
    float *p = malloc(n * sizeof *p);
    if (!p || nc_get_var_float(ncid, varid, p) != NC_NOERR) {
        free(p);
        return NULL;
    }
    if (fill && nc_get_att_float(ncid, varid, "_FillValue", fill) != NC_NOERR)
        *fill = NC_FILL_FLOAT;
    return p;
}

static size_t nearest(const double *x, size_t n, double v)
{
    size_t best = 0;
    for (size_t i = 1; i < n; i++)
        if (fabs(x[i] - v) < fabs(x[best] - v))
            best = i;
    return best;
}

/* Land mask, kept for the ice and tide checks. */
static double *mlon, *mlat;
static size_t mnlon, mnlat;
static signed char *mask;

static int land_at(double lon, double lat)
{
    return mask[nearest(mlat, mnlat, lat) * mnlon + nearest(mlon, mnlon, lon)];
}

static void check_landmask(void)
{
    int ncid;
    if (open_nc("landmask_liaodong.nc", &ncid))
        return;
    check_metadata("landmask", ncid);
    mnlon = read_coord(ncid, "lon", &mlon);
    mnlat = read_coord(ncid, "lat", &mlat);
    int varid = -1;
    CHECK(nc_inq_varid(ncid, "land_binary_mask", &varid) == NC_NOERR, "no land_binary_mask");
    CHECK(mnlon > 1 && mnlat > 1, "landmask coordinates");
    if (varid < 0 || mnlon < 2 || mnlat < 2) {
        nc_close(ncid);
        return;
    }
    CHECK_CLOSE(mlon[1] - mlon[0], 0.01, 0, 1e-9, "mask lon step");
    CHECK_CLOSE(mlat[1] - mlat[0], 0.01, 0, 1e-9, "mask lat step");
    /* The domain contains the bay head and reaches south past 40.0 N. */
    CHECK(mlon[0] <= 121.0 && mlon[mnlon - 1] >= 122.4, "mask lon %g..%g", mlon[0],
          mlon[mnlon - 1]);
    CHECK(mlat[0] < 40.0 && mlat[mnlat - 1] >= 41.0, "mask lat %g..%g", mlat[0],
          mlat[mnlat - 1]);
    mask = malloc(mnlon * mnlat);
    CHECK(mask && nc_get_var_schar(ncid, varid, mask) == NC_NOERR, "read land_binary_mask");
    nc_close(ncid);
    size_t nland = 0, nbad = 0;
    for (size_t k = 0; k < mnlon * mnlat; k++) {
        nbad += mask[k] != 0 && mask[k] != 1;
        nland += mask[k] == 1;
    }
    CHECK(nbad == 0, "%zu mask values other than 0 and 1", nbad);
    /* Both land and sea, the sea a large share (the bay). */
    CHECK(nland > mnlon * mnlat / 5 && nland < mnlon * mnlat * 4 / 5, "land share %zu of %zu",
          nland, mnlon * mnlat);
    static const struct {
        const char *name;
        double lon, lat;
        int land;
    } places[] = {
        {"JZ20-2 area", 121.37, 40.47, 0}, {"JZ9-3 area", 121.55, 40.77, 0},
        {"mid-bay", 121.50, 40.30, 0},     {"patch centre", 121.82, 40.62, 0},
        {"Yingkou", 122.23, 40.67, 1},     {"Jinzhou", 121.13, 41.10, 1},
    };
    for (size_t i = 0; i < sizeof places / sizeof *places; i++)
        CHECK(land_at(places[i].lon, places[i].lat) == places[i].land, "%s (%.2f E %.2f N) is %s",
              places[i].name, places[i].lon, places[i].lat, places[i].land ? "sea" : "land");
}

/* Peer check: io/landmask rasterises the same GSHHG file independently
 * (scan lines from the SW node, where the generator casts rays from the
 * four corners). Known difference: when a cell centre lies exactly on a
 * 2-degree bin border (the 40.00 N row, depending on rounding of the grid
 * origin), io/landmask may classify the 121.90-121.99 E coast as sea where
 * both neighbouring bins say land; so allow 0.1 % of cells to differ. */
static void check_landmask_peer(void)
{
    const char *gshhg = landmask_gshhg_default_path();
    if (!mask || !gshhg) {
        printf("  landmask peer check skipped (no GSHHG file)\n");
        return;
    }
    sph_error err;
    sph_error_clear(&err);
    double d = mlon[1] - mlon[0];
    landmask_grid g = {mlon[0] - 0.5 * d, mlon[mnlon - 1] + 0.5 * d, mlat[0] - 0.5 * d,
                       mlat[mnlat - 1] + 0.5 * d, d};
    landmask *m = landmask_create_gshhg(gshhg, &g, &err);
    CHECK(m != NULL, "io/landmask: %s", err.msg);
    if (!m)
        return;
    size_t differ = 0;
    for (size_t j = 0; j < mnlat; j++)
        for (size_t i = 0; i < mnlon; i++)
            differ += landmask_is_land(m, mlon[i], mlat[j]) != mask[j * mnlon + i];
    printf("  landmask: %zu of %zu cells differ from io/landmask\n", differ, mnlon * mnlat);
    CHECK(differ <= mnlon * mnlat / 1000, "%zu cells differ from io/landmask's rasterisation",
          differ);
    landmask_free(m);
}

static void check_ice(void)
{
    int ncid;
    if (!mask || open_nc("ice_19990208T06.nc", &ncid))
        return;
    check_metadata("ice", ncid);
    double *lon, *lat, *t;
    size_t nlon = read_coord(ncid, "lon", &lon), nlat = read_coord(ncid, "lat", &lat);
    size_t nt = read_coord(ncid, "time", &t);
    CHECK(nt == 1, "ice: %zu times", nt);
    CHECK(nlon == mnlon && nlat == mnlat, "ice grid %zux%zu differs from the mask's", nlon, nlat);
    /* 1999-02-08 06:00 at UTC+8 is 1999-02-07T22:00Z. */
    char units[256];
    int tv;
    double base, want;
    nc_inq_varid(ncid, "time", &tv);
    att_text(ncid, tv, "units", units, sizeof units);
    CHECK(strncmp(units, "hours since ", 12) == 0 && time_parse_iso(units + 12, &base) == 0,
          "ice time units \"%s\"", units);
    time_parse_iso("1999-02-07T22:00:00Z", &want);
    if (nt == 1)
        CHECK_CLOSE(base + 3600.0 * t[0], want, 0, 1.0, "ice valid time");
    size_t n = nlon * nlat;
    float cfill, hfill;
    float *c = read_float(ncid, "siconc", n, &cfill), *h = read_float(ncid, "sithick", n, &hfill);
    nc_close(ncid);
    CHECK(c && h, "ice: siconc/sithick not readable");
    if (!c || !h || nlon != mnlon || nlat != mnlat) {
        free(c); free(h); free(lon); free(lat); free(t);
        return;
    }
    double dlon = (lon[nlon - 1] - lon[0]) / (double)(nlon - 1);
    double dlat = (lat[nlat - 1] - lat[0]) / (double)(nlat - 1);
    double parea = 0.0, phsum = 0.0, hmax_out = 0.0, cnorth = 0.0;
    size_t npatch = 0, outside_box = 0, ice_on_land = 0, fill_on_sea = 0, bad_range = 0;
    size_t ice_south = 0, nnorth = 0;
    for (size_t j = 0; j < nlat; j++)
        for (size_t i = 0; i < nlon; i++) {
            size_t k = j * nlon + i;
            int cf = c[k] == cfill, hf = h[k] == hfill;
            if (mask[k]) {
                ice_on_land += !((cf || c[k] == 0.0f) && (hf || h[k] == 0.0f));
                continue;
            }
            if (cf || hf) {
                fill_on_sea++;
                continue;
            }
            bad_range += c[k] < 0.0f || c[k] > 1.0f || h[k] < 0.0f || (h[k] > 0) != (c[k] > 0);
            if (lat[j] < 40.25)
                ice_south += c[k] > 0.0f;
            if (h[k] > 0.2f) {
                double a = R_EARTH_KM * R_EARTH_KM * dlon * D2R *
                           (sin((lat[j] + 0.5 * dlat) * D2R) - sin((lat[j] - 0.5 * dlat) * D2R));
                parea += a;
                phsum += a * h[k];
                npatch++;
                outside_box += lon[i] < 121.75 - 1e-9 || lon[i] > 121.89 + 1e-9 ||
                               lat[j] < 40.55 - 1e-9 || lat[j] > 40.69 + 1e-9;
            } else {
                if (h[k] > hmax_out)
                    hmax_out = h[k];
                if (lat[j] > 40.5) {
                    cnorth += c[k];
                    nnorth++;
                }
            }
        }
    CHECK(npatch > 0, "no thick patch");
    printf("  patch: %zu cells, %.2f km^2, mean %.4f m; surrounding ice up to %.3f m\n", npatch,
           parea, npatch ? phsum / parea : 0.0, hmax_out);
    if (npatch > 0) {
        CHECK_CLOSE(phsum / parea, 0.35, 0, 0.02, "patch mean thickness (m)");
        CHECK_CLOSE(parea, 100.0, 0.20, 0, "patch area (km^2)");
    }
    CHECK(outside_box == 0, "%zu patch cells outside the seed's box", outside_box);
    CHECK(hmax_out > 0.0 && hmax_out < 0.10, "surrounding ice up to %.3f m (want < 0.10)",
          hmax_out);
    CHECK(ice_on_land == 0, "%zu land cells carry ice", ice_on_land);
    CHECK(fill_on_sea == 0, "%zu sea cells are _FillValue", fill_on_sea);
    CHECK(bad_range == 0, "%zu cells out of range or inconsistent", bad_range);
    CHECK(ice_south == 0, "%zu cells south of 40.25 N carry ice (open water expected)", ice_south);
    if (nnorth) {
        double cm = cnorth / (double)nnorth;
        CHECK(cm >= 0.5 && cm <= 0.9, "thin-ice concentration north of 40.5 N %.3f", cm);
    }
    free(c); free(h); free(lon); free(lat); free(t);
}

static void check_atmos(void)
{
    int ncid;
    if (open_nc("atmos_199902.nc", &ncid))
        return;
    check_metadata("atmos", ncid);
    double *lon, *lat, *t;
    size_t nlon = read_coord(ncid, "lon", &lon), nlat = read_coord(ncid, "lat", &lat);
    size_t nt = read_coord(ncid, "time", &t);
    CHECK(nt > 0 && nlon > 1 && nlat > 1, "atmos coordinates");
    if (!(nt > 0 && nlon > 1 && nlat > 1)) {
        nc_close(ncid);
        return;
    }
    /* Scene 22..118 h since 1999-02-07 00Z, with 3 h of margin each side,
     * and the grid covering the domain. */
    CHECK(t[0] <= 19.0 + 1e-9 && t[nt - 1] >= 121.0 - 1e-9, "atmos time %g..%g h", t[0],
          t[nt - 1]);
    CHECK(lon[0] <= 120.8 && lon[nlon - 1] >= 122.6 && lat[0] <= 39.6 && lat[nlat - 1] >= 41.1,
          "atmos grid does not cover the domain");
    size_t n = nlon * nlat * nt, nxy = nlon * nlat;
    float *u = read_float(ncid, "u10", n, NULL), *v = read_float(ncid, "v10", n, NULL);
    float *ta = read_float(ncid, "t2m", n, NULL), *td = read_float(ncid, "d2m", n, NULL);
    float *sw = read_float(ncid, "ssrd", n, NULL), *lw = read_float(ncid, "strd", n, NULL);
    nc_close(ncid);
    CHECK(u && v && ta && td && sw && lw, "atmos variables not readable");
    if (u && v && ta && td && sw && lw) {
        size_t bad_speed = 0, bad_dew = 0, bad_lw = 0;
        for (size_t k = 0; k < n; k++) {
            double s = hypot(u[k], v[k]);
            bad_speed += !(s >= 0.0 && s <= 12.0);
            bad_dew += !(td[k] <= ta[k] + 1e-3);
            /* Clear to cloudy skies: 0.6..1.0 of the black body at air temperature. */
            double bb = 5.670374419e-8 * pow(ta[k], 4.0);
            bad_lw += !(lw[k] >= 0.6 * bb && lw[k] <= 1.0 * bb);
        }
        CHECK(bad_speed == 0, "%zu wind speeds outside 0..12 m/s", bad_speed);
        CHECK(bad_dew == 0, "%zu dew points above air temperature", bad_dew);
        CHECK(bad_lw == 0, "%zu longwave values outside 0.6..1.0 sigma T^4", bad_lw);

        /* At the JZ20-2 platform (the seed's wind and temperature record). */
        size_t p = nearest(lat, nlat, 40.47) * nlon + nearest(lon, nlon, 121.37);
        double um = 0, vm = 0, tfirst = 0, tlast = 0, tmax_last = -1e9;
        int hours = 0, below = 0, nfirst = 0, nlast = 0;
        double sw_night = 0, sw_noon = 0;
        for (size_t q = 0; q < nt; q++) {
            if (t[q] < 22.0 - 1e-9 || t[q] >= 118.0 - 1e-9)
                continue;
            size_t k = q * nxy + p;
            hours++;
            um += u[k];
            vm += v[k];
            below += ta[k] < 273.15f;
            if (t[q] < 22.0 + 72.0 - 1e-9) {
                tfirst += ta[k];
                nfirst++;
            } else {
                tlast += ta[k];
                nlast++;
                if (ta[k] > tmax_last)
                    tmax_last = ta[k];
            }
            /* Local (UTC+8) midnight and noon. */
            double local = fmod(t[q] + 8.0, 24.0);
            if (fabs(local) < 1e-6)
                sw_night += sw[k];
            if (fabs(local - 12.0) < 1e-6)
                sw_noon = sw[k];
        }
        CHECK(hours == 96, "atmos: %d hourly records in the scene (want 96)", hours);
        um /= hours;
        vm /= hours;
        /* Direction the mean wind blows towards, degrees clockwise from north. */
        double towards = fmod(atan2(um, vm) / D2R + 360.0, 360.0);
        printf("  JZ20-2 wind: mean towards %.1f deg at %.2f m/s; %d of %d h below 0 C; "
               "T first 72 h %.2f K, last 24 h %.2f K (max %.2f K)\n",
               towards, hypot(um, vm), below, hours, tfirst / nfirst, tlast / nlast, tmax_last);
        CHECK(towards > 180.0 && towards < 270.0,
              "mean wind blows towards %.1f deg (want the south-west quadrant)", towards);
        CHECK((double)below >= 0.75 * hours, "only %d of %d hours below 0 C", below, hours);
        if (nfirst && nlast)
            CHECK(tlast / nlast > tfirst / nfirst + 2.0,
                  "no warming: last 24 h mean %.2f K vs first 72 h %.2f K", tlast / nlast,
                  tfirst / nfirst);
        CHECK(tmax_last > 273.15, "no thaw in the last 24 h (max %.2f K)", tmax_last);
        CHECK(sw_night == 0.0, "shortwave at local midnight %.1f", sw_night);
        /* Noon at 40.5 N in mid-February: cos(zenith) ~ 0.57, so 1000 W m-2
         * times cloud factors 0.4..0.8 gives roughly 230..460 W m-2. */
        CHECK(sw_noon > 150.0 && sw_noon < 500.0, "noon shortwave %.1f W m-2", sw_noon);
    }
    free(u); free(v); free(ta); free(td); free(sw); free(lw);
    free(lon); free(lat); free(t);
}

static void check_tide(void)
{
    int ncid;
    if (open_nc("tide_bohai_harmonic.nc", &ncid))
        return;
    check_metadata("tide", ncid);
    char fmt[64];
    att_text(ncid, NC_GLOBAL, "sphice_tide_format", fmt, sizeof fmt);
    CHECK(strcmp(fmt, "harmonic-1") == 0, "tide format \"%s\"", fmt);
    int dimc, dims, vc;
    size_t ncons = 0, slen = 0;
    CHECK(nc_inq_dimid(ncid, "constituent", &dimc) == NC_NOERR &&
              nc_inq_dimlen(ncid, dimc, &ncons) == NC_NOERR && ncons == 4,
          "constituent dimension (%zu)", ncons);
    CHECK(nc_inq_dimid(ncid, "name_strlen", &dims) == NC_NOERR &&
              nc_inq_dimlen(ncid, dims, &slen) == NC_NOERR && slen >= 2 && slen <= 16,
          "name_strlen dimension");
    char names[4][17];
    int im2 = -1;
    memset(names, 0, sizeof names);
    if (ncons == 4 && slen >= 2 && slen <= 16 && nc_inq_varid(ncid, "constituent", &vc) == 0) {
        char raw[4 * 16];
        CHECK(nc_get_var_text(ncid, vc, raw) == NC_NOERR, "read constituent names");
        static const char *const want[] = {"m2", "s2", "k1", "o1"};
        for (int c = 0; c < 4; c++) {
            memcpy(names[c], raw + c * slen, slen);
            for (int e = (int)slen - 1; e >= 0 && (names[c][e] == ' ' || names[c][e] == 0); e--)
                names[c][e] = '\0';
            if (strcmp(names[c], "m2") == 0)
                im2 = c;
        }
        for (int w = 0; w < 4; w++) {
            int found = 0;
            for (int c = 0; c < 4; c++)
                found |= strcmp(names[c], want[w]) == 0;
            CHECK(found, "constituent %s missing", want[w]);
        }
    }
    double *lon, *lat;
    size_t nlon = read_coord(ncid, "lon", &lon), nlat = read_coord(ncid, "lat", &lat);
    size_t nxy = nlon * nlat, n = nxy * 4;
    float fill;
    float *ha = read_float(ncid, "h_amp", n, &fill), *ua = read_float(ncid, "u_amp", n, NULL);
    float *up = read_float(ncid, "u_phase", n, NULL), *va = read_float(ncid, "v_amp", n, NULL);
    float *vp = read_float(ncid, "v_phase", n, NULL), *hp = read_float(ncid, "h_phase", n, NULL);
    nc_close(ncid);
    CHECK(ha && ua && up && va && vp && hp && nlon > 1 && nlat > 1, "tide variables");
    if (ha && ua && up && va && vp && hp && im2 >= 0 && nlon > 1 && nlat > 1) {
        /* Land is _FillValue, sea is not (where the mask says so). */
        size_t bad_fill = 0;
        if (mask)
            for (size_t j = 0; j < nlat; j++)
                for (size_t i = 0; i < nlon; i++)
                    bad_fill += (ha[j * nlon + i] == fill) != land_at(lon[i], lat[j]);
        CHECK(bad_fill == 0, "%zu tide points where _FillValue and land disagree", bad_fill);

        /* M2 along the bay axis (bearing 35 deg) at the patch centre. */
        size_t k = (size_t)im2 * nxy + nearest(lat, nlat, 40.62) * nlon + nearest(lon, nlon, 121.82);
        CHECK(ha[k] != fill, "no tide at the patch centre");
        const double omega = 28.9841042 * D2R; /* rad per hour */
        const double ex = sin(35.0 * D2R), ey = cos(35.0 * D2R);
        int changes = 0;
        double prev = 0.0, amax = 0.0;
        for (int s = 0; s <= 960; s++) {
            double th = 0.1 * s;
            double ue = ua[k] * cos(omega * th - up[k] * D2R);
            double vn = va[k] * cos(omega * th - vp[k] * D2R);
            double along = ue * ex + vn * ey;
            if (s > 0 && (along > 0) != (prev > 0))
                changes++;
            prev = along;
            if (fabs(along) > amax)
                amax = fabs(along);
        }
        printf("  M2 at patch centre: along-axis %.3f m/s, %d sign changes in 96 h, "
               "elevation %.3f m\n", amax, changes, ha[k]);
        CHECK(changes >= 14, "M2 along-axis current changes sign %d times in 96 h", changes);
        CHECK(amax >= 0.4 && amax <= 0.8, "M2 along-axis current amplitude %.3f m/s", amax);
        /* Big tides in the bay (Yingkou range 2.5-3 m): M2 amplitude about 1 m. */
        CHECK(ha[k] >= 0.9 && ha[k] <= 1.4, "M2 elevation amplitude %.3f m", ha[k]);
        /* Amplitude grows towards the head (40.9 N, 121.7 E) from the mouth (40.0 N, 121.2 E). */
        size_t kh = (size_t)im2 * nxy + nearest(lat, nlat, 40.85) * nlon + nearest(lon, nlon, 121.6);
        size_t km = (size_t)im2 * nxy + nearest(lat, nlat, 40.0) * nlon + nearest(lon, nlon, 121.2);
        if (ha[kh] != fill && ha[km] != fill)
            CHECK(ha[kh] > ha[km], "M2 amplitude head %.3f <= mouth %.3f", ha[kh], ha[km]);
    }
    free(ha); free(ua); free(up); free(va); free(vp); free(hp);
    free(lon); free(lat);
}

static void check_stations(void)
{
    char path[2048], *text = NULL;
    size_t len;
    sph_error err;
    sph_error_clear(&err);
    snprintf(path, sizeof path, "%s/stations.json", dir);
    CHECK(read_file(path, &text, &len, &err) == 0, "%s", err.msg);
    if (!text)
        return;
    cJSON *root = cJSON_Parse(text);
    CHECK(root != NULL, "stations.json does not parse");
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(root, "stations");
    int found = 0;
    const cJSON *s;
    cJSON_ArrayForEach(s, st) {
        const cJSON *nm = cJSON_GetObjectItemCaseSensitive(s, "name");
        const cJSON *lo = cJSON_GetObjectItemCaseSensitive(s, "lon");
        const cJSON *la = cJSON_GetObjectItemCaseSensitive(s, "lat");
        if (cJSON_IsString(nm) && cJSON_IsNumber(lo) && cJSON_IsNumber(la) &&
            strcmp(nm->valuestring, "JZ20-2") == 0) {
            found = 1;
            CHECK_CLOSE(lo->valuedouble, 121.37, 0, 0.05, "JZ20-2 lon");
            CHECK_CLOSE(la->valuedouble, 40.47, 0, 0.05, "JZ20-2 lat");
            if (mask)
                CHECK(!land_at(lo->valuedouble, la->valuedouble), "JZ20-2 on land");
        }
    }
    CHECK(found, "stations.json has no JZ20-2");
    const cJSON *edge = cJSON_GetObjectItemCaseSensitive(root, "edge_reference");
    CHECK(cJSON_IsNumber(cJSON_GetObjectItemCaseSensitive(edge, "lon")) &&
              cJSON_IsNumber(cJSON_GetObjectItemCaseSensitive(edge, "lat")),
          "stations.json edge_reference lon/lat");
    cJSON_Delete(root);
    free(text);
}

int main(void)
{
    const char *d = getenv("SPHICE_DEMO_DIR");
    snprintf(dir, sizeof dir, "%s", d ? d : "forcing/liaodong-1999");
    check_landmask();
    check_landmask_peer();
    check_ice();
    check_atmos();
    check_tide();
    check_stations();
    free(mask);
    free(mlon);
    free(mlat);
    return check_summary("test_demo_forcing");
}
