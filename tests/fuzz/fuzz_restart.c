/* libFuzzer harness: the restart reader. The input is a restart file;
 * its header is read, and when it is sane and small the particles are
 * read into a set sized from it (as the engine does before resuming). */
#include "io/restart.h"

#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_guard_setup();
    const char *path = fuzz_file(0, data, size);
    restart_header h;
    sph_error err;
    sph_error_clear(&err);
    if (restart_read_header(path, &h, &err) != SPH_OK)
        return 0;
    if (h.n > 100000 || h.nlayers < 0 || h.nlayers > 64)
        return 0; /* the engine sizes the model from the header; keep the fuzzer's memory small */
    sph_particles *P = sph_particles_create(h.n ? h.n : 1, h.nlayers);
    if (!P)
        return 0;
    restart_header r;
    sph_error_clear(&err);
    (void)restart_read(path, (data[size ? size - 1 : 0] & 1) ? NULL : "+proj=test", &r, P, &err);
    sph_particles_free(P);
    return 0;
}
