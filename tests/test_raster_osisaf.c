/* OSI SAF / ESA CCI sea-ice concentration (OSI-450/430-b style) as the
 * initial raster (issue 19 item 2), in the shape their product user
 * guides give: ice_conc (time, yc, xc) in %, packed short with
 * scale_factor 0.01 and _FillValue -32767 (over land), grid_mapping
 * Lambert_Azimuthal_Grid (EASE2 north: lambert_azimuthal_equal_area at
 * (0 E, 90 N), WGS84), xc/yc in km, ancillary_variables naming
 * status_flag, whose flag_masks 1 2 4 8 16 32 64 128 mean "land lake
 * open_water_filtered land_spill_over high_t2m spatial_interp
 * temporal_interp max_ice_climo". Asserts: positions on Snyder's polar
 * LAEA formula (0.01 m), cell area dx dy (equal area), land and lake
 * bits taken as land (never open water), an open-water-filtered 0 kept
 * as open water, seeded area and volume within 1 % of the raster's. */
#include <unistd.h>

#include "raster_provider.h"

enum { NX = 30, NY = 24 };
static const double WA = 6378137.0, WRF = 298.257223563, D = 25000.0;
static const double X0 = 300e3 + 12500, Y0 = -1800e3 + 12500;

static int status_of(int i, int j) { return i < 2 ? 1 : (i == 10 && j == 5) ? 2 : (j < 3 ? 4 : 0); }
static double pct_of(int i, int j)
{
    if (status_of(i, j) & 3) return -1; /* fill */
    if (j < 3) return 0;
    return fmin(100, 20 + 3 * i + 1.5 * j);
}

