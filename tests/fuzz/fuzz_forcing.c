/* libFuzzer harness: the forcing reader. The input is a NetCDF file
 * opened as one source (atmosphere, ocean or tide: the first byte picks
 * the kind) over a small box in time and space, then sampled at a few
 * points and times. Every failure must be an error, never a crash. */
#include <math.h>

#include "io/forcing.h"

#include "fuzz.h"

/* the cycle and box of the seed files (tests/fuzz/gen_corpus.c, the engine
 * case: tests/engine_case.h), 1999-02-08T06:00Z */
#define T0 918453600.0

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_guard_setup();
    if (size < 1)
        return 0;
    const char *path = fuzz_file(0, data + 1, size - 1);
    const char *files[1] = {path};
    forcing_source_spec s = {0};
    s.name = "fuzz";
    s.kind = (forcing_kind)(data[0] % 3);
    s.files = files;
    s.nfiles = 1;
    forcing *f = NULL;
    sph_error err;
    sph_error_clear(&err);
    if (forcing_open(&f, &s, 1, T0, T0 + 3600, 121.0, 121.5, 40.0, 40.5, &err) != SPH_OK)
        return 0;
    enum { N = 4 };
    double lon[N] = {121.0, 121.2, 121.5, 121.37}, lat[N] = {40.0, 40.3, 40.5, 40.11};
    double a[17][N];
    forcing_sample out = {a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10],
                          a[11], a[12], a[13], a[14], a[15], a[16], 0};
    for (int k = 0; k < 3; k++) {
        sph_error_clear(&err);
        if (forcing_sample_at(f, T0 + 1800.0 * k, N, lon, lat, &out, &err) != SPH_OK)
            break;
    }
    forcing_var_info info[16];
    (void)forcing_describe(f, info, 16);
    forcing_close(f);
    return 0;
}
