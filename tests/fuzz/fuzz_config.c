/* libFuzzer harness: the configuration parser (sph_config_parse) on any
 * text. It must return an error or a configuration, never crash. */
#include <string.h>

#include "service/config.h"

#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *text = malloc(size + 1);
    if (!text)
        return 0;
    memcpy(text, data, size);
    text[size] = '\0';
    struct sph_config *c = NULL;
    sph_error err;
    sph_error_clear(&err);
    if (sph_config_parse(text, "<fuzz>", &c, &err) == SPH_OK)
        sph_config_free(c);
    free(text);
    return 0;
}
