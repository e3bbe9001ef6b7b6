/* CF grid mappings as PROJ definitions: see io/cf_mapping.h. */
#include "io/cf_mapping.h"

#include <math.h>
#include <netcdf.h>
#include <proj.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

static int text_att(int ncid, int varid, const char *att, char *buf, size_t len)
{
    size_t n;
    nc_type t;
    if (nc_inq_att(ncid, varid, att, &t, &n) != NC_NOERR || t != NC_CHAR || n >= len ||
        nc_get_att_text(ncid, varid, att, buf) != NC_NOERR)
        return 0;
    buf[n] = '\0';
    return 1;
}

int cf_att_num(int ncid, int varid, const char *att, double *v, size_t *n, size_t max)
{
    size_t len;
    if (nc_inq_attlen(ncid, varid, att, &len) != NC_NOERR || len < 1 || len > max)
        return 0;
    nc_type t;
    nc_inq_atttype(ncid, varid, att, &t);
    if (t == NC_CHAR || t == NC_STRING)
        return 0;
    if (nc_get_att_double(ncid, varid, att, v) != NC_NOERR)
        return 0;
    if (n)
        *n = len;
    return 1;
}

/* The figure of the earth as PROJ parameters; 0 when the mapping gives none. */
static int ellipsoid(int ncid, int gm, char *ell, size_t len)
{
    double a = NAN, b = NAN, rf = NAN, R = NAN;
    cf_att_num(ncid, gm, "semi_major_axis", &a, NULL, 1);
    cf_att_num(ncid, gm, "semi_minor_axis", &b, NULL, 1);
    cf_att_num(ncid, gm, "inverse_flattening", &rf, NULL, 1);
    cf_att_num(ncid, gm, "earth_radius", &R, NULL, 1);
    if (a > 0 && b > 0)
        snprintf(ell, len, "+a=%.17g +b=%.17g", a, b);
    else if (a > 0 && rf > 0)
        snprintf(ell, len, "+a=%.17g +rf=%.17g", a, rf);
    else if (a > 0 && rf == 0)
        snprintf(ell, len, "+R=%.17g", a);
    else if (R > 0)
        snprintf(ell, len, "+R=%.17g", R);
    else
        return 0;
    return 1;
}

