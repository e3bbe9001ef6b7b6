/* Naming by cycle time (service/cycle_name.h). */
#include "service/cycle_name.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "service/schedule.h"
#include "util/timeutil.h"

int cycle_expand_template(const char *tmpl, double t, char *out, size_t len, sph_error *err)
{
    long secs = (long)llround(t);
    long days = (long)floor((double)secs / 86400.0);
    long sod = secs - days * 86400, y;
    int m, d;
    time_civil_from_days(days, &y, &m, &d);
    long doy = days - time_days_from_civil(y, 1, 1) + 1;
    size_t used = 0;
    for (const char *p = tmpl; *p; p++) {
        char piece[32];
        if (*p != '%') {
            piece[0] = *p;
            piece[1] = 0;
        } else {
            switch (*++p) {
            case 'Y': snprintf(piece, sizeof piece, "%04ld", y); break;
            case 'y': snprintf(piece, sizeof piece, "%02ld", ((y % 100) + 100) % 100); break;
            case 'm': snprintf(piece, sizeof piece, "%02d", m); break;
            case 'd': snprintf(piece, sizeof piece, "%02d", d); break;
            case 'H': snprintf(piece, sizeof piece, "%02ld", sod / 3600); break;
            case 'M': snprintf(piece, sizeof piece, "%02ld", sod / 60 % 60); break;
            case 'S': snprintf(piece, sizeof piece, "%02ld", sod % 60); break;
            case 'j': snprintf(piece, sizeof piece, "%03ld", doy); break;
            case '%': snprintf(piece, sizeof piece, "%%"); break;
            default:
                return sph_err_set(err, SPH_ERR_CONFIG,
                                   "template \"%s\": unsupported field %%%c (use %%Y %%m %%d %%H %%M %%S %%j %%y %%%%)",
                                   tmpl, *p ? *p : ' ');
            }
        }
        size_t n = strlen(piece);
        if (used + n >= len)
            return sph_err_set(err, SPH_ERR_CONFIG, "template \"%s\": expands beyond %zu characters", tmpl, len);
        memcpy(out + used, piece, n + 1);
        used += n;
    }
    if (len)
        out[used] = 0;
    return SPH_OK;
}

void cycle_restart_name(double t, char *buf, size_t len)
{
    char name[32];
    cycle_name(t, name, sizeof name);
    snprintf(buf, len, "restart-%s.nc", name);
}