int main(void)
{
    char dir[] = "/tmp/sphice-test-raster-osisaf-XXXXXX";
    CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    char path[512];
    snprintf(path, sizeof path, "%s/ice_conc_nh_ease2-250_cdr-v3p0_199902081200.nc", dir);
    int ncid, d[3], vx, vy, vt, vc, vs, gm;
    CHECK(nc_create(path, NC_CLOBBER | NC_NETCDF4, &ncid) == NC_NOERR, "create");
    nc_def_dim(ncid, "time", 1, &d[0]);
    nc_def_dim(ncid, "yc", NY, &d[1]);
    nc_def_dim(ncid, "xc", NX, &d[2]);
    nc_def_var(ncid, "time", NC_DOUBLE, 1, &d[0], &vt);
    rp_text(ncid, vt, "units", "seconds since 1978-01-01 00:00:00");
    nc_def_var(ncid, "xc", NC_DOUBLE, 1, &d[2], &vx);
    rp_text(ncid, vx, "standard_name", "projection_x_coordinate");
    rp_text(ncid, vx, "units", "km");
    nc_def_var(ncid, "yc", NC_DOUBLE, 1, &d[1], &vy);
    rp_text(ncid, vy, "standard_name", "projection_y_coordinate");
    rp_text(ncid, vy, "units", "km");
    nc_def_var(ncid, "Lambert_Azimuthal_Grid", NC_INT, 0, NULL, &gm);
    rp_text(ncid, gm, "grid_mapping_name", "lambert_azimuthal_equal_area");
    rp_num(ncid, gm, "longitude_of_projection_origin", 0);
    rp_num(ncid, gm, "latitude_of_projection_origin", 90);
    rp_num(ncid, gm, "false_easting", 0);
    rp_num(ncid, gm, "false_northing", 0);
    rp_num(ncid, gm, "semi_major_axis", WA);
    rp_num(ncid, gm, "inverse_flattening", WRF);
    rp_text(ncid, gm, "proj4_string", "+proj=laea +lon_0=0 +datum=WGS84 +ellps=WGS84 +lat_0=90.0");
    nc_def_var(ncid, "ice_conc", NC_SHORT, 3, d, &vc);
    rp_text(ncid, vc, "standard_name", "sea_ice_area_fraction");
    rp_text(ncid, vc, "units", "%");
    rp_text(ncid, vc, "grid_mapping", "Lambert_Azimuthal_Grid");
    rp_text(ncid, vc, "ancillary_variables", "total_standard_error status_flag");
    rp_num(ncid, vc, "scale_factor", 0.01);
    short fill = -32767;
    nc_put_att_short(ncid, vc, "_FillValue", NC_SHORT, 1, &fill);
    nc_def_var(ncid, "status_flag", NC_SHORT, 3, d, &vs);
    rp_text(ncid, vs, "standard_name", "sea_ice_area_fraction status_flag");
    short masks[8] = {1, 2, 4, 8, 16, 32, 64, 128};
    nc_put_att_short(ncid, vs, "flag_masks", NC_SHORT, 8, masks);
    rp_text(ncid, vs, "flag_meanings", "land lake open_water_filtered land_spill_over high_t2m "
                                       "spatial_interp temporal_interp max_ice_climo");
    rp_text(ncid, vs, "grid_mapping", "Lambert_Azimuthal_Grid");
    nc_enddef(ncid);
    double t = 6.64e8, xs[NX], ys[NY];
    nc_put_var_double(ncid, vt, &t);
    for (int i = 0; i < NX; i++)
        xs[i] = (X0 + i * D) / 1000;
    for (int j = 0; j < NY; j++)
        ys[j] = (Y0 + j * D) / 1000;
    nc_put_var_double(ncid, vx, xs);
    nc_put_var_double(ncid, vy, ys);
    static short c[NY * NX], s[NY * NX];
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            double p = pct_of(i, j);
            c[j * NX + i] = p < 0 ? fill : (short)lround(p * 100);
            s[j * NX + i] = (short)status_of(i, j);
        }
    nc_put_var_short(ncid, vc, c);
    nc_put_var_short(ncid, vs, s);
    nc_close(ncid);

    ice_raster_options o;
    ice_raster_options_default(&o);
    o.default_thickness = 0.6;
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    CHECK(ice_raster_read(path, &o, &r, &err) == SPH_OK && r, "read: %s", err.msg);
    if (r) {
        double worst = 0, worst_area = 0, want_area = 0, want_vol = 0;
        int bad = 0;
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                double lon, lat, x, y;
                ice_raster_cell_lonlat(r, i, j, &lon, &lat);
                rp_laea_forward(WA, WRF, 0, lon, lat, &x, &y);
                worst = fmax(worst, fmax(fabs(x - (X0 + i * D)), fabs(y - (Y0 + j * D))));
                worst_area = fmax(worst_area, fabs(ice_raster_area(r, i, j) / (D * D) - 1));
                size_t k = (size_t)j * NX + i;
                int land = (status_of(i, j) & 3) != 0;
                int got = r->land ? r->land[k] : 0;
                if (land != (got == 1) || (land && !isnan(r->conc[k])) ||
                    (!land && fabs(r->conc[k] - pct_of(i, j) / 100) > 1e-9))
                    bad++;
                if (!land && pct_of(i, j) / 100 > 0.05) {
                    want_area += pct_of(i, j) / 100 * D * D;
                    want_vol += pct_of(i, j) / 100 * 0.6 * D * D;
                }
            }
        CHECK(worst < 0.01, "cell centres off the LAEA formula by %g m", worst);
        CHECK(worst_area < 1e-6, "equal-area cells off dx dy by %g", worst_area);
        CHECK(bad == 0 && r->nland == (size_t)(2 * NY + 1),
              "%d cells with wrong land/concentration; %zu land cells (want %d)", bad, r->nland,
              2 * NY + 1);
        rp_check_seeded("OSI SAF EASE2", r, want_area, want_vol, 0.05);
    }
    ice_raster_free(r);
    unlink(path);
    rmdir(dir);
    return check_summary("test_raster_osisaf");
}
