/* GIS products of the writer (io/gis.h): class polygons and edge at the
 * map times (GeoJSON, GeoPackage) and the fields as Cloud-Optimised
 * GeoTIFF at each map time. */
#include "products_impl.h"

#include <stdio.h>

#include "io/gis.h"
#include "util/log.h"

int prod_gis_add(prod_writer *p, double t, const char *stamp, const edge_set *e, sph_error *err)
{
    if (!p->gis && !(p->gis = gis_store_new()))
        return sph_err_set(err, SPH_ERR_NOMEM, "products: out of memory");
    int rc = gis_store_add(p->gis, &p->grid, p->masked[PF_VAR_CONC], p->land, e, p->opts.edge_threshold, t,
                           err);
    if (rc != SPH_OK)
        return rc;
    char name[PROD_NAME_LEN], path[PROD_PATH];
    snprintf(name, sizeof name, "%s_fields_%s.tif", p->prefix, stamp);
    snprintf(path, sizeof path, "%s/%s", p->stage, name);
    const double *bands[5] = { p->masked[PF_VAR_CONC], p->masked[PF_VAR_THICK], p->masked[PF_VAR_HBAR],
                               p->masked[PF_VAR_U], p->masked[PF_VAR_V] };
    const char *names[5] = { "siconc", "sithick", "sivol", "siu", "siv" };
    const char *units[5] = { "1", "m", "m", "m s-1", "m s-1" };
    if ((rc = gis_write_cog(path, &p->grid, 5, bands, names, units, err)) == SPH_OK)
        prod_add_product(p, name);
    return rc;
}

int prod_gis_close(prod_writer *p, sph_error *err)
{
    if (!p->gis)
        return SPH_OK;
    char name[PROD_NAME_LEN], path[PROD_PATH];
    snprintf(name, sizeof name, "%s_ice_classes.geojson", p->prefix);
    snprintf(path, sizeof path, "%s/%s", p->stage, name);
    int rc = gis_write_classes_geojson(p->gis, path, err);
    if (rc != SPH_OK)
        return rc;
    prod_add_product(p, name);
    snprintf(name, sizeof name, "%s_gis.gpkg", p->prefix);
    snprintf(path, sizeof path, "%s/%s", p->stage, name);
    if ((rc = gis_write_gpkg(p->gis, path, p->cycle_time, err)) == SPH_OK)
        prod_add_product(p, name);
    return rc;
}
