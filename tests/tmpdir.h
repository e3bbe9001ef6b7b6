/* A test's scratch folder: the files directly in it, then the folder. */
#ifndef SPHICE_TESTS_TMPDIR_H
#define SPHICE_TESTS_TMPDIR_H

#include <dirent.h>
#include <stdio.h>
#include <unistd.h>

static inline void tmpdir_remove(const char *dir)
{
    DIR *dd = opendir(dir);
    for (struct dirent *de = dd ? readdir(dd) : NULL; de; de = readdir(dd)) {
        char f[1024];
        snprintf(f, sizeof f, "%s/%s", dir, de->d_name);
        if (de->d_name[0] != '.')
            unlink(f);
    }
    if (dd)
        closedir(dd);
    rmdir(dir);
}

#endif