int cf_mapping_proj(int ncid, int gm, char *def, size_t len, char *why, size_t wlen)
{
    static const char *const text_atts[] = {"crs_wkt", "spatial_ref", "proj4", "proj4text",
                                            "proj4_params", "proj4string", "proj4_string", NULL};
    for (const char *const *a = text_atts; *a; a++)
        if (text_att(ncid, gm, *a, def, len) && def[0])
            return 0;
    char code[256];
    static const char *const epsg_atts[] = {"epsg_code", "EPSG", "epsg", "srid", NULL};
    for (const char *const *a = epsg_atts; *a; a++) {
        double v;
        const char *digits = NULL;
        if (text_att(ncid, gm, *a, code, sizeof code)) {
            digits = strrchr(code, ':');
            digits = digits ? digits + 1 : code;
        } else if (cf_att_num(ncid, gm, *a, &v, NULL, 1) && v > 0 && v < 1e6) {
            snprintf(code, sizeof code, "%.0f", v);
            digits = code;
        }
        if (digits && *digits && strspn(digits, "0123456789") == strlen(digits)) {
            snprintf(def, len, "EPSG:%s", digits);
            return 0;
        }
    }
    char name[128];
    if (!text_att(ncid, gm, "grid_mapping_name", name, sizeof name)) {
        snprintf(why, wlen, "has no grid_mapping_name, crs_wkt, proj4 or EPSG code");
        return -1;
    }
    char ell[160];
    if (!ellipsoid(ncid, gm, ell, sizeof ell)) {
        snprintf(why, wlen, "(%s) gives no ellipsoid (semi_major_axis with semi_minor_axis or "
                 "inverse_flattening, or earth_radius)", name);
        return -1;
    }
    double fe = 0, fn = 0, lat0 = NAN, lon0 = NAN, k0 = NAN, sp[2] = {NAN, NAN};
    size_t nsp = 0;
    cf_att_num(ncid, gm, "false_easting", &fe, NULL, 1);
    cf_att_num(ncid, gm, "false_northing", &fn, NULL, 1);
    cf_att_num(ncid, gm, "latitude_of_projection_origin", &lat0, NULL, 1);
    cf_att_num(ncid, gm, "standard_parallel", sp, &nsp, 2);
    const char *missing = NULL;
    char body[512];
    if (strcmp(name, "polar_stereographic") == 0) {
        cf_att_num(ncid, gm, "straight_vertical_longitude_from_pole", &lon0, NULL, 1);
        cf_att_num(ncid, gm, "scale_factor_at_projection_origin", &k0, NULL, 1);
        if (!isfinite(lon0))
            missing = "straight_vertical_longitude_from_pole";
        else if (!(fabs(lat0) == 90))
            missing = "latitude_of_projection_origin (+90 or -90)";
        else if (nsp == 1 && isfinite(sp[0]))
            snprintf(body, sizeof body, "+proj=stere +lat_0=%.17g +lat_ts=%.17g +lon_0=%.17g",
                     lat0, sp[0], lon0);
        else if (k0 > 0)
            snprintf(body, sizeof body, "+proj=stere +lat_0=%.17g +k_0=%.17g +lon_0=%.17g",
                     lat0, k0, lon0);
        else
            missing = "standard_parallel or scale_factor_at_projection_origin";
    } else if (strcmp(name, "stereographic") == 0 ||
               strcmp(name, "lambert_azimuthal_equal_area") == 0) {
        int stere = name[0] == 's';
        cf_att_num(ncid, gm, "longitude_of_projection_origin", &lon0, NULL, 1);
        cf_att_num(ncid, gm, "scale_factor_at_projection_origin", &k0, NULL, 1);
        if (!isfinite(lon0))
            missing = "longitude_of_projection_origin";
        else if (!isfinite(lat0))
            missing = "latitude_of_projection_origin";
        else if (stere && !(k0 > 0))
            missing = "scale_factor_at_projection_origin";
        else if (stere)
            snprintf(body, sizeof body, "+proj=stere +lat_0=%.17g +lon_0=%.17g +k_0=%.17g", lat0,
                     lon0, k0);
        else
            snprintf(body, sizeof body, "+proj=laea +lat_0=%.17g +lon_0=%.17g", lat0, lon0);
    } else if (strcmp(name, "lambert_conformal_conic") == 0) {
        cf_att_num(ncid, gm, "longitude_of_central_meridian", &lon0, NULL, 1);
        if (!isfinite(lon0))
            missing = "longitude_of_central_meridian";
        else if (!isfinite(lat0))
            missing = "latitude_of_projection_origin";
        else if (nsp < 1 || !isfinite(sp[0]))
            missing = "standard_parallel";
        else
            snprintf(body, sizeof body, "+proj=lcc +lat_1=%.17g +lat_2=%.17g +lat_0=%.17g "
                     "+lon_0=%.17g", sp[0], nsp == 2 ? sp[1] : sp[0], lat0, lon0);
    } else if (strcmp(name, "transverse_mercator") == 0) {
        cf_att_num(ncid, gm, "longitude_of_central_meridian", &lon0, NULL, 1);
        cf_att_num(ncid, gm, "scale_factor_at_central_meridian", &k0, NULL, 1);
        if (!isfinite(lon0))
            missing = "longitude_of_central_meridian";
        else if (!isfinite(lat0))
            missing = "latitude_of_projection_origin";
        else if (!(k0 > 0))
            missing = "scale_factor_at_central_meridian";
        else
            snprintf(body, sizeof body, "+proj=tmerc +lat_0=%.17g +lon_0=%.17g +k_0=%.17g", lat0,
                     lon0, k0);
    } else {
        snprintf(why, wlen, ": grid_mapping_name \"%s\" not supported (polar_stereographic, "
                 "stereographic, lambert_conformal_conic, lambert_azimuthal_equal_area, "
                 "transverse_mercator, or a crs_wkt / proj4 / EPSG attribute)", name);
        return -1;
    }
    if (missing) {
        snprintf(why, wlen, "(%s) lacks %s", name, missing);
        return -1;
    }
    snprintf(def, len, "%s +x_0=%.17g +y_0=%.17g %s +units=m +no_defs", body, fe, fn, ell);
    return 0;
}

#define CFM_D2R (M_PI / 180.0)

