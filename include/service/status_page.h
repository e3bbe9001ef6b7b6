/* The status page of `sphice serve` (GET /) and the latest cycle's files
 * it shows (GET /latest/NAME).
 *
 * The page is one self-contained HTML document: inline CSS and a small
 * inline script, no external resource (no CDN, no web font, no remote
 * image). The script reads /status every 10 s and shows the service state,
 * the running cycle's progress, the last cycles of the history, the
 * forcing ages of the last run, the latest cycle's quick-look maps and its
 * ice edge (the GeoJSON drawn in an inline SVG).
 *
 * Files of the latest cycle are served only when all of these hold: the
 * name is a plain file name (letters, digits, '.', '_', '-'; not starting
 * with '.'; no '/'), it ends in .png or .geojson, OUT_DIR/latest/
 * manifest.json lists it, and OUT_DIR/latest/NAME is a regular file (not a
 * symbolic link) of at most STATUS_MAX_FILE bytes. Anything else is 404:
 * no path outside the latest cycle can be reached. */
#ifndef SPHICE_SERVICE_STATUS_PAGE_H
#define SPHICE_SERVICE_STATUS_PAGE_H

#include <stddef.h>

#include <cjson/cJSON.h>

#define STATUS_MAX_FILE (32u << 20)

/* The page (static text). */
const char *status_page_html(void);

/* {"cycle": ISO time or null, "quicklooks": ["/latest/NAME.png", ...],
 *  "edge": "/latest/NAME.geojson" or null} from OUT_DIR/latest/manifest.json
 * (all null/empty when there is no published cycle). */
cJSON *status_latest_json(const char *out_dir);

/* The bytes of the latest cycle's file NAME (see above), malloc'd, with
 * its length and content type; NULL when it is not served. */
char *status_latest_file(const char *out_dir, const char *name, size_t *len, const char **content_type);

#endif
