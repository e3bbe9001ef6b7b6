/* Publishing a completed stage directory (see products_publish in
 * io/products.h). The order makes a crash at any point safe: the stage is
 * checked first (nothing changed if incomplete), the directory rename is
 * atomic, and `latest` switches only after the new directory is in place,
 * so `latest` always points at a complete product set. */
#define _XOPEN_SOURCE 700
#include "products_impl.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <libgen.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "util/fileio.h"
#include "util/jsonutil.h"
#include "util/log.h"

static int check_manifest(const char *stage, sph_error *err)
{
    char path[PROD_PATH];
    snprintf(path, sizeof path, "%s/manifest.json", stage);
    char *text = NULL;
    struct stat sb;
    if (stat(path, &sb) != 0)
        return sph_err_set(err, SPH_ERR_IO,
                           "publish %s: no manifest.json (products incomplete); not published",
                           stage);
    int rc = read_file(path, &text, NULL, err);
    if (rc != SPH_OK)
        return rc;
    cJSON *m = cJSON_Parse(text);
    free(text);
    cJSON *complete = m ? cJSON_GetObjectItem(m, "complete") : NULL;
    cJSON *files = m ? cJSON_GetObjectItem(m, "files") : NULL;
    if (!cJSON_IsTrue(complete) || !cJSON_IsArray(files)) {
        cJSON_Delete(m);
        return sph_err_set(err, SPH_ERR_BAD_DATA, "publish %s: manifest.json is not complete",
                           stage);
    }
    cJSON *f;
    cJSON_ArrayForEach(f, files) {
        cJSON *name = cJSON_GetObjectItem(f, "name"), *bytes = cJSON_GetObjectItem(f, "bytes");
        if (!cJSON_IsString(name) || !cJSON_IsNumber(bytes) || strchr(name->valuestring, '/')) {
            rc = sph_err_set(err, SPH_ERR_BAD_DATA, "publish %s: bad entry in manifest.json", stage);
            break;
        }
        char fp[PROD_PATH];
        snprintf(fp, sizeof fp, "%s/%s", stage, name->valuestring);
        if (stat(fp, &sb) != 0 || (double)sb.st_size != bytes->valuedouble) {
            rc = sph_err_set(err, SPH_ERR_BAD_DATA,
                             "publish %s: %s missing or of the wrong size; not published", stage,
                             name->valuestring);
            break;
        }
    }
    cJSON_Delete(m);
    return rc;
}

int products_manifest_add(const char *stage_dir, const char *const *names, sph_error *err)
{
    char path[PROD_PATH];
    snprintf(path, sizeof path, "%s/manifest.json", stage_dir);
    int rc = SPH_OK;
    cJSON *m = json_read_file(path, err);
    if (!m)
        return err ? err->code : SPH_ERR_BAD_DATA;
    cJSON *files = cJSON_GetObjectItem(m, "files");
    if (!cJSON_IsArray(files)) {
        cJSON_Delete(m);
        return sph_err_set(err, SPH_ERR_BAD_DATA, "manifest %s: no file list", path);
    }
    for (const char *const *n = names; n && *n && rc == SPH_OK; n++) {
        int listed = 0;
        cJSON *f;
        cJSON_ArrayForEach(f, files) {
            const char *have = cJSON_GetStringValue(cJSON_GetObjectItem(f, "name"));
            listed |= have && !strcmp(have, *n);
        }
        if (listed)
            continue;
        char fp[PROD_PATH], hex[65];
        struct stat sb;
        snprintf(fp, sizeof fp, "%s/%s", stage_dir, *n);
        if (!**n || strchr(*n, '/') || stat(fp, &sb) != 0 || !S_ISREG(sb.st_mode)) {
            rc = sph_err_set(err, SPH_ERR_IO, "manifest %s: %s is not a file of the stage", path, *n);
            break;
        }
        if ((rc = sha256_file(fp, hex, err)) != SPH_OK)
            break;
        f = cJSON_CreateObject();
        cJSON_AddItemToArray(files, f);
        cJSON_AddStringToObject(f, "name", *n);
        cJSON_AddNumberToObject(f, "bytes", (double)sb.st_size);
        cJSON_AddStringToObject(f, "sha256", hex);
    }
    if (rc != SPH_OK) {
        cJSON_Delete(m);
        return rc;
    }
    return prod_write_json(path, m, err);
}

static int rm_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb;
    (void)flag;
    (void)ftw;
    return remove(path);
}

static void fsync_dir_of(const char *path)
{
    char buf[PROD_PATH];
    snprintf(buf, sizeof buf, "%s", path);
    int fd = open(dirname(buf), O_RDONLY | O_DIRECTORY);
    if (fd >= 0) {
        (void)fsync(fd);
        close(fd);
    }
}

int products_publish(const char *stage_dir, const char *final_dir, const char *latest_link,
                     sph_error *err)
{
    if (!stage_dir || !final_dir)
        return sph_err_set(err, SPH_ERR_PARAM, "publish: missing directory");
    int rc = check_manifest(stage_dir, err);
    if (rc != SPH_OK)
        return rc;
    char old[PROD_PATH] = "";
    struct stat sb;
    if (lstat(final_dir, &sb) == 0) {
        snprintf(old, sizeof old, "%s.old.%ld", final_dir, (long)getpid());
        if (rename(final_dir, old) != 0)
            return sph_err_set(err, SPH_ERR_IO, "publish: move aside %s: %s", final_dir,
                               strerror(errno));
    }
    if (rename(stage_dir, final_dir) != 0) {
        int e = errno;
        if (old[0] && rename(old, final_dir) != 0)
            log_error("publish: could not restore %s from %s: %s", final_dir, old, strerror(errno));
        return sph_err_set(err, SPH_ERR_IO, "publish: rename %s -> %s: %s", stage_dir, final_dir,
                           strerror(e));
    }
    fsync_dir_of(final_dir);
    if (old[0] && nftw(old, rm_entry, 16, FTW_DEPTH | FTW_PHYS) != 0)
        log_warn("publish: could not remove the replaced %s: %s", old, strerror(errno));
    if (!latest_link)
        return SPH_OK;
    /* relative target when the link sits beside the directory */
    char a[PROD_PATH], b[PROD_PATH], c[PROD_PATH];
    snprintf(a, sizeof a, "%s", final_dir);
    snprintf(b, sizeof b, "%s", latest_link);
    snprintf(c, sizeof c, "%s", final_dir);
    const char *target = strcmp(dirname(a), dirname(b)) == 0 ? basename(c) : final_dir;
    rc = atomic_symlink(target, latest_link, err);
    if (rc == SPH_OK)
        fsync_dir_of(latest_link);
    return rc;
}
