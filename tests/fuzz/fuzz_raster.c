/* libFuzzer harness: the initial ice raster reader (ice_raster_read) on a
 * file holding the input: ESRI ASCII grids and NetCDF (classic and
 * netCDF-4), chosen by content as in operation. The first byte of the
 * input picks whether a second copy of the grid is given as the ESRI
 * thickness grid. A successful read is sampled once at its centre. */
#include <math.h>

#include "io/raster.h"

#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_guard_setup();
    if (size < 1)
        return 0;
    int with_thick = data[0] & 1;
    const char *path = fuzz_file(0, data + 1, size - 1);
    ice_raster_options o;
    ice_raster_options_default(&o);
    if (with_thick)
        o.thickness_path = fuzz_file(1, data + 1, size - 1);
    ice_raster *r = NULL;
    sph_error err;
    sph_error_clear(&err);
    if (ice_raster_read(path, &o, &r, &err) == SPH_OK) {
        double c, h;
        ice_raster_sample(r, r->lon[r->nlon / 2], r->lat[r->nlat / 2], &c, &h);
        for (int j = 0; j < r->nlat; j++)
            (void)ice_raster_cell_area(r, j);
        ice_raster_free(r);
    }
    return 0;
}
