/* STUB, TO BE DELETED BY THE LEAD WHEN THE REAL ENGINE (forecast.c) IS MERGED.
 * It only lets `sphice` link before the engine exists. */
#include "service/forecast.h"

int forecast_run(const struct sph_config *cfg, const forecast_request *req, forecast_progress *prog,
                 const volatile sig_atomic_t *cancel, forecast_result *res, sph_error *err)
{
    (void)cfg; (void)req; (void)prog; (void)cancel; (void)res;
    return sph_err_set(err, SPH_ERR_INTERNAL, "forecast: engine not built (forecast_stub.c)");
}