static void cfm_unit(double lon, double lat, double *u)
{
    u[0] = cos(lat * CFM_D2R) * cos(lon * CFM_D2R);
    u[1] = cos(lat * CFM_D2R) * sin(lon * CFM_D2R);
    u[2] = sin(lat * CFM_D2R);
}

int cf_rotated_pole_read(int ncid, int gm, cf_rotated_pole *rp, char *why, size_t wlen)
{
    double plat = NAN, plon = NAN;
    rp->l0 = 0.0;
    cf_att_num(ncid, gm, "grid_north_pole_latitude", &plat, NULL, 1);
    cf_att_num(ncid, gm, "grid_north_pole_longitude", &plon, NULL, 1);
    cf_att_num(ncid, gm, "north_pole_grid_longitude", &rp->l0, NULL, 1);
    if (!isfinite(plat) || !isfinite(plon) || fabs(plat) > 90.0 || !isfinite(rp->l0)) {
        snprintf(why, wlen, "(rotated_latitude_longitude) lacks grid_north_pole_latitude or "
                 "grid_north_pole_longitude");
        return -1;
    }
    /* the rotated pole; the rotated origin on the great circle through both
     * poles, 90 degrees from it, beyond the true pole */
    cfm_unit(plon, plat, rp->ez);
    cfm_unit(plon + 180.0, 90.0 - plat, rp->ex);
    rp->ey[0] = rp->ez[1] * rp->ex[2] - rp->ez[2] * rp->ex[1];
    rp->ey[1] = rp->ez[2] * rp->ex[0] - rp->ez[0] * rp->ex[2];
    rp->ey[2] = rp->ez[0] * rp->ex[1] - rp->ez[1] * rp->ex[0];
    return 0;
}

void cf_rotated_to_geo(const cf_rotated_pole *rp, double rlon, double rlat, double *lon, double *lat,
                       double *angle)
{
    double rl = (rlon - rp->l0) * CFM_D2R, rf = rlat * CFM_D2R;
    double a = cos(rf) * cos(rl), b = cos(rf) * sin(rl), c = sin(rf), g[3], t[3];
    for (int q = 0; q < 3; q++) {
        g[q] = a * rp->ex[q] + b * rp->ey[q] + c * rp->ez[q];
        t[q] = -sin(rl) * rp->ex[q] + cos(rl) * rp->ey[q]; /* rotated east */
    }
    double la = atan2(g[2], hypot(g[0], g[1])), lo = atan2(g[1], g[0]);
    *lat = la / CFM_D2R;
    *lon = lo / CFM_D2R;
    if (angle) {
        double e = -sin(lo) * t[0] + cos(lo) * t[1];
        double n = -sin(la) * cos(lo) * t[0] - sin(la) * sin(lo) * t[1] + cos(la) * t[2];
        *angle = atan2(n, e);
    }
}

double cf_rotated_angle_at(const cf_rotated_pole *rp, double lon, double lat)
{
    double g[3], a, b, glon, glat;
    cfm_unit(lon, lat, g);
    double rx = g[0] * rp->ex[0] + g[1] * rp->ex[1] + g[2] * rp->ex[2];
    double ry = g[0] * rp->ey[0] + g[1] * rp->ey[1] + g[2] * rp->ey[2];
    double rz = g[0] * rp->ez[0] + g[1] * rp->ez[1] + g[2] * rp->ez[2];
    a = atan2(ry, rx) / CFM_D2R + rp->l0;
    b = atan2(rz, hypot(rx, ry)) / CFM_D2R;
    double angle;
    cf_rotated_to_geo(rp, a, b, &glon, &glat, &angle);
    return angle;
}

int cf_mapping_proj_text(char *def, size_t len)
{
    if (strstr(def, "+proj=") || strncasecmp(def, "EPSG:", 5) == 0)
        return 0;
    PJ_CONTEXT *ctx = proj_context_create();
    if (!ctx)
        return -1;
    proj_log_level(ctx, PJ_LOG_NONE);
    PJ *P = proj_create(ctx, def);
    const char *s = P && proj_get_type(P) == PJ_TYPE_PROJECTED_CRS ? proj_as_proj_string(ctx, P, PJ_PROJ_4, NULL)
                                                                    : NULL;
    int rc = s && strlen(s) < len ? 0 : -1;
    if (rc == 0)
        snprintf(def, len, "%s", s);
    proj_destroy(P);
    proj_context_destroy(ctx);
    return rc;
}
