#include "util/fileio.h"

#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

void atomic_tmp_name(const char *final_path, char *tmp, size_t len)
{
    snprintf(tmp, len, "%s.tmp.%ld", final_path, (long)getpid());
}

static int fsync_path(const char *path, int dir)
{
    int fd = open(path, dir ? (O_RDONLY | O_DIRECTORY) : O_RDONLY);
    if (fd < 0)
        return -1;
    int rc = fsync(fd);
    close(fd);
    return rc;
}

int atomic_commit(const char *tmp_path, const char *final_path, sph_error *err)
{
    if (fsync_path(tmp_path, 0) != 0) {
        int e = errno;
        unlink(tmp_path);
        return sph_err_set(err, SPH_ERR_IO, "fsync %s: %s", tmp_path, strerror(e));
    }
    if (rename(tmp_path, final_path) != 0) {
        int e = errno;
        unlink(tmp_path);
        return sph_err_set(err, SPH_ERR_IO, "rename %s -> %s: %s", tmp_path, final_path,
                           strerror(e));
    }
    char dirbuf[4096];
    snprintf(dirbuf, sizeof dirbuf, "%s", final_path);
    (void)fsync_path(dirname(dirbuf), 1);
    return SPH_OK;
}

int atomic_write_file(const char *path, const void *data, size_t len, sph_error *err)
{
    char tmp[4096];
    atomic_tmp_name(path, tmp, sizeof tmp);
    FILE *f = fopen(tmp, "wb");
    if (!f)
        return sph_err_set(err, SPH_ERR_IO, "create %s: %s", tmp, strerror(errno));
    size_t n = fwrite(data, 1, len, f);
    int bad = n != len || fflush(f) != 0;
    int e = errno;
    if (fclose(f) != 0)
        bad = 1;
    if (bad) {
        unlink(tmp);
        return sph_err_set(err, SPH_ERR_IO, "write %s: %s", tmp, strerror(e));
    }
    return atomic_commit(tmp, path, err);
}

int atomic_symlink(const char *target, const char *link_path, sph_error *err)
{
    char tmp[4096];
    atomic_tmp_name(link_path, tmp, sizeof tmp);
    unlink(tmp);
    if (symlink(target, tmp) != 0)
        return sph_err_set(err, SPH_ERR_IO, "symlink %s: %s", tmp, strerror(errno));
    if (rename(tmp, link_path) != 0) {
        int e = errno;
        unlink(tmp);
        return sph_err_set(err, SPH_ERR_IO, "rename %s -> %s: %s", tmp, link_path, strerror(e));
    }
    return SPH_OK;
}

int mkdir_p(const char *path, sph_error *err)
{
    char buf[4096];
    snprintf(buf, sizeof buf, "%s", path);
    size_t n = strlen(buf);
    for (size_t i = 1; i <= n; i++) {
        if (buf[i] == '/' || buf[i] == '\0') {
            char c = buf[i];
            buf[i] = '\0';
            if (mkdir(buf, 0755) != 0 && errno != EEXIST)
                return sph_err_set(err, SPH_ERR_IO, "mkdir %s: %s", buf, strerror(errno));
            buf[i] = c;
        }
    }
    return SPH_OK;
}

int read_file(const char *path, char **data, size_t *len, sph_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return sph_err_set(err, SPH_ERR_IO, "open %s: %s", path, strerror(errno));
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    for (;;) {
        if (!buf) {
            fclose(f);
            return sph_err_set(err, SPH_ERR_NOMEM, "read %s: out of memory", path);
        }
        size_t r = fread(buf + n, 1, cap - n - 1, f);
        n += r;
        if (r == 0)
            break;
        if (cap - n - 1 == 0) {
            cap *= 2;
            char *nb = realloc(buf, cap);
            if (!nb)
                free(buf);
            buf = nb;
        }
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        return sph_err_set(err, SPH_ERR_IO, "read %s: I/O error", path);
    }
    buf[n] = '\0';
    *data = buf;
    if (len)
        *len = n;
    return SPH_OK;
}

static void to_hex(const unsigned char *md, unsigned n, char *hex)
{
    static const char digits[] = "0123456789abcdef";
    for (unsigned i = 0; i < n; i++) {
        hex[2 * i] = digits[md[i] >> 4];
        hex[2 * i + 1] = digits[md[i] & 15];
    }
    hex[2 * n] = '\0';
}

void sha256_hex(const void *data, size_t len, char hex[65])
{
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned n = 0;
    EVP_Digest(data, len, md, &n, EVP_sha256(), NULL);
    to_hex(md, n, hex);
}

int sha256_file(const char *path, char hex[65], sph_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return sph_err_set(err, SPH_ERR_IO, "open %s: %s", path, strerror(errno));
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    EVP_DigestInit_ex(ctx, EVP_sha256(), NULL);
    unsigned char buf[65536];
    size_t r;
    while ((r = fread(buf, 1, sizeof buf, f)) > 0)
        EVP_DigestUpdate(ctx, buf, r);
    int bad = ferror(f);
    fclose(f);
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned n = 0;
    EVP_DigestFinal_ex(ctx, md, &n);
    EVP_MD_CTX_free(ctx);
    if (bad)
        return sph_err_set(err, SPH_ERR_IO, "read %s: I/O error", path);
    to_hex(md, n, hex);
    return SPH_OK;
}

int fault_point(const char *point)
{
    const char *f = getenv("SPHICE_FAULT");
    return f && point && strcmp(f, point) == 0;
}
